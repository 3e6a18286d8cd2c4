"""The agent protocol every robot policy implements.

A robot policy (the paper's Learner, a baseline, the Oracle, an SB3 model, your own learner)
plugs into the envs and the benchmark through four calls per episode:

1. ``begin_episode(start)`` — a new episode starts at support ``start``;
2. ``act(observation)`` — choose the robot's action from what the robot may observe: the
   state, the action mask and the human's last action; never the intention ι;
3. ``observe(state, robot_action, human_action, next_state)`` — one transition happened;
4. ``end_episode(trace, intention)`` — learn from the episode, with the intention revealed in
   hindsight (the support where the episode ended; -1 if the episode was cut off by the step
   limit before the object came to rest, when nothing is revealed).

Two flavours share these names. :class:`Agent` handles one stream of episodes with plain
ints and is what a user writes. :class:`BatchAgent` advances ``n_runs`` independent
streams at once with arrays (a leading run axis) and is what the benchmark drives; our own
agents are written this way, and :class:`Batched` turns any list of :class:`Agent` into
one, while :meth:`BatchAgent.single` gives a batch of one the plain :class:`Agent` API.

A minimal user agent that copies the human's previous action when it can::

    class Copycat(Agent):
        name = "copycat"

        def begin_episode(self, start):
            pass

        def act(self, observation):
            a = int(observation["last_human_action"])
            return a if observation["action_mask"][a] else 0  # 0 = wait

        def observe(self, state, robot_action, human_action, next_state):
            pass

        def end_episode(self, trace, intention):
            pass

Run it with ``hri-bench study hanger --agents learner,mymodule:Copycat``.

**An optional belief.** An agent that keeps a belief over the intentions may expose it, and
the benchmark then scores how soon its most likely intention is right and how calibrated it
is (docs/results.md, "Metrics"). :meth:`Agent.belief` returns a (K,) array of probabilities
over the K intentions (supports) or None; :meth:`BatchAgent.belief` a (n_runs, K) array or
None. The default is None (no belief). The benchmark reads it with :func:`read_belief`
before every ``act``: it is the belief the action is chosen on. The Learner, the goal filter,
``countqmdp`` and ``qmdp`` expose theirs (so do the recordings and the browser view).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from hri_envs.checks import integer_action
from hri_envs.errors import ActionError, ConfigError

__all__ = ["METHODS", "Agent", "BatchAgent", "Batched", "Trace", "agent_name", "missing_methods",
           "read_belief", "run_streams"]

#: The methods every agent implements, in the order of an episode (``belief`` is optional).
METHODS: tuple[str, ...] = ("begin_episode", "act", "observe", "end_episode")


def missing_methods(cls: type) -> list[str]:
    """The protocol's methods (:data:`METHODS`) that the agent class ``cls`` leaves abstract
    or does not define as methods (an attribute that is not callable), in episode order.

    A class that misses one cannot be instantiated (or fails at its first call): the
    benchmark checks this when it reads an agent's name, before anything is simulated.
    """
    abstract: frozenset[str] = getattr(cls, "__abstractmethods__", frozenset())
    return [m for m in METHODS if m in abstract or not callable(getattr(cls, m, None))]


def agent_name(agent: object) -> str:
    """The name messages call ``agent`` by: the ``name`` it or its class sets (a class
    below :class:`Agent` and :class:`BatchAgent`, whose ``name`` is the placeholder
    "agent"), else its class's name, so that a nameless agent is not called 'agent'.
    """
    own = getattr(agent, "__dict__", {}).get("name")
    if isinstance(own, str) and own:
        return own
    for cls in type(agent).__mro__:
        if cls in (Agent, BatchAgent):
            break
        if isinstance(vars(cls).get("name"), str) and vars(cls)["name"]:
            return str(vars(cls)["name"])
    return type(agent).__name__


@dataclass(frozen=True)
class Trace:
    """One episode as the robot saw it.

    Attributes:
        states: (T+1,) visited states s_0 .. s_T.
        robot_actions: (T,) the robot's actions.
        human_actions: (T,) the human's actions.
    """

    states: np.ndarray
    robot_actions: np.ndarray
    human_actions: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.robot_actions)
        if len(self.states) != n + 1 or len(self.human_actions) != n:
            raise ConfigError(
                f"a trace needs T+1 states and T actions per agent; got {len(self.states)} "
                f"states, {n} robot and {len(self.human_actions)} human actions",
                field="states",
            )

    @property
    def start_state(self) -> int:
        """s_0."""
        return int(self.states[0])


class Agent(ABC):
    """A robot policy for one stream of episodes (see the module docstring)."""

    name: ClassVar[str] = "agent"

    @abstractmethod
    def begin_episode(self, start: int) -> None:
        """A new episode starts with the object resting on support ``start``."""

    @abstractmethod
    def act(self, observation: Mapping[str, Any]) -> int:
        """The robot's action for the robot's observation (keys ``state``, ``start``,
        ``last_human_action``, ``action_mask``).
        """

    @abstractmethod
    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        """One transition of the current episode."""

    @abstractmethod
    def end_episode(self, trace: Trace, intention: int) -> None:
        """Learn from the finished episode; ``intention`` is where it ended (-1: truncated)."""

    def belief(self) -> np.ndarray | None:
        """Optional: (K,) probabilities over the intentions before the next ``act``, or None
        (the default: the agent exposes no belief).
        """
        return None


def read_belief(agent: Agent | BatchAgent, n_runs: int | None = None) -> np.ndarray | None:
    """The belief an agent exposes, as a float array, or None when it exposes none.

    Calls the agent's ``belief()`` (:meth:`Agent.belief`, :meth:`BatchAgent.belief`); an
    object without one, or whose ``belief`` is not callable, has none.

    Args:
        agent: Any agent.
        n_runs: When given, the belief must be (n_runs, K).

    Raises:
        ConfigError: The belief is not a finite array of non-negative numbers summing to 1
            per run, or not (n_runs, K).
    """
    held = getattr(agent, "belief", None)
    value = held() if callable(held) else None
    if value is None:
        return None
    name = agent_name(agent)
    try:
        b = np.asarray(value, dtype=float)
    except (TypeError, ValueError):  # a str, a dict, a ragged list: not a vector of numbers
        raise ConfigError(f"belief() of agent {name!r} returned {type(value).__name__} "
                          f"{str(value)[:60]!r}; a belief is an array of numbers, a "
                          f"probability vector over the supports per run",
                          field="belief") from None
    if n_runs is not None and (b.ndim != 2 or b.shape[0] != n_runs):
        raise ConfigError(f"belief() of agent {name!r} returned shape {b.shape}; expected "
                          f"({n_runs}, K)", field="belief")
    # One pass each (called every step): NaN and ±inf fail one of the two comparisons.
    if b.size and not (b.min() >= 0.0 and np.abs(b.sum(-1) - 1.0).max() <= 1e-6):
        raise ConfigError(f"belief() of agent {name!r} is not a probability vector per run "
                          f"(finite, >= 0, summing to 1)", field="belief")
    return b


def run_streams(seed: int, runs: Sequence[int] | np.ndarray) -> list[np.random.Generator]:
    """One independent generator per run, derived from ``(seed, run)`` only.

    Results therefore do not depend on how runs are grouped into batches or processes.
    """
    return [np.random.default_rng([int(seed), int(r)]) for r in runs]


class BatchAgent(ABC):
    """A robot policy advancing ``n_runs`` independent streams of episodes in lockstep.

    Every method takes arrays with a leading run axis; ``active`` (bool, (n_runs,)) marks the
    runs whose episode is still going, and only those may consume randomness, so that a run's
    results depend on its own seed only.
    """

    name: ClassVar[str] = "agent"

    def __init__(self, n_runs: int) -> None:
        if n_runs < 1:
            raise ConfigError(f"n_runs must be >= 1, got {n_runs}", field="n_runs")
        self.n_runs = n_runs

    @abstractmethod
    def begin_episode(self, starts: np.ndarray) -> None:
        """New episodes start at supports ``starts`` (n_runs,)."""

    @abstractmethod
    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """(n_runs,) robot actions; entries of inactive runs are ignored."""

    @abstractmethod
    def observe(
        self,
        states: np.ndarray,
        robot_actions: np.ndarray,
        human_actions: np.ndarray,
        next_states: np.ndarray,
        active: np.ndarray,
    ) -> None:
        """One transition in every active run."""

    @abstractmethod
    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Learn from one finished episode per run (``intentions`` -1 where truncated)."""

    def belief(self) -> np.ndarray | None:
        """Optional: (n_runs, K) probabilities over the intentions before the next ``act``,
        or None (the default: the agent exposes no belief).
        """
        return None

    def single(self) -> Agent:
        """The batch of one as a plain :class:`Agent`."""
        if self.n_runs != 1:
            raise ConfigError(f"single() needs n_runs == 1, this agent has {self.n_runs}",
                              field="n_runs")
        return _Single(self)


class _Single(Agent):
    def __init__(self, batch: BatchAgent) -> None:
        self.batch = batch
        self.name = agent_name(batch)  # type: ignore[misc]

    def begin_episode(self, start: int) -> None:
        self.batch.begin_episode(np.array([start]))

    def act(self, observation: Mapping[str, Any]) -> int:
        obs = {k: np.asarray(v)[None] for k, v in observation.items()}
        actions = np.asarray(self.batch.act(obs, np.ones(1, bool)))
        if actions.shape != (1,) or actions.dtype.kind not in "iu":
            raise ActionError(f"act() of agent {self.name!r} returned {actions.dtype} of shape "
                              f"{actions.shape}; a batch of one gives one integer action, "
                              "shape (1,)")
        return int(actions[0])

    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        one = np.ones(1, bool)
        self.batch.observe(np.array([state]), np.array([robot_action]), np.array([human_action]),
                           np.array([next_state]), one)

    def end_episode(self, trace: Trace, intention: int) -> None:
        self.batch.end_episode([trace], np.array([intention]))

    def belief(self) -> np.ndarray | None:
        b = read_belief(self.batch)
        return None if b is None else b[0]


class Batched(BatchAgent):
    """Runs a list of single-stream :class:`Agent` objects as one :class:`BatchAgent`.

    Args:
        agents: One agent per run.
        runs: The runs' indices, for error messages (default 0 .. n-1).
    """

    def __init__(self, agents: Sequence[Agent], runs: Sequence[int] | None = None) -> None:
        super().__init__(len(agents))
        self.agents = list(agents)
        self.name = agent_name(agents[0])  # type: ignore[misc]
        self.runs = list(range(len(agents)) if runs is None else (int(r) for r in runs))
        if len(self.runs) != self.n_runs:
            raise ConfigError(f"{self.n_runs} agents but {len(self.runs)} run indices",
                              field="runs")

    @classmethod
    def from_factory(cls, factory: Callable[[int], Agent], runs: Sequence[int]) -> Batched:
        """One agent per run, ``factory(run)``."""
        return cls([factory(int(r)) for r in runs], runs)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Start one episode per agent."""
        for agent, start in zip(self.agents, starts, strict=True):
            agent.begin_episode(int(start))

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Ask each active agent for an action.

        Raises:
            ActionError: An agent returned something other than an integer (a Python or
                numpy integer): ``bool``, floats such as 0.5 or 1.0 and strings are refused
                rather than rounded or parsed. The message names the agent, the run and the
                value. Whether the integer is in the action space is checked where the
                action is used (the benchmark's loop, the envs).
        """
        out = np.zeros(self.n_runs, dtype=np.int64)
        for i in np.flatnonzero(active):
            out[i] = integer_action(self.agents[i].act({k: v[i] for k, v in observations.items()}),
                                    f"act() of agent {self.name!r}", f" for run {self.runs[i]}")
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Pass the transition to each active agent."""
        for i in np.flatnonzero(active):
            self.agents[i].observe(int(states[i]), int(robot_actions[i]), int(human_actions[i]),
                                   int(next_states[i]))

    def belief(self) -> np.ndarray | None:
        """The agents' beliefs stacked, (n_runs, K); None unless every agent exposes one.

        Not validated here: whoever reads it (:func:`read_belief`) checks the stacked array
        once, instead of once per agent and again stacked (this runs every step).

        Raises:
            ConfigError: The agents' beliefs differ in size.
        """
        beliefs = []
        for agent in self.agents:
            held = getattr(agent, "belief", None)
            value = held() if callable(held) else None
            if value is None:
                return None
            beliefs.append(np.asarray(value, dtype=float).reshape(-1))
        if len({b.size for b in beliefs}) > 1:
            raise ConfigError(f"belief() of agent {self.name!r} returned beliefs of sizes "
                              f"{sorted({b.size for b in beliefs})} across runs; expected the "
                              "same K in every run", field="belief")
        return np.stack(beliefs)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Let every agent learn from its episode."""
        for agent, trace, intention in zip(self.agents, traces, intentions, strict=True):
            agent.end_episode(trace, int(intention))
