"""The single-agent Gymnasium environment: the robot cooperates with a scripted human."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from hri_envs.checks import check_flag
from hri_envs.envs.backends import BACKENDS, episode_backend
from hri_envs.envs.config import (
    check_env_settings,
    check_physics_options,
    check_seed,
    parse_reset_options,
    scenario_graph,
)
from hri_envs.envs.episode import Episode
from hri_envs.envs.formats import ClassicLayout, check_observation_format
from hri_envs.envs.render import render_ansi
from hri_envs.envs.spaces import check_action, robot_observation_space
from hri_envs.envs.window import check_display
from hri_envs.errors import ConfigError, ResetNeeded
from hri_envs.humans.protocol import BatchHuman, checked_actions
from hri_envs.humans.seat import HumanLike, seat_human
from hri_envs.humans.spec import HumanSpec
from hri_envs.task.episode import EpisodeRules, reached_intention, revise_intention
from hri_envs.task.scenarios import scenario_spec, spec_of

__all__ = ["RobotEnv", "panda_env"]

_ONE = np.ones(1, dtype=bool)
_ONE.setflags(write=False)


class RobotEnv(gym.Env[dict[str, Any], np.int64]):
    """The robot's side of physical human-robot cooperation, with a scripted human partner.

    ## Description

    The robot helps a scripted human carry an object (clothes hanger or wheel) to the
    support the human intends, without ever observing that intention ι (paper: van der
    Spaa, Kober, Gienger, *Simultaneously learning intentions and preferences during
    physical human-robot cooperation*). The dynamics are the abstract transition graph of
    :mod:`hri_envs.task.graph`; in each step the human acts by its preference
    (:func:`hri_envs.humans.scripted.preference_human`), optionally passive or turning back.
    This is the two-agent :class:`~hri_envs.envs.parallel.CooperationParallelEnv` seen from
    the robot.

    ## Action Space

    ``Discrete(A)`` (hanger A = 10, wheel A = 12): 0 wait, 1 grasp/let go, 2 take off,
    3 put on, 4 rotate, 5.. move over to support k, then move (up/down) to height h.
    :meth:`action_masks` (sb3-contrib's convention) gives the actions valid in the state;
    an invalid action aborts the step with reward -1.

    ## Observation Space

    ``Dict`` with ``"state"`` ``Discrete(S)``, ``"start"`` ``Discrete(K)``,
    ``"last_human_action"`` ``Discrete(A)`` (wait at reset) and ``"action_mask"``
    ``Box(0, 1, (A,), int8)``. ι is not observed. With ``observation_format="classic"``:
    ``{"observation": Box(0, 1, (N,), float32), "action_mask": Box(0, 1, (A,), int8)}``, the
    robot's view in the parallel env's classic format; ``"flat"``: one ``Box``, the vector
    with the mask appended (:mod:`hri_envs.envs.formats`).

    ## Rewards

    The robot cooperation reward R_R (paper Sect. 4.5): -1 for an aborted step or a robot
    motion the human counteracts, r0 when the robot waits while the human acts, -1 when the
    human waits and the state (pose and grasp) does not change, 0 otherwise.

    Grasping and letting go are never counteracted and cost nothing, so a robot can replace
    a wait (r0) by a pointless grasp-and-release; ``reward="no-free-toggle"`` (default
    ``"paper"``, the rule above) makes a robot toggle that the object's next motion does not
    need cost r0 like waiting (:func:`hri_envs.task.episode.unneeded_toggle`).
    docs/task-model.md, "Reward", works both rules through on the wheel and with turning back.

    ## Starting State

    The object rests on a uniformly drawn start support with μ = 0, and ι is uniform among
    the other supports; ``reset(options={"start": k, "intention": k, "turn_back": bool})``
    fixes them (supports by index or name "A", "B", ...). The wheel's stands are placed at
    random per episode (``options={"layout": ((xB, yB), (xC, yC))}`` fixes them); the
    layout changes the picture only.

    ## Episode End

    Terminated when the object rests with μ = 0 on a support other than the start, or on
    the start after it was lifted. Truncated after ``max_cycles`` steps. The last step's
    ``info["reached_intention"]`` says whether the object rests on ι (False before).

    ## Arguments

    ```python
    import gymnasium as gym
    import hri_envs
    env = gym.make("hri_envs/Hanger-v0", preference=None, human_passive=0.0,
                   turn_back=0.0, r0=-0.33, max_cycles=100, render_mode=None)
    ```

    - ``scenario``: "hanger" or "wheel" (set by the registered id);
    - ``human``: who the human is: a :class:`~hri_envs.humans.spec.HumanSpec` (a scripted
      human, a population, split or family, or a ``module:Class`` of your own: the same
      description a study and ``serve`` take), or a ready-made human: a
      :class:`~hri_envs.humans.scripted.ScriptedHuman` (for example a Boltzmann human), any
      :class:`~hri_envs.humans.protocol.Human` or one-row
      :class:`~hri_envs.humans.protocol.BatchHuman` (a human who keeps state, a person).
      On the Panda backends the spec's ``body`` (:class:`~hri_envs.humans.spec.HumanBody`)
      is the physical human: its ``preset`` ("weak-human") and params (the ``human_*``
      physics options below) join ``physics`` (a key given both ways is refused); the graph
      backend refuses a body;
    - the spec's shorthand, instead of ``human``:
      ``preference`` (one of :func:`hri_envs.humans.scripted.preferences_for`; default: the
      hanger study's most frequent one, or the wheel's "straight"), ``human_passive``
      (probability that the human waits in a step; paper Fig. 10c: 0.2), ``turn_back``
      (probability per episode of turning back halfway), ``human_rationality`` (β of a
      Boltzmann human that samples its free-space action from ``softmax(β · Q_pref)``;
      ``inf``, the default, is deterministic; docs/environments.md, "Human populations"),
      ``population`` (a population, split, mixture or family: every ``reset`` draws a new
      member with the env's ``np_random``) and ``human_params`` (a family's parameters);
    - ``r0``: the robot's passive reward in (-1, 0) (default -0.33 hanger, -0.25 wheel);
    - ``reward``: a registered reward rule's name (``"paper"``, the default,
      ``"no-free-toggle"``, or your own: :data:`hri_envs.task.episode.REWARD_RULES`; see
      "Rewards");
    - ``max_cycles``: step limit per episode (default 100);
    - ``render_mode``: None, "ansi", "rgb_array" or "human" (a window; without a display
      :class:`~hri_envs.errors.DisplayUnavailableError` when built); ``render_intention``
      shows ι in it;
    - ``observation_format``: "dict" (default), "classic" or "flat" (see Observation Space);
    - ``backend``: "graph" (the abstract transition graph) or "mujoco": the same task on a
      simulated Franka Panda (:mod:`hri_envs.physics`, registered as
      ``hri_envs/HangerPanda-v0`` and ``hri_envs/WheelPanda-v0``). Both agents' actions are
      executed physically; the next state is the closest abstract state; the observed
      ``"last_human_action"`` is the action the robot *infers*; ``info`` carries the step's
      interaction impulses (sensed, and ``*_true``), duration, ``"graph_agrees"``,
      ``"human_action_inferred"``/``"human_action_true"`` and ``"fault"``; a fault
      truncates the episode with ``info["truncation_reason"]``, a physical one with r⁻;
    - ``physics``: options of the mujoco backend (docs/physics.md): ``video_path``,
      ``video_fps``, ``camera`` (the pictures' camera: "overview", "side", "top" or a
      mapping), ``preset`` ("weak-human", "noisy-sensor"), ``randomize``,
      ``attempt_invalid`` (the robot physically tries actions the graph refuses) and the
      parameters ``human_stiffness``, ``human_force``, ``human_noise``, ``human_delay_s``,
      ``human_mass``, ``sensor_noise_n``, ``sensor_bias_n``, ``sensor_delay_s``,
      ``object_mass``, ``hold_force``, ``human_grip_force``, ``handle_noise_n``; e.g.
      ``{"preset": "weak-human"}``.

    The human draws from its own generator, seeded from the env's ``np_random`` at every
    reset, so ``reset(seed=...)`` reproduces the episode.

    ## Version History

    - v0: initial version.
    """

    metadata: dict[str, Any] = {"render_modes": ["ansi", "rgb_array", "human"],
                                "render_fps": 4}

    def __init__(
        self,
        scenario: str = "hanger",
        *,
        human: HumanLike | None = None,
        r0: float | None = None,
        max_cycles: int = 100,
        render_mode: str | None = None,
        backend: str = "graph",
        render_intention: bool = False,
        physics: dict[str, Any] | None = None,
        observation_format: str = "dict",
        reward: str = "paper",
        **human_keywords: Any,
    ) -> None:
        (self.scenario_name, self.r0, self.max_cycles, self.render_mode,
         self.backend) = check_env_settings(scenario, r0, max_cycles, render_mode,
                                            self.metadata["render_modes"], backend)
        physics = check_physics_options(
            physics, self.backend, human.body if isinstance(human, HumanSpec) else None)
        self.render_intention = check_flag(render_intention, "render_intention")
        self.observation_format = check_observation_format(observation_format)
        self._human_window = self.render_mode == "human"
        if self._human_window:
            check_display()

        self.graph = scenario_graph(scenario)
        self._human: BatchHuman = seat_human(self.graph, human=human, body=True,
                                             **human_keywords)
        self.rules = EpisodeRules(self.graph, self.r0, reward)
        self._episode: Episode = episode_backend(self.backend)(self.rules, None, **physics)
        self._sync_turn_state()
        self._sample_layout = spec_of(self.graph).layout
        n_s, n_k, n_a = self.graph.n_states, self.graph.n_intentions, self.graph.n_actions
        self.observation_space = robot_observation_space(n_s, n_k, n_a)
        if self.observation_format != "dict":
            self._classic = ClassicLayout(n_s, n_k, n_a, self.observation_format == "flat")
            self.observation_space = self._classic.space
            self._observation = self._classic_observation  # type: ignore[method-assign]
        self.action_space = spaces.Discrete(n_a)
        self.layout: tuple[tuple[float, float], ...] | None = None
        self._reward = 0.0
        self._done = True

    @property
    def human(self) -> BatchHuman:
        """The human in the seat (a :class:`~hri_envs.humans.protocol.BatchHuman` of one row);
        assign a ``ScriptedHuman``, ``Human`` or ``BatchHuman`` to replace it (from the next
        reset on).
        """
        return self._human

    @human.setter
    def human(self, human: HumanLike) -> None:
        self._human = seat_human(self.graph, human=human)
        self._sync_turn_state()

    def _sync_turn_state(self) -> None:
        """Hand the episode where the seat's human turns back."""
        ts = self._human.turn_state
        if ts is None:
            ts = np.full((self.graph.n_intentions,) * 2, -1)
        self._episode.set_turn_state(ts if ts.ndim == 2 else ts[0])

    @property
    def intention(self) -> int:
        """The human's current goal ι (hidden from the robot's observation)."""
        return self._episode.intention

    def action_masks(self) -> np.ndarray:
        """(A,) bool, the robot's valid actions in the current state."""
        return self.graph.valid[self._episode.state].copy()

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode; see the class docstring for ``options``."""
        opts = parse_reset_options(options, self.graph)
        super().reset(seed=check_seed(seed))
        rng = self.np_random
        human = self._human
        human.draw(rng)  # a population's new member, drawn first
        self._sync_turn_state()
        human.seed(np.random.default_rng(int(rng.integers(2**63))))
        self._episode.draw(rng, opts.start, opts.intention, opts.turn_back,
                           float(human.turn_back[0]))
        ep = self._episode
        human.begin_episode(np.array([ep.start]), np.array([ep.intention]))
        if self._sample_layout is not None:
            self.layout = opts.layout if opts.layout is not None else self._sample_layout(rng)
        self._episode.place(self.layout, rng)
        self._reward = 0.0
        self._done = False
        if self._human_window:
            self.render()
        return self._observation(), {"aborted": False, "invalid_action": False,
                                     "reached_intention": False}

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """The robot acts, the scripted human acts, the object moves."""
        a_r = check_action("robot", action, self.rules.n_actions)
        if self._done:
            raise ResetNeeded()
        a_h, seen = self._human_action(a_r)
        return self._advance(a_r, a_h, seen)

    def _human_action(self, a_r: int) -> tuple[int, dict[str, np.ndarray]]:
        """The human's action against the robot's ``a_r``, and what the human saw."""
        ep = self._episode
        s = ep.state
        seen = {"state": np.array([s]), "start": np.array([ep.start]),
                "intention": np.array([ep.intention]),
                "last_human_action": np.array([ep.last_human]),
                "action_mask": self.rules.action_mask[s][None], "robot_action": np.array([a_r])}
        return int(checked_actions(self._human.act(seen, _ONE), 1, self.rules.n_actions)[0]), seen

    def _advance(self, a_r: int, a_h: int, seen: dict[str, np.ndarray]
                 ) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """The joint action moves the episode (the second half of :meth:`step`)."""
        ep, human = self._episode, self._human
        t = ep.advance(a_r, a_h)
        human.observe(seen["state"], seen["robot_action"], np.array([a_h]),
                      np.array([ep.state]), _ONE)
        revised = human.revised_intentions()  # a human who changed its mind
        if revised is not None and not t.terminated:
            ep.intention = int(revise_intention(ep.intention, revised[0]))
        self._reward = t.reward
        truncated = not t.terminated and (ep.steps >= self.max_cycles or ep.fault is not None)
        info: dict[str, Any] = {"aborted": t.aborted, "invalid_action": t.robot_invalid,
                                "reached_intention": False, **ep.step_info()}
        self._done = t.terminated or truncated
        if self._done:
            human.end_episode()
            info["reached_intention"] = t.terminated and bool(
                reached_intention(self.graph, ep.state, ep.intention))
        if self._human_window:
            self.render()
        return self._observation(), t.reward, t.terminated, truncated, info

    def _observation(self) -> dict[str, Any]:
        ep = self._episode
        return {"state": ep.state, "start": ep.start, "last_human_action": ep.observed_human,
                "action_mask": self.rules.action_mask[ep.state].copy()}

    def _classic_observation(self) -> dict[str, Any]:
        ep = self._episode
        return self._classic.encode(ep.state, ep.start, ep.observed_human, None,
                                    self.rules.action_mask[ep.state])

    def render(self) -> str | np.ndarray | None:
        """Render according to ``render_mode`` (None: nothing)."""
        ep = self._episode
        if self.render_mode == "ansi":
            return render_ansi(
                self.graph, title=f"{self.scenario_name} (robot)", state=ep.state,
                previous=ep.previous, start=ep.start,
                intention=ep.intention if self.render_intention else None,
                last_human=ep.last_human, last_robot=ep.last_robot, reward=self._reward,
                steps=ep.steps, max_cycles=self.max_cycles,
            )
        if self.render_mode == "rgb_array":
            return ep.render(self.layout)
        if self.render_mode == "human":
            ep.show(self.layout, f"{self.scenario_name} (robot)", self.metadata["render_fps"])
        return None

    def close(self) -> None:
        """Release what the backend holds (the physics' renderer, a pending video)."""
        self._episode.close()


def panda_env(scenario: str = "hanger", *, backend: str = "mujoco", **kwargs: Any) -> RobotEnv:
    """The entry point of the Panda ids (``hri_envs/HangerPanda-v0``, ...): a
    :class:`RobotEnv` on a backend that simulates the Panda.

    ``gymnasium.make(panda_id, backend=...)`` may choose among the physics backends of
    :data:`~hri_envs.envs.backends.BACKENDS` (``physical``: "mujoco", "mjwarp"); any other
    (the abstract "graph") is refused rather than silently giving the graph env under a Panda
    id: that env is the scenario's graph id.

    Raises:
        ConfigError: ``backend`` is not a physics backend (``field="backend"``).
    """
    physical = [name for name, spec in BACKENDS.items() if spec.physical]
    if not isinstance(backend, str) or backend not in physical:
        try:
            graph_id = f" ({scenario_spec(scenario).gym_id})"
        except ConfigError:
            graph_id = ""
        raise ConfigError(f"a Panda id simulates the Panda: backend must be one of the physics "
                          f"backends {', '.join(physical)}, got {backend!r}; the graph env has "
                          f"an id of its own{graph_id}", field="backend")
    return RobotEnv(scenario, backend=backend, **kwargs)


#: ``gymnasium.make`` reads the render modes of an entry point from its ``metadata``.
panda_env.metadata = RobotEnv.metadata  # type: ignore[attr-defined]
