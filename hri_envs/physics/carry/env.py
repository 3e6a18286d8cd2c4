"""The continuous-control Gymnasium env: the robot carries the object with a whole human arm.

Registered as ``hri_envs/HangerPandaContinuous-v0`` and ``hri_envs/WheelPandaContinuous-v0``
(:mod:`hri_envs.registration`); the parallel two-agent form is
:mod:`hri_envs.physics.carry.parallel`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from hri_envs.envs.backends import carry_backend
from hri_envs.envs.config import check_layout, check_options_mapping, check_seed
from hri_envs.errors import ConfigError, ResetNeeded
from hri_envs.humans.spec import HumanSpec
from hri_envs.physics.carry.human.intention import HumanParams, carry_human_spec
from hri_envs.physics.carry.options import (
    SENSOR_KEYS,
    check_population,
    check_sensor,
    check_step_scale,
    vector_env,
)
from hri_envs.physics.carry.reward import (
    EFFORT_LEVER_M,
    EpisodeRecord,
    PlacingReward,
    RewardWeights,
    StallClock,
    check_weights,
)
from hri_envs.physics.carry.robot_view import RobotTask, observation_layout
from hri_envs.physics.carry.sim import DRIVES, CarryStep, RobotCommand
from hri_envs.physics.carry.simulation import ACTION_SIZE, CarrySimulation, check_box_action
from hri_envs.physics.scene.design import physical_graph
from hri_envs.physics.scene.ik import IKFailure
from hri_envs.physics.scene.rendering import EpisodePictures, RenderSettings
from hri_envs.task.scenarios import episode_geometry, spec_of

__all__ = ["ACTION_SIZE", "SENSOR_KEYS", "VERSIONS", "CarryEnv", "CarrySimulation",
           "HiddenIntentionError", "PlacingReward", "RewardWeights", "check_box_action",
           "check_sensor", "check_step_scale", "vector_env"]

_FAULT_KINDS = ("dropped", "slipped", "too_weak")
#: The continuous ids' versions: 0 (progress reward, frozen) and 1 (placing reward, the
#: intention hidden from ``info`` until the episode's end).
VERSIONS: tuple[int, ...] = (0, 1)
class HiddenIntentionError(AttributeError):
    """The intention was asked for during a v1 episode: it is revealed at the end."""


class CarryEnv(gym.Env[np.ndarray, np.ndarray]):
    """The robot carries an object with a simulated human, feeling them through its wrist.

    ## Description

    A simulated Franka Panda and a simulated human carry an object (clothes hanger, or
    wheel) from the support it rests on to the support the human intends. The human is a
    whole arm on a torso (:mod:`hri_envs.physics.carry.human.whole_arm`; torque-driven with adult
    strength limits, or muscle-driven through MyoSuite's arm) that holds the object's
    handle by friction and conveys their hidden intention by force: their hand tracks a
    minimum-jerk reference along their route to the goal with an impedance around it,
    pushing against a robot that goes another way and yielding to one that goes theirs
    (:mod:`hri_envs.physics.carry.human.intention`). The robot never observes the intention; it
    feels
    the human through its wrist force/torque sensor. docs/physics.md, "Continuous envs".

    ## Action Space

    ``Box(-1, 1, (7,), float32)``, at 25 Hz: the robot's grip target relative to where its
    grip is, ``a[0:3] x max_step_m`` (default 2 cm) in the world's x, y, z and a rotation
    vector ``a[3:6] x max_step_rad`` (default 0.06 rad), tracked by the existing Cartesian
    impedance controller with stiffness scale ``(a[6] + 1) / 2`` (0: passive, gravity and
    payload compensated; 1: the design's stiffness).

    ## Observation Space

    ``Box(-inf, inf, (N,), float32)``, physical units: the object's position (3) [m],
    orientation quaternion (4, w >= 0), linear (3) [m/s] and angular velocity (3) [rad/s];
    the robot's grip position (3) and orientation (4); its joint positions (n) [rad, m] and
    velocities (n) (n = 7 hanger, 10 wheel with its mobile base); the wrist sensor's estimate
    of the external wrench on the object (6) [N, N m] (compensated, biased, noisy, delayed:
    :mod:`hri_envs.physics.scene.sensing`); the start support, one-hot (K); the supports'
    positions (K x 3) [m]; the elapsed fraction of the time limit (1). Never the intention.
    Hanger N = 53, wheel N = 59.

    ## Rewards

    **v1** (``*PandaContinuous-v1``; :class:`~hri_envs.physics.carry.reward.PlacingReward`):
    placing the object at the human's goal is what pays. Per step ``- w_e effort
    - w_d disagreement - w_s stall``: ``effort`` the human's effort (∫ |F| + |τ| / 0.1 m dt
    [N s] of the wrench their hand puts on the handle), ``disagreement`` the work [J] the
    human does against the object's motion, ``stall`` the seconds the object stalled (moved
    < 1 cm and turned < 0.05 rad in the last 2 s); at the end ``+ w_place`` if the object
    rests on the human's goal, else ``- w_fail`` (dropped, slipped, too weak, another
    support, or the time limit). Defaults 0.02 per N s, 0.1 per J, 0.5 per s, 10, 5. The
    per-step costs stop at ``cost_cap`` (10) per episode, so a return lies in [-15, 10]:
    at least 0 when the object was placed at the goal, at most -5 when not.

    **v0** (``*PandaContinuous-v0``, kept as it was; :class:`~hri_envs.physics.
    carry.reward.RewardWeights`): per step ``w_p Δprogress - w_e effort - w_d
    disagreement`` with ``progress`` along the human's route (0 at the start, 1 at the goal)
    and the effort's torque over the scenario's lever; ``- w_f`` for a drop, slip or too weak
    (defaults 10, 0.02, 0.1, 5). It credits progress without placing and costs nothing for a
    time-out; docs/physics.md, "Rewards".

    ## Starting State

    The object rests on a start support; the robot holds its grip block, the human the
    handle; the human's goal ι is another support. Start and goal are uniform draws from
    ``np_random`` unless ``reset(options={"start": k, "intention": k})`` fixes them
    (indices or names "A", "B", ...); ``options={"robot_holds": False}`` starts with the
    robot's hand off the object (the human carries alone). The wheel's stands are placed at
    random per episode (``options={"layout": ((xB, yB), (xC, yC))}`` fixes them). v1:
    ``options={"human": HumanSpec, HumanParams or mapping}`` sets this episode's human (a
    spec without a population; else the
    ``population``'s draw, else ``human``).

    ## Episode End

    Terminated when the object is *placed* (it rests, slow for 0.15 s, on a support after
    leaving its start: ``info["placed"]`` is that support, ``info["reached_intention"]``
    whether it is the goal), *dropped* (it touched the floor or fell, or slipped out of a
    human's hand who carried it alone) or *slipped* (the handle slipped out of the human's
    hand), or when a human who carries the object alone is *too weak* (their arm pushed at
    its strength limit for 1 s without moving the object, and cannot lift its weight):
    ``info["fault"]`` is ``"dropped"``, ``"slipped"`` or ``"too_weak"`` and
    ``info["fault_detail"]`` says why (the arm's greatest lifting force in its posture
    against the object's weight, the joints at their strength limit, the grip force).
    Truncated when the time limit passes (``max_time_s``, 30 s hanger, 45 s wheel) or the
    robot cannot reach its grip (``info["fault"] = "ik_failure"``).

    ## Arguments

    ```python
    import gymnasium as gym
    import hri_envs
    env = gym.make("hri_envs/HangerPandaContinuous-v0", drive="torque", human=None,
                   max_time_s=None, reward=None, sensor=None, render_mode=None,
                   backend="mujoco", camera=None, render_goal=False,
                   render_size=(640, 480))
    ```

    - ``scenario``: "hanger" or "wheel" (set by the registered id);
    - ``backend``: "mujoco" (MuJoCo's C library, the default) or "mjwarp" (the same scene on
      MuJoCo Warp, the "mjwarp" extra; the torque drive only; docs/physics.md, "Many worlds
      on MuJoCo Warp"); ``gymnasium.make_vec(id, num_envs=N, vectorization_mode=
      "vector_entry_point")`` steps N of them on MuJoCo Warp together
      (:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`);
    - ``drive``: "torque" (joint torque motors, the default) or "muscle" (MyoSuite's arm,
      the "arm" extra; docs/physics.md says where it works);
    - ``human``: a :class:`~hri_envs.humans.spec.HumanSpec` (the one description of the
      human every env takes): its ``body`` is the physical human (``preset`` "default",
      "weak", "hesitant", "firm" and params, the fields of :class:`~hri_envs.physics.
      carry.human.intention.HumanParams`: ``strength``, ``stiffness``, ``hesitation_s``,
      ``reaction_s``, ``grip_force_n``, ``speed``, ``sex``, ``stature_m``, ``body_mass_kg``,
      ``drive``), its ``preference`` the route's, its ``population`` a physical population (as
      ``population=``); ``passive``, ``turn_back``, ``rationality`` and ``params`` are
      refused (:class:`~hri_envs.errors.ConfigError` naming the field). The shorthand: a
      mapping of the body's ``preset`` and params (``human={"preset": "weak", "strength":
      0.7}`` is ``HumanSpec(body=HumanBody("weak", {"strength": 0.7}))``, the same
      episodes);
    - ``max_time_s``: the time limit [s]; ``reward``: a mapping of the version's weights
      (v1 :class:`PlacingReward`, v0 :class:`RewardWeights`);
    - ``sensor``: the wrist sensor's ``noise_n``, ``bias_n``, ``delay_s``;
    - ``max_step_m``, ``max_step_rad``: the action's scale;
    - ``render_mode``: None or "rgb_array"; ``camera``: "overview" (the default), "side",
      "top" (each fitted at reset to hold the supports, the object and both agents) or a
      mapping of MuJoCo's free-camera ``lookat``, ``distance``, ``azimuth``, ``elevation``
      (the keys left out are the overview's); ``render_size``: ``(width, height)`` [px];
      ``render_goal``: mark the human's goal (for a viewer; False by default, as an agent
      learning from pixels must not see it). The supports are labelled by name
      (docs/physics.md, "Pictures");
    - ``population``: v1: the name of a physical human population; a member is drawn at
      every reset from ``np_random`` (:mod:`hri_envs.physics.carry.human.population`); the shorthand
      of ``human=HumanSpec(population=...)``;
    - ``version``: 1 or 0 (set by the registered id).

    ``info`` (v1) during an episode holds only what the robot's observation shows:
    ``time_s`` and ``stalled``. The step that ends the episode adds ``placed``,
    ``reached_intention``, ``fault`` (``fault_detail``) and ``episode``: the human's effort
    (also per unit of route progress), the impulses, peak and RMS interaction force, the
    object's RMS jerk, the disagreement work, the time stalled, the time to place, the
    return, the intention and the outcome (:class:`~hri_envs.physics.carry.reward.
    EpisodeRecord`). The intention is hidden until then: ``env.unwrapped.intention`` raises
    :class:`HiddenIntentionError` during a v1 episode. (The simulation itself, ``sim``, holds
    the human and their route: references and tools may read it, a robot agent never gets
    it; :meth:`robot_task` is what a robot may know.)

    ``info`` (v0) of every step: ``progress``, ``effort``, ``linear_impulse``,
    ``angular_impulse``, ``disagreement``, ``episode_effort``, ``fault``, ``placed``,
    ``reached_intention``, ``saturated`` (arm joints at their strength limit).

    ## Version History

    - v1: the reward pays for placing (progress no longer credited), a time-out and a stall
      cost, one effort lever for every scenario; ``info`` holds nothing derived from the
      intention during an episode and reports the interaction figures at its end;
      ``population``.
    - v0: initial version (``backend="mjwarp"`` added later; the default is unchanged).
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(self, scenario: str = "hanger", *, drive: str = "torque",
                 human: HumanSpec | Mapping[str, Any] | None = None,
                 max_time_s: float | None = None,
                 reward: Mapping[str, float] | None = None,
                 sensor: Mapping[str, float] | None = None, max_step_m: float = 0.02,
                 max_step_rad: float = 0.06, render_mode: str | None = None,
                 backend: str = "mujoco", population: str | None = None,
                 version: int = 0, camera: str | Mapping[str, Any] | None = None,
                 render_goal: bool = False, render_size: tuple[int, int] = (640, 480)
                 ) -> None:
        if version not in VERSIONS:
            raise ConfigError(f"unknown version {version!r} of the continuous envs; allowed: "
                              f"{', '.join(map(str, VERSIONS))}", field="version")
        self.human = carry_human_spec(human, population)
        if self.human.population is not None and version == 0:
            raise ConfigError("population= needs the v1 ids (*PandaContinuous-v1); v0 takes "
                              "one human (human=...)", field="population")
        self.version = version
        self.graph = physical_graph(scenario)
        spec = spec_of(self.graph)
        if drive not in DRIVES:
            raise ConfigError(f"unknown drive {drive!r}; allowed: {', '.join(DRIVES)}",
                              field="drive")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}",
                              field="render_mode")
        self.pictures = EpisodePictures(RenderSettings.check(camera, render_goal, render_size))
        self.human_params = HumanParams.of_spec(self.human)
        self.weights: RewardWeights | PlacingReward = check_weights(
            PlacingReward if version else RewardWeights, reward)
        population = self.human.population
        self.population = None if population is None else check_population(population,
                                                                           self.graph)
        max_time_s = spec.continuous_time_s if max_time_s is None else max_time_s
        if isinstance(max_time_s, bool) or not isinstance(max_time_s, int | float) \
                or not math.isfinite(max_time_s) or max_time_s <= 0:
            raise ConfigError(f"max_time_s must be a positive number [s], got {max_time_s!r}",
                              field="max_time_s")
        check_step_scale(max_step_m, max_step_rad)
        sensor = check_sensor(sensor)
        make_sim = carry_backend(backend, drive)
        self.scenario_name, self.render_mode, self.backend = scenario, render_mode, backend
        self.sim: CarrySimulation = make_sim(self.graph, drive, max_step_m=max_step_m,
                                             max_step_rad=max_step_rad, sensor=sensor)
        self._layout_sampler = spec.layout
        self.max_steps = max(1, round(max_time_s / self.sim.dt_step))
        n_k = self.graph.n_intentions
        n_q = len(self.sim.scene.robot_dofs)
        self.n_obs = 13 + 7 + 2 * n_q + 6 + n_k + 3 * n_k + 1
        self.observation_space = spaces.Box(-np.inf, np.inf, (self.n_obs,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (ACTION_SIZE,), np.float32)
        self.layout: tuple[tuple[float, float], ...] | None = None
        self.time_limit_s = float(max_time_s)
        self.layout_names = observation_layout(n_q, n_k)
        self._done = True
        self.steps = 0
        self.start, self._intention = 0, 1
        self.episode_effort = 0.0
        self._progress = 0.0
        self._record = EpisodeRecord(self.sim.dt_step)
        self._stall = StallClock(self.sim.dt_step)

    @property
    def intention(self) -> int:
        """The human's goal support: v0 always; v1 only once the episode has ended.

        Raises:
            HiddenIntentionError: (an ``AttributeError``) during a v1 episode.
        """
        if self.version and not self._done:
            raise HiddenIntentionError(
                "the intention is hidden during an episode of the v1 ids; it is revealed at "
                "the episode's end (info['episode']['intention'])")
        return self._intention

    # ------------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; see the class docstring for ``options``."""
        super().reset(seed=check_seed(seed))
        opts = dict(check_options_mapping(options) if options is not None else {})
        # pettingzoo.test's api tests probe reset(options={"options": 1}): ignored, as by
        # the v0 envs (hri_envs.envs.config).
        allowed = ["start", "intention", "robot_holds"] + (
            ["layout"] if self._layout_sampler is not None else []) + (
            ["human"] if self.version else [])
        unknown = sorted(map(str, set(opts) - {*allowed, "options"}))
        if unknown:
            raise ConfigError(f"unknown reset option(s) {', '.join(map(repr, unknown))}; "
                              f"allowed: {', '.join(allowed)}", field="options")
        rng = self.np_random
        k = self.graph.n_intentions
        start = self._support(opts.get("start"), "start")
        if start is None:
            start = int(rng.integers(k))
        goal = self._support(opts.get("intention"), "intention")
        if goal is None:
            goal = int((start + 1 + rng.integers(k - 1)) % k)
        if goal == start:
            raise ConfigError(f"the intention must differ from the start support ({start})",
                              field="intention")
        robot_holds = opts.get("robot_holds", True)
        if not isinstance(robot_holds, bool | np.bool_):
            raise ConfigError(f"reset option 'robot_holds' must be True or False, got "
                              f"{robot_holds!r}", field="options")
        self.layout = None
        if self._layout_sampler is not None:
            self.layout = (check_layout(opts["layout"], self.graph)
                           if opts.get("layout") is not None else self._layout_sampler(rng))
        scenario = episode_geometry(self.graph, self.layout)
        self.start, self._intention = start, goal
        if opts.get("human") is not None:  # v1: this episode's human
            human = HumanParams.of_spec(carry_human_spec(opts["human"], episode=True))
        elif self.population is not None:
            human = self.population.draw(rng)
        else:
            human = self.human_params
        self._fault: str | None = None
        try:
            self.sim.reset(start, goal, np.random.default_rng(int(rng.integers(2**63))),
                           scenario, human, bool(robot_holds))
        except IKFailure as exc:
            self._fault = f"ik_failure: {exc}"
        self.steps, self.episode_effort, self._done = 0, 0.0, False
        self._robot_holds = bool(robot_holds)
        if self.version:
            self._record.reset()
            pose = self.sim.object_pose()
            self._stall.reset(pose.pos, pose.quat)
            return self._observation(), {"time_s": 0.0, "stalled": False}
        self._progress = self.sim.progress()
        return self._observation(), {"progress": self._progress, "placed": -1,
                                     "reached_intention": False, "fault": None}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The robot acts for 40 ms; the human acts; the object moves."""
        a = check_box_action("robot", action)
        if self._done:
            raise ResetNeeded()
        if self._fault is not None:  # the robot could not reach its grip: nothing runs
            self._done = True
            info: dict[str, Any] = {"fault": "ik_failure", "fault_detail": self._fault,
                                    "placed": -1, "reached_intention": False}
            if self.version:
                info["episode"] = self._record.report(
                    outcome="ik_failure", placed=-1, intention=self._intention,
                    progress=0.0, fault="ik_failure")
            else:
                info["progress"] = self._progress
            return self._observation(), 0.0, False, True, info
        return self._after(self.sim.step(self.sim.command(a)))

    def _after(self, res: CarryStep) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """The step's observation, reward, ends and info after the simulation's step."""
        return self._after_v1(res) if self.version else self._after_v0(res)

    def _after_v1(self, res: CarryStep
                  ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """v1: the placing reward; the intention only in the last step's info."""
        self.steps += 1
        w = self.weights
        assert isinstance(w, PlacingReward)
        pose = self.sim.object_pose()
        stalled = res.placed < 0 and self._stall.update(pose.pos, pose.quat)
        effort = res.linear_impulse + res.angular_impulse / EFFORT_LEVER_M
        cost = (w.effort * effort + w.disagreement * res.disagreement
                + (w.stall * self.sim.dt_step if stalled else 0.0))
        reward = -min(cost, max(w.cost_cap - self._record.cost, 0.0))  # capped per episode
        self._record.charge(-reward)
        kind = res.fault_kind
        terminated = res.placed >= 0 or kind in _FAULT_KINDS
        truncated = not terminated and (self.steps >= self.max_steps or kind is not None)
        self._done = terminated or truncated
        info: dict[str, Any] = {"time_s": self.steps * self.sim.dt_step, "stalled": stalled}
        if not self._done:
            self._record.add(res, stalled, reward)
            return self._observation(), float(reward), False, False, info
        reached = res.placed == self._intention
        reward += w.place if reached else -w.fail
        self._record.add(res, stalled, reward)
        outcome = ("placed" if reached else "wrong_support" if res.placed >= 0
                   else kind if kind is not None else "timeout")
        info.update(placed=res.placed, reached_intention=reached, fault=kind)
        if res.fault is not None:
            info["fault_detail"] = res.fault
        info["episode"] = self._record.report(
            outcome=outcome, placed=res.placed, intention=self._intention,
            progress=self.sim.progress(), fault=kind)
        return self._observation(), float(reward), terminated, truncated, info

    def _after_v0(self, res: CarryStep
                  ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """v0: the progress reward, everything in every step's info (frozen)."""
        self.steps += 1
        w = self.weights
        assert isinstance(w, RewardWeights)
        reward = (w.progress * (res.progress - self._progress) - w.effort * res.effort
                  - w.disagreement * res.disagreement)
        self._progress = res.progress
        self.episode_effort += res.effort
        kind = res.fault_kind
        terminated = res.placed >= 0 or kind in _FAULT_KINDS
        if kind in _FAULT_KINDS:
            reward -= w.fault
        truncated = not terminated and (self.steps >= self.max_steps or kind is not None)
        self._done = terminated or truncated
        info = {"progress": res.progress, "effort": res.effort,
                "linear_impulse": res.linear_impulse, "angular_impulse": res.angular_impulse,
                "disagreement": res.disagreement, "episode_effort": self.episode_effort,
                "fault": kind, "placed": res.placed,
                "reached_intention": res.placed == self._intention,
                "saturated": res.saturated, "time_s": self.steps * self.sim.dt_step}
        if res.fault is not None:
            info["fault_detail"] = res.fault
        return self._observation(), float(reward), terminated, truncated, info

    def robot_task(self) -> RobotTask:
        """What the robot may know of the current episode (:class:`~hri_envs.physics.
        carry.robot_view.RobotTask`): the supports, the start, the task graph, the action's scale,
        the design; never the intention or the human.
        """
        return RobotTask(
            scenario=self.scenario_name, graph=self.graph,
            geometry=episode_geometry(self.graph, self.layout), start=self.start,
            seats=np.array(self.sim.seat_positions(), dtype=float), layout=self.layout,
            dt=self.sim.dt_step, time_limit_s=self.time_limit_s,
            max_step_m=self.sim.max_step_m, max_step_rad=self.sim.max_step_rad,
            design=self.sim.design, layout_names=dict(self.layout_names),
            robot_holds=getattr(self, "_robot_holds", True))

    def _support(self, value: Any, key: str) -> int | None:
        if value is None:
            return None
        names = [s.name for s in self.graph.scenario.supports]
        if isinstance(value, str) and value in names:
            return names.index(value)
        if isinstance(value, int | np.integer) and not isinstance(value, bool) \
                and 0 <= value < len(names):
            return int(value)
        raise ConfigError(f"reset option {key!r} must be a support index 0-{len(names) - 1} or "
                          f"name {', '.join(names)}, got {value!r}", field="options")

    def _observation(self) -> np.ndarray:
        sim = self.sim
        onehot = np.zeros(self.graph.n_intentions)
        onehot[self.start] = 1.0
        frac = self.steps / self.max_steps
        state = getattr(sim, "observation_state", None)  # the C backend's, in one call
        if state is not None:
            return np.concatenate([state(), sim.sensed, onehot, sim.seat_positions().ravel(),
                                   [frac]]).astype(np.float32)
        obj = sim.object_pose()
        q = obj.quat if obj.quat[0] >= 0 else -obj.quat
        v, w = sim.object_velocity()
        grip = sim.grip_pose()
        gq = grip.quat if grip.quat[0] >= 0 else -grip.quat
        joints, joint_vel = sim.robot_joints()
        out = np.concatenate([obj.pos, q, v, w, grip.pos, gq, joints, joint_vel, sim.sensed,
                              onehot, sim.seat_positions().ravel(), [frac]])
        return out.astype(np.float32)

    def render(self) -> np.ndarray | None:
        """An RGB picture (``render_mode="rgb_array"``), else None: the camera fitted to the
        episode's start, the supports labelled, the goal marked only with ``render_goal=True``
        (:class:`~hri_envs.physics.scene.rendering.EpisodePictures`).
        """
        if self.render_mode != "rgb_array":
            return None
        return self.pictures.draw(self.sim.model, self.sim.data, self.sim.seat_positions(),
                                  self.graph.support_names, (self.start, self.layout),
                                  self.steps == 0, self._intention)

    def close(self) -> None:
        """Release the renderer."""
        self.pictures.close()

    # ------------------------------------------------------------------ references
    def robot_command(self, action: np.ndarray) -> RobotCommand:
        """The command an action gives in the current state (for agents and tools)."""
        return self.sim.command(check_box_action("robot", action))
