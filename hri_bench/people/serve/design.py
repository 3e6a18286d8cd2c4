"""What a web session is: the server's settings and each participant's counterbalanced design.

:class:`ServeConfig` holds what whoever starts ``hri-bench serve`` chooses (never the
browser): the scenario, the robot agent, the number of episodes, the texts, where the data
goes. :func:`assignment` gives participant ``i`` (in the order they joined) their episodes
and, optionally, the preference they are asked to follow:

* **Intentions** are counterbalanced over the ordered (start, goal) pairs of the scenario's
  supports. The pairs are put in one Eulerian circuit of the complete directed graph of the
  supports (for the hanger A→B, B→C, C→A, A→C, C→B, B→A), so that every episode starts
  where the last one ended, as in the paper's user study; participant ``i`` begins at
  position ``i`` of the circuit. Over ``K (K - 1)`` consecutive participants every pair
  comes equally often at every episode position (a Latin square).
* **Preferences** (``preferences``): participant ``i`` is asked to follow
  ``preferences[i mod n]``.
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.config import default_config
from hri_bench.data.datasets import check_dataset_id
from hri_bench.people.serve.access import check_host_name
from hri_bench.run.agents import validate_agent_name
from hri_envs.checks import check_flag, check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.scenarios import SCENARIOS, NamedScenario, ScenarioSpec

__all__ = ["DEFAULT_CONSENT", "DEFAULT_INSTRUCTIONS", "LEAD_CONSENT", "LEAD_INSTRUCTIONS",
           "UNSUITED_AGENTS", "Assignment",
           "ServeConfig", "assignment", "describe_preference", "pair_circuit"]

#: Agents that cannot face a person: they copy or plan for a scripted human's policy (the
#: oracle, the exact references ``informed`` and ``blind``, and ``qmdp``, which reads each
#: run's human model).
UNSUITED_AGENTS = ("oracle", "informed", "blind", "qmdp")
#: The most sessions at once (each has a thread and a robot).
MAX_SESSIONS = 1000

DEFAULT_CONSENT = """\
This is a study of how a robot learns to cooperate with a person. You will carry an object
together with a simulated robot, a few times, by choosing your actions with the keyboard.

We record what you and the robot do in each step (the actions, the object's positions, the
robot's estimate of your goal) and how long you take to choose, under a random anonymous
code. We record nothing else about you: no name, no address, no browser details.

Taking part is voluntary; you may stop at any time by closing this page. Recorded episodes
are kept under the anonymous code, which is shown at the end.
"""

DEFAULT_INSTRUCTIONS = """\
You and the robot carry the {object} between its supports ({supports}). Each episode you are
given a goal: bring the {object} there and leave it resting on it (let go).

In each step the picture shows the robot arm, your arm, the supports and the {object}; your
goal is marked green, and the text under the picture says where the {object} is and who
holds it. The robot chooses its action at the same time as you; it does not know your goal
and learns from what you do. You are in control: when you both hold the {object}, it moves
your way.

Choose an action with its number key (or click it). When an episode is over, press Enter for
the next one.
"""


#: The consent text of the physical tasks (``physical=True``).
LEAD_CONSENT = """\
This is a study of how a robot learns to cooperate with a person. You will carry an object
together with a simulated robot arm, a few times, by leading a simulated arm's hand with your
mouse, your finger or the keyboard.

We record what you and the robot do in each step (where you lead the hand, the forces, the
object's and the robot's motion, the robot's estimate of your goal) and when, under a random
anonymous code. We record nothing else about you: no name, no address, no browser details.

Taking part is voluntary; you may stop at any time by closing this page. Recorded episodes
are kept under the anonymous code, which is shown at the end.
"""

#: The instructions of the physical tasks (``physical=True``).
LEAD_INSTRUCTIONS = """\
You and the robot arm hold the {object} together; it rests on one of its supports
({supports}). Each episode you are given a goal, marked green: carry the {object} there with
the robot and put it on, so that it rests there.

You lead your arm's hand: the orange ball is where you pull it to. Drag in the picture with
the mouse or a finger to move the ball up, down, left and right; hold Shift while dragging,
or use the buttons, to move it nearer or farther; turn the {object} with the turn buttons.
Keys: arrows (left, right, up, down), W and S (farther, nearer), Q and E (turn). Your hand
follows the ball as a real arm would, and the red arrow shows the force your hand puts on
the handle. The robot feels that force through its wrist; it does not know your goal.
"""


@dataclass(frozen=True)
class ServeConfig(NamedScenario):
    """The settings of ``hri-bench serve`` (docs/people.md).

    Attributes:
        scenario: "hanger" or "wheel".
        agent: The robot: any agent name ``hri-bench study`` accepts (the Learner by
            default; ``sb3:PATH``, ``module:Class``) except :data:`UNSUITED_AGENTS`.
        episodes: Episodes per session.
        dataset: The dataset id the sessions are recorded in (default
            ``<scenario>-people-v0``).
        data: The datasets' root folder (None: :func:`hri_bench.data.datasets.data_root`).
        host: Address to bind; 127.0.0.1 (this machine only) unless told otherwise.
        port: TCP port (0: any free one).
        allowed_hosts: Names (``NAME`` or ``NAME:PORT``) the server answers to besides the
            address it listens on, e.g. the machine's name or a TLS proxy's
            (:mod:`hri_bench.people.serve.access`).
        seed: Base seed; participant ``i``'s robot draws from ``(seed, i)``.
        max_steps: Step limit per episode.
        r0: The robot's waiting reward (None: the scenario's).
        reward: The reward variant.
        preferences: Preferences participants are asked to follow, counterbalanced (empty:
            none is asked for).
        instructions: Instructions shown beside the task (``{object}`` and ``{supports}``
            are filled in).
        consent: The consent text shown before a session starts (``{object}`` and
            ``{supports}`` are filled in).
        show_belief: Show the robot's belief about the goal during play.
        max_sessions: The most sessions running at once.
        idle_timeout_s: A session whose participant does nothing this long is closed (one
            nobody has played yet, after 30 s without a connected page:
            :data:`~hri_bench.people.serve.session.CLAIM_TIMEOUT_S`).
        agent_timeout_s: The longest one call of the robot's agent may take (making it,
            an ``act``, its learning after an episode), and never longer than
            ``idle_timeout_s``; a longer one ends the session (``failed``), as an agent
            that raises or exits does.
        learner: Changes to the Learner's configuration, as (name, value) pairs.
        physical: Serve the continuous physical task (the participant leads the simulated
            arm's hand; ``agent`` names a physical robot,
            :mod:`hri_bench.core.physical_robots`) instead of the task graph.
        synthetic: The sessions are scripted humans' driving the page's input protocol
            (:mod:`hri_bench.people.synthetic`), recorded in a synthetic dataset; never set
            for people.
        population: With ``synthetic`` (physical only): the physical population whose
            members' bodies and arms take the human's seat (session ``i``'s human is its
            member of run ``i``, :meth:`~hri_envs.physics.carry.human.population.PhysicalPopulation.
            member_index`); people take the default body.
        max_time_s: The physical task's time limit per episode [s] (None: the env's, 30 s
            hanger, 45 s wheel).
    """

    scenario: str = "hanger"
    agent: str = "learner"
    episodes: int = 8
    dataset: str | None = None
    data: Path | None = None
    host: str = "127.0.0.1"
    port: int = 8000
    allowed_hosts: tuple[str, ...] = ()
    seed: int = 0
    max_steps: int = 60
    r0: float | None = None
    reward: str = "paper"
    preferences: tuple[str, ...] = ()
    instructions: str = DEFAULT_INSTRUCTIONS
    consent: str = DEFAULT_CONSENT
    show_belief: bool = False
    max_sessions: int = 50
    idle_timeout_s: float = 1800.0
    agent_timeout_s: float = 60.0
    learner: tuple[tuple[str, Any], ...] = field(default_factory=tuple)
    physical: bool = False
    synthetic: bool = False
    population: str | None = None
    max_time_s: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.scenario, str) or self.scenario not in SCENARIOS:
            raise ConfigError(f"scenario must be one of {', '.join(SCENARIOS)}, got "
                              f"{self.scenario!r}", field="scenario")
        if not isinstance(self.agent, str):
            raise ConfigError(f"agent must be an agent's name, got {self.agent!r}",
                              field="agent")
        check_flag(self.physical, "physical")
        check_flag(self.synthetic, "synthetic")
        if self.physical:
            self._check_physical()
        else:
            if self.synthetic or self.population is not None:
                raise ConfigError("synthetic sessions through the page and their population "
                                  "are for the physical tasks (hri-bench dataset record "
                                  "records the graph's)", field="synthetic")
            if self.max_time_s is not None:
                raise ConfigError("a time limit is the physical tasks' (--physical); a graph "
                                  "task's episodes end at --max-steps", field="max_time_s")
            try:
                validate_agent_name(self.agent)
            except ConfigError as exc:
                raise ConfigError(str(exc), field="agent") from None
            if self.agent in UNSUITED_AGENTS:
                raise ConfigError(f"agent {self.agent!r} copies or plans for a scripted "
                                  "human's policy and cannot face a person; give another "
                                  "(e.g. learner)", field="agent")
        check_whole(self.episodes, "episodes", minimum=1, maximum=1000)
        check_whole(self.seed, "seed", minimum=0)
        check_whole(self.port, "port", minimum=0, maximum=65535)
        check_whole(self.max_steps, "max_steps", minimum=1, maximum=10_000)
        check_whole(self.max_sessions, "max_sessions", minimum=1, maximum=MAX_SESSIONS)
        check_real(self.idle_timeout_s, "idle_timeout_s", low=1.0, high=7 * 86400.0,
                   allowed="a number of seconds in [1, 604800]")
        check_real(self.agent_timeout_s, "agent_timeout_s", low=0.1, high=86400.0,
                   allowed="a number of seconds in [0.1, 86400]")
        if self.r0 is not None:
            check_real(self.r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True,
                       allowed="None or a number in (-1, 0)")
        if self.reward not in REWARD_RULES:
            raise ConfigError(f"reward must be one of {', '.join(REWARD_RULES)}, got "
                              f"{self.reward!r}", field="reward")
        if not isinstance(self.host, str) or not self.host or any(c.isspace()
                                                                  for c in self.host):
            raise ConfigError(f"host must be an address to bind, got {self.host!r}",
                              field="host")
        if not isinstance(self.allowed_hosts, tuple) or len(self.allowed_hosts) > 100:
            raise ConfigError("allowed_hosts must be a tuple of at most 100 host names",
                              field="allowed_hosts")
        for name in self.allowed_hosts:
            try:
                check_host_name(name)
            except ValueError:
                raise ConfigError(f"allowed_hosts: expected a host name or address, "
                                  f"optionally with ':PORT' (IPv6 in brackets), got "
                                  f"{name!r}", field="allowed_hosts") from None
        allowed = self.spec.preferences
        bad = [p for p in self.preferences if p not in allowed]
        if bad or not isinstance(self.preferences, tuple):
            raise ConfigError(f"preferences must be of the {self.scenario}'s: "
                              f"{', '.join(allowed[:4])}{', ...' if len(allowed) > 4 else ''} "
                              f"(or 'all'); got {', '.join(map(str, bad))}",
                              field="preferences")
        for name in ("instructions", "consent"):
            text = getattr(self, name)
            if not isinstance(text, str) or not text.strip() or len(text) > 100_000:
                raise ConfigError(f"{name} must be a non-empty text of at most 100,000 "
                                  "characters", field=name)
        check_flag(self.show_belief, "show_belief")
        check_dataset_id(self.dataset_id)
        if self.learner:
            default_config(self.spec, **dict(self.learner))

    def _check_physical(self) -> None:
        """A physical robot; the physical texts by default; a population only for
        synthetic sessions.
        """
        from hri_bench.core.physical_robots import check_robot  # noqa: PLC0415

        check_robot(self.agent)
        if self.learner:
            raise ConfigError("learner settings are the graph Learner's; the physical robots "
                              "take none", field="learner")
        if self.consent == DEFAULT_CONSENT:
            object.__setattr__(self, "consent", LEAD_CONSENT)
        if self.instructions == DEFAULT_INSTRUCTIONS:
            object.__setattr__(self, "instructions", LEAD_INSTRUCTIONS)
        if self.max_time_s is not None:
            check_real(self.max_time_s, "max_time_s", low=1.0, high=3600.0,
                       allowed="None or a number of seconds in [1, 3600]")
        if self.population is not None:
            if not self.synthetic:
                raise ConfigError("a population takes the human's seat in synthetic sessions "
                                  "only; people take the default body", field="population")
            from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

            physical_population(self.population, self.graph)

    @property
    def dataset_id(self) -> str:
        """The dataset the sessions go to."""
        if self.dataset:
            return self.dataset
        kind = ("-physical" if self.physical else "") + (
            "-synthetic" if self.synthetic else "-people")
        return f"{self.scenario}{kind}-v0"

    @property
    def waiting_reward(self) -> float:
        """r0 after defaults."""
        return self.spec.r0 if self.r0 is None else self.r0

    @property
    def local_only(self) -> bool:
        """Whether the server is reachable from this machine only."""
        return self.host in ("127.0.0.1", "localhost", "::1") or self.host.startswith("127.")

    def text_hashes(self) -> dict[str, str]:
        """sha256 of the consent and instruction texts (recorded with each session)."""
        return {f"{k}_sha256": hashlib.sha256(getattr(self, k).encode()).hexdigest()
                for k in ("consent", "instructions")}

    def public(self) -> dict[str, Any]:
        """What the page may know: texts, the task's names, episodes; nothing of the server."""
        graph = self.graph
        obj = graph.scenario.object_name
        supports = ", ".join(graph.support_names)

        def fill(text: str) -> str:
            return text.replace("{object}", obj).replace("{supports}", supports)

        return {"scenario": self.scenario, "object": obj, "supports": list(graph.support_names),
                "episodes": self.episodes, "consent": fill(self.consent),
                "instructions": fill(self.instructions), "physical": self.physical}

    def settings(self) -> dict[str, Any]:
        """The settings recorded with each session (texts by their hash)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
               if f.name not in ("instructions", "consent", "data", "host", "port",
                                 "allowed_hosts")}
        out["preferences"] = list(self.preferences)
        out["learner"] = [list(p) for p in self.learner]
        out["idle_timeout_s"] = float(self.idle_timeout_s)
        out["agent_timeout_s"] = float(self.agent_timeout_s)
        return {**out, **self.text_hashes()}


def pair_circuit(n_supports: int) -> list[tuple[int, int]]:
    """Every ordered pair (start, goal ≠ start) once, each starting where the last ended
    (an Eulerian circuit of the complete directed graph, by Hierholzer's algorithm).
    """
    todo = {k: [g for g in reversed(range(n_supports)) if g != k] for k in range(n_supports)}
    stack, path = [0], []
    while stack:
        v = stack[-1]
        if todo[v]:
            stack.append(todo[v].pop())
        else:
            path.append(stack.pop())
    path.reverse()
    return list(zip(path[:-1], path[1:], strict=True))


@dataclass(frozen=True)
class Assignment:
    """A participant's design.

    Attributes:
        index: The participant's row of the design (join order, from 0).
        pairs: (start, goal) per episode.
        preference: The preference they are asked to follow, or None.
    """

    index: int
    pairs: tuple[tuple[int, int], ...]
    preference: str | None


def assignment(config: ServeConfig, index: int) -> Assignment:
    """Participant ``index``'s counterbalanced design (see the module docstring)."""
    circuit = pair_circuit(config.graph.n_intentions)
    pairs = tuple(circuit[(index + e) % len(circuit)] for e in range(config.episodes))
    prefs = config.preferences
    return Assignment(index, pairs, prefs[index % len(prefs)] if prefs else None)


def describe_preference(spec: ScenarioSpec, preference: str) -> str:
    """How a preference of the scenario ``spec`` reads to a participant (one or two
    sentences): the scenario's own words (:attr:`ScenarioSpec.preference_wording`), else
    "Carry it the way called '<preference>'.".
    """
    words = spec.preference_wording
    text = None if words is None else words(preference)
    return text if text is not None else f"Carry it the way called {preference!r}."
