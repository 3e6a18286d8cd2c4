"""The two-agent PettingZoo environment: a human and a robot carry an object together."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from pettingzoo.utils.env import ParallelEnv

from hri_envs.checks import check_flag
from hri_envs.envs.backends import episode_backend
from hri_envs.envs.config import (
    check_env_settings,
    check_physics_options,
    check_seed,
    parse_reset_options,
    scenario_graph,
)
from hri_envs.envs.episode import Episode
from hri_envs.envs.formats import ClassicLayout, check_human_reward, check_observation_format
from hri_envs.envs.render import render_ansi
from hri_envs.envs.spaces import check_action, human_observation_space, robot_observation_space
from hri_envs.envs.window import check_display
from hri_envs.errors import ActionError, ConfigError, ResetNeeded
from hri_envs.humans.scripted import check_probability
from hri_envs.humans.seat import human_spec
from hri_envs.humans.spec import HumanSpec
from hri_envs.task.episode import EpisodeRules, goal_reward, reached_intention
from hri_envs.task.scenarios import spec_of

__all__ = ["AGENTS", "CooperationParallelEnv"]

AGENTS: tuple[str, str] = ("human", "robot")


class CooperationParallelEnv(ParallelEnv[str, dict[str, Any], int]):
    """Physical human-robot cooperation with a hidden human intention, for two agents.

    ## Description

    A human and a robot carry an object (a clothes hanger, or a wheel) from the support it
    rests on to the support the human intends (paper: van der Spaa, Kober, Gienger,
    *Simultaneously learning intentions and preferences during physical human-robot
    cooperation*). The task is the abstract transition graph of
    :mod:`hri_envs.task.graph`: states are (position, orientation, grasp μ), both agents act
    in every step, and the joint transition is deterministic: grasp toggles first, the step
    is aborted if either action is invalid afterwards, and a held object moves by the
    human's action, or by the robot's when the human waits. The human knows the goal ι;
    the robot never observes it.

    ## Action Space

    ``Discrete(A)`` for both agents, one global numbering (hanger A = 10, wheel A = 12):
    0 wait, 1 grasp/let go, 2 take off, 3 put on, 4 rotate, 5.. move over to support k,
    then move (up/down) to height h. Which actions are valid in a state is in the
    observation's ``action_mask``; an invalid (masked) action aborts the step.

    ## Observation Space

    A ``Dict`` per agent:

    - ``"state"``: ``Discrete(S)``, the abstract state (hanger S = 24, wheel S = 36);
    - ``"start"``: ``Discrete(K)``, the support the episode started on;
    - ``"last_human_action"``: ``Discrete(A)``, the human's previous action (wait at reset);
      on the graph backend the robot senses it directly;
    - ``"action_mask"``: ``Box(0, 1, (A,), int8)``, the actions valid in the state;
    - ``"intention"``: ``Discrete(K)``, the human's goal ι, **human only**.

    :meth:`state` returns ``[state, start, intention, last_human_action, lifted]``.

    With ``observation_format="classic"`` both agents observe instead
    ``{"observation": Box(0, 1, (N,), float32), "action_mask": Box(0, 1, (A,), int8)}``, one
    space for both (the robot's ι slot zero, with an "absent" flag); ``"flat"`` gives one
    ``Box`` instead (the vector with the mask appended). The layouts are in
    :mod:`hri_envs.envs.formats`.

    ## Rewards

    Both agents receive the robot cooperation reward R_R (paper Sect. 4.5): -1 for an
    aborted step or a robot motion the human counteracts, r0 when the robot waits while the
    human acts, -1 when the human waits and the state (pose and grasp) does not change, 0
    otherwise. The human's own preference reward θᵀφ(s, ι) is what learners infer and is
    not paid out; sharing R_R makes the game fully cooperative.

    With ``human_reward="goal"`` the human is paid its own task reward instead
    (:func:`hri_envs.task.episode.goal_reward`): +1 for the step that ends the episode with
    the object on ι, r⁻ = -1 for an aborted step, 0 otherwise. ``info["robot_reward"]``
    always carries R_R.

    Grasping and letting go are never counteracted and cost nothing, so a robot can replace
    a wait (r0) by a pointless grasp-and-release; ``reward="no-free-toggle"`` (default
    ``"paper"``, the rule above) makes a robot toggle that the object's next motion does not
    need cost r0 like waiting (:func:`hri_envs.task.episode.unneeded_toggle`).
    docs/task-model.md, "Reward", works both rules through on the wheel and with turning back.

    ## Starting State

    The object rests on a start support with μ = 0; start and ι ≠ start are uniform, or set
    with ``reset(options={"start": k, "intention": k})`` (indices or names "A", "B", ...).
    ``options={"turn_back": True}`` makes the human change ι to the start support halfway
    along the default preference's route (paper Table 2, episode 8; routes of a single
    motion, such as B → C on the hanger, have no halfway point). The wheel's stands are
    placed at random each episode (``options={"layout": ((xB, yB), (xC, yC))}`` fixes
    them); the layout only changes the picture, not the graph.

    ## Episode End

    Terminated when the object rests with μ = 0 on a support other than the start, or on
    the start after it was lifted. Truncated after ``max_cycles`` steps. The last step's
    ``info["reached_intention"]`` (both agents) says whether the object rests on ι (False in
    every earlier step, so that the info keys stay the same within an episode).

    ## Arguments

    ```python
    from hri_envs import hanger_v0, wheel_v0
    env = hanger_v0.parallel_env(r0=-0.33, max_cycles=100, render_mode=None, backend="graph")
    ```

    - ``scenario``: "hanger" or "wheel" (fixed by the versioned modules);
    - ``r0``: the robot's passive reward in (-1, 0) (default -0.33 hanger, -0.25 wheel);
    - ``human``: a :class:`~hri_envs.humans.spec.HumanSpec` of which ``turn_back``,
      ``preference`` (the route on which the human turns back) and, on the Panda backends,
      ``body`` (the physical human, as for :class:`~hri_envs.envs.robot.RobotEnv`) apply
      here; any other field set is a :class:`~hri_envs.errors.ConfigError` naming it. Or
      the shorthand keywords:
    - ``turn_back``: probability per episode that ι turns to the start support halfway (as
      ``options={"turn_back": True}``, drawn at reset; default 0). The human is an agent
      here, so its rationality and preference are the policy you give it, not env options;
    - ``reward``: a registered reward rule's name (``"paper"``, the default,
      ``"no-free-toggle"``, or your own: :data:`hri_envs.task.episode.REWARD_RULES`; see
      "Rewards");
    - ``max_cycles``: step limit per episode (default 100);
    - ``render_mode``: None, "ansi", "rgb_array" or "human" (a window: matplotlib on the
      graph backend, MuJoCo's viewer on the physics; without a display the env raises
      :class:`~hri_envs.errors.DisplayUnavailableError` when built);
    - ``observation_format``: "dict" (default), "classic" or "flat" (see Observation Space);
    - ``human_reward``: "cooperation" (default) or "goal" (see Rewards);
    - ``backend``: "graph" (the abstract transition graph) or "mujoco" (the same task on a
      simulated Franka Panda, :mod:`hri_envs.physics`: both agents' actions are executed
      physically, the next state is the closest abstract state, and the robot's
      ``"last_human_action"`` is the action it *infers* from the transition; ``info``
      carries the step's interaction impulses (sensed at the wrist, and ``*_true``),
      duration, ``"graph_agrees"``, ``"human_action_inferred"``/``"human_action_true"``
      and ``"fault"``; a fault truncates the episode with ``info["truncation_reason"]``,
      a physical one (``dropped``, ``grasp_failed``, ``pulled_out``, ``off_support``)
      with reward r⁻);
    - ``physics``: options of the mujoco backend (docs/physics.md): ``video_path``,
      ``video_fps``, ``camera`` (the pictures' camera: "overview", "side", "top" or a
      mapping), ``preset`` ("weak-human", "noisy-sensor"), ``randomize``
      (``{key: (low, high)}`` per episode), ``attempt_invalid`` (bool: the robot
      physically tries actions the graph refuses) and the parameters ``human_stiffness`` [N/m],
      ``human_force`` [N], ``human_noise`` [N], ``human_delay_s``, ``sensor_noise_n``,
      ``sensor_bias_n``, ``sensor_delay_s``, ``object_mass`` [kg], ``hold_force`` [N],
      ``human_grip_force`` [N], ``handle_noise_n`` [N];
      e.g. ``{"video_path": "ep{episode}.gif", "video_fps": 10}`` records every episode;
    - ``render_intention``: show ι in renderings (default hidden).

    ## Version History

    - v0: initial version.
    """

    metadata: dict[str, Any] = {
        "name": "hri_cooperation_v0",
        "render_modes": ["ansi", "rgb_array", "human"],
        "is_parallelizable": True,
        "render_fps": 4,
    }

    def __init__(
        self,
        scenario: str = "hanger",
        *,
        r0: float | None = None,
        max_cycles: int = 100,
        render_mode: str | None = None,
        backend: str = "graph",
        render_intention: bool = False,
        physics: dict[str, Any] | None = None,
        observation_format: str = "dict",
        human_reward: str = "cooperation",
        reward: str = "paper",
        human: HumanSpec | None = None,
        **human_keywords: Any,
    ) -> None:
        spec = human_spec(human, human_keywords)
        if not isinstance(spec, HumanSpec):
            raise ConfigError("the parallel env's human is an agent (your policy): its human "
                              "spec sets only turn_back (and the preference whose route it "
                              f"turns back on), got {spec!r}", field="human")
        spec.refuse("the parallel env", ("preference", "turn_back", "body"),
                    " (its human is an agent, your policy: a spec sets where it turns back "
                    "and, on a physical backend, its body)", field="human")
        self.turn_back = check_probability(spec.turn_back, "turn_back")
        self.metadata = {**type(self).metadata, "name": f"{scenario}_v0",
                         "render_modes": list(type(self).metadata["render_modes"])}
        (self.scenario_name, self.r0, self.max_cycles, self.render_mode,
         self.backend) = check_env_settings(scenario, r0, max_cycles, render_mode,
                                            self.metadata["render_modes"], backend)
        physics = check_physics_options(physics, self.backend, spec.body)
        self.render_intention = check_flag(render_intention, "render_intention")
        self.observation_format = check_observation_format(observation_format)
        self.human_reward = check_human_reward(human_reward)
        self._goal_reward = self.human_reward == "goal"
        self._human_window = self.render_mode == "human"
        if self._human_window:
            check_display()

        self.graph = scenario_graph(scenario)
        self.rules = EpisodeRules(self.graph, self.r0, reward)
        turn_state = spec.scripted(self.graph).turn_state  # where a turning human turns
        self._episode: Episode = episode_backend(self.backend)(self.rules, turn_state,
                                                               **physics)
        # The graph backend itself has no faults and no figures of its own for the infos.
        self._graph_only = type(self._episode) is Episode
        self._masks = list(self.rules.action_mask)  # (A,) int8 read-only row per state
        self._sample_layout = spec_of(self.graph).layout
        n_s, n_k, n_a = self.graph.n_states, self.graph.n_intentions, self.graph.n_actions
        self._observation_spaces: dict[str, spaces.Space[Any]] = {
            "human": human_observation_space(n_s, n_k, n_a),
            "robot": robot_observation_space(n_s, n_k, n_a)}
        if self.observation_format != "dict":
            self._classic = ClassicLayout(n_s, n_k, n_a, self.observation_format == "flat")
            self._observation_spaces = {agent: self._classic.space for agent in AGENTS}
            self._observations = self._classic_observations  # type: ignore[method-assign]
        else:  # bound once: step() looks it up in the instance's dict
            self._observations = self._observations  # type: ignore[method-assign]
        self._n_actions = n_a
        self._action_spaces = {agent: spaces.Discrete(n_a) for agent in AGENTS}
        self.observation_spaces = self._observation_spaces
        self.action_spaces = self._action_spaces
        self.state_space = spaces.MultiDiscrete([n_s, n_k, n_k, n_a, 2])

        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        self.layout: tuple[tuple[float, float], ...] | None = None
        self._reward = 0.0
        self._np_random: np.random.Generator | None = None
        self._np_random_seed: int | None = None

    # ----------------------------------------------------------------- spaces
    def observation_space(self, agent: str) -> spaces.Space[Any]:  # noqa: D102
        return self._observation_spaces[self._known(agent)]

    def action_space(self, agent: str) -> spaces.Discrete:  # noqa: D102
        return self._action_spaces[self._known(agent)]

    def _known(self, agent: str) -> str:
        if not isinstance(agent, str) or agent not in self._action_spaces:
            raise ConfigError(f"unknown agent {agent!r}; agents: {', '.join(AGENTS)}",
                              field="agent")
        return agent

    @property
    def np_random(self) -> np.random.Generator:
        """The env's generator (seeded by :meth:`reset`)."""
        if self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random()
        return self._np_random

    @property
    def intention(self) -> int:
        """The human's current goal ι (for the human agent, loggers and tests)."""
        return self._episode.intention

    # ----------------------------------------------------------------- API
    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, dict[str, Any]], dict[str, dict[str, Any]]]:
        """Start an episode; see the class docstring for ``options``."""
        opts = parse_reset_options(options, self.graph)
        if check_seed(seed) is not None:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        rng = self.np_random
        self._episode.draw(rng, opts.start, opts.intention, opts.turn_back, self.turn_back)
        if self._sample_layout is not None:
            self.layout = opts.layout if opts.layout is not None else self._sample_layout(rng)
        self._episode.place(self.layout, rng)
        self.agents = list(AGENTS)
        self._reward = 0.0
        human_info = {"aborted": False, "invalid_action": False, "robot_reward": 0.0,
                      "reached_intention": False, "intention": self._episode.intention}
        robot_info = {"aborted": False, "invalid_action": False, "robot_reward": 0.0,
                      "reached_intention": False}
        if self._human_window:
            self.render()
        ep = self._episode
        return (self._observations(ep.state, ep.start, ep.intention, ep.last_human,
                                   ep.observed_human),
                {"human": human_info, "robot": robot_info})

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, dict[str, Any]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """Apply both agents' actions ``{"human": a_H, "robot": a_R}`` at once.

        Raises:
            ActionError: ``actions`` is not a mapping with exactly the agents "human" and
                "robot", or an action is not an integer in the action space.
            ResetNeeded: Before :meth:`reset`, or after the episode ended.
        """
        if not self.agents:
            raise ResetNeeded()
        n_a = self._n_actions
        if type(actions) is not dict and not isinstance(actions, Mapping):
            raise ActionError(f"step() takes a dict of one action per agent, e.g. "
                              f"{{'human': 0, 'robot': 0}}; got {actions!r}")
        if len(actions) != 2:  # the cheap test on the hot path; names are checked below
            unknown = sorted(map(str, set(actions) - set(self.agents)))
            if unknown:
                raise ActionError(f"unknown agent(s) {', '.join(unknown)} in the actions; "
                                  f"step() takes one action for each of {self.agents}")
        try:  # a plain int in range needs no further check
            a_h = actions["human"]
            if type(a_h) is not int or not 0 <= a_h < n_a:
                a_h = check_action("human", a_h, n_a)
            a_r = actions["robot"]
            if type(a_r) is not int or not 0 <= a_r < n_a:
                a_r = check_action("robot", a_r, n_a)
        except KeyError as missing:
            raise ActionError(
                f"missing action for agent {missing}; step() needs one action per agent in "
                f"{self.agents}"
            ) from None
        ep = self._episode
        r, aborted, terminated, robot_invalid, human_invalid = ep.advance(a_r, a_h)
        self._reward = r
        state, intention, last_human = ep.state, ep.intention, ep.last_human
        graph_only = self._graph_only  # the graph: no faults, the robot sees a_H itself
        truncated = not terminated and (ep.steps >= self.max_cycles
                                        or (not graph_only and ep.fault is not None))
        reached = False
        if terminated or truncated:
            self.agents = []
            reached = terminated and bool(reached_intention(self.graph, state, intention))
        human_info = {"aborted": aborted, "invalid_action": human_invalid, "robot_reward": r,
                      "reached_intention": reached, "intention": intention}
        robot_info = {"aborted": aborted, "invalid_action": robot_invalid, "robot_reward": r,
                      "reached_intention": reached}
        if not graph_only:  # the backend's own figures (the physics)
            extra = ep.step_info()
            human_info.update(extra)
            robot_info.update(extra)
        r_h = (float(goal_reward(self.graph, state, intention, aborted, terminated))
               if self._goal_reward else r)
        if self._human_window:
            self.render()
        return (
            self._observations(state, ep.start, intention, last_human,
                               last_human if graph_only else ep.observed_human),
            {"human": r_h, "robot": r},
            {"human": terminated, "robot": terminated},
            {"human": truncated, "robot": truncated},
            {"human": human_info, "robot": robot_info},
        )

    def _observations(self, state: int, start: int, intention: int, last_human: int,
                      seen_human: int) -> dict[str, dict[str, Any]]:
        """Both agents' observations (the robot sees ``seen_human``, not ι)."""
        mask = self._masks[state]
        return {"human": {"state": state, "start": start, "last_human_action": last_human,
                          "action_mask": mask.copy(), "intention": intention},
                "robot": {"state": state, "start": start, "last_human_action": seen_human,
                          "action_mask": mask.copy()}}

    def _classic_observations(self, state: int, start: int, intention: int, last_human: int,
                              seen_human: int) -> dict[str, dict[str, Any]]:
        """:meth:`_observations` in the "classic"/"flat" format."""
        enc, mask = self._classic.encode, self._masks[state]
        return {"human": enc(state, start, last_human, intention, mask),
                "robot": enc(state, start, seen_human, None, mask)}

    def state(self) -> np.ndarray:
        """``[state, start, intention, last_human_action, lifted]``, int64, shape (5,)."""
        ep = self._episode
        return np.array([ep.state, ep.start, ep.intention, ep.last_human, int(ep.lifted)],
                        dtype=np.int64)

    def render(self) -> str | np.ndarray | None:
        """Render according to ``render_mode`` (None: nothing)."""
        ep = self._episode
        if self.render_mode == "ansi":
            return render_ansi(
                self.graph, title=self.metadata["name"], state=ep.state, previous=ep.previous,
                start=ep.start, intention=ep.intention if self.render_intention else None,
                last_human=ep.last_human, last_robot=ep.last_robot, reward=self._reward,
                steps=ep.steps, max_cycles=self.max_cycles,
            )
        if self.render_mode == "rgb_array":
            return ep.render(self.layout)
        if self.render_mode == "human":
            ep.show(self.layout, self.metadata["name"], self.metadata["render_fps"])
        return None

    def close(self) -> None:
        """Release what the backend holds (the physics' renderer, a pending video)."""
        self._episode.close()
