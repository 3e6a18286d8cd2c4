"""Continuous carrying: the robot's Cartesian grip targets at 25 Hz and a whole human arm.

:class:`CarrySim` owns one MuJoCo scene of a scenario with the whole human arm
(:mod:`~hri_envs.physics.carry.human.whole_arm`, torque-driven, or
:mod:`~hri_envs.physics.carry.human.muscles`, muscle-driven). Both partners hold the object from the
start (the robot by its grasp weld on the grip block, the human by friction on the handle); the
human means to bring it to their goal support along their route
(:mod:`~hri_envs.physics.carry.human.intention`). Each
:meth:`CarrySim.step` takes the robot's action, a grip target relative to where its grip
is (and a stiffness), and simulates 40 ms:

* the robot's impedance controller (:class:`~hri_envs.physics.scene.controller.
  ImpedanceController`, at 125 Hz) tracks a line from its grip to the target with the
  given stiffness (0: passive, gravity and payload compensated); its null-space posture
  follows a mink IK reference updated once per step (25 Hz);
* the human's reference advances (yielding to a robot that leads their way) and their arm's
  impedance pulls the hand towards it, within their strength (:mod:`~hri_envs.physics.
  carry.human.arm_control`); the torso walks and turns with the reference;
* the supports hold a resting object by their seat law (:mod:`~hri_envs.physics.scene.seats`);
* the wrist sensor reads the external wrench on the object (:mod:`~hri_envs.physics.
  scene.sensing`: compensated, biased, noisy, delayed).

The five control periods run compiled (:mod:`~hri_envs.physics.carry.periods`): those
classes' laws over a world axis. What a step reports (:class:`CarryStep`): the route
progress, the human's effort (the wrench their hand puts on the handle, integrated: the
paper's H2 measure from the human's side), the disagreement (work the human does *against*
the object's motion), where the object rests, and a fault: ``dropped`` (the object touched
the floor or fell, or slipped out of the hand of a human who carries it alone),
``slipped`` (the handle slipped out of the human's hand), ``too_weak`` (a human who
carries the object alone has pushed at their strength limit for 1 s without moving it, and
the arm cannot lift its weight) or ``ik_failure``.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

import mujoco
import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.physics.carry import rules, stages
from hri_envs.physics.carry.faults import check_faults, max_lift_n, why_slipped
from hri_envs.physics.carry.human.arm_control import ArmDrive, HandImpedance, TorqueDrive
from hri_envs.physics.carry.human.body import ArmBody, BodySize
from hri_envs.physics.carry.human.intention import (
    HUMAN_DRIVES,
    HumanParams,
    IntentionHuman,
    route_states,
)
from hri_envs.physics.carry.human.whole_arm import (
    ARM_JOINTS,
    COMFORT_POSTURE,
    TORQUE_LIMITS,
    WholeArm,
    add_whole_arm,
    handle_quat_in_object,
)
from hri_envs.physics.carry.interaction import InteractionMeter, StepInteraction
from hri_envs.physics.carry.periods import CarryPeriods, PeriodsResult
from hri_envs.physics.carry.rules import CALM_S, STRAINED_S
from hri_envs.physics.carry.types import CarryStep, RobotCommand, grip_reference
from hri_envs.physics.carry.types import rotate as _rotate
from hri_envs.physics.scene import laws
from hri_envs.physics.scene.build import (
    FINGER_ON_GRIP_M,
    FINGER_OPEN_M,
    build_robot_model,
    build_scene,
)
from hri_envs.physics.scene.controller import ImpedanceController
from hri_envs.physics.scene.design import PhysicsDesign, design_for
from hri_envs.physics.scene.ik import IKFailure, ReferenceIK
from hri_envs.physics.scene.kinematics import (
    Pose,
    compose,
    rotation_error,
)
from hri_envs.physics.scene.observer import StateObserver
from hri_envs.physics.scene.rig import SceneRig
from hri_envs.physics.scene.seats import Seats
from hri_envs.physics.scene.sensing import SensorModel, WristSensor
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import BOTH, TaskGraph

__all__ = ["CALM_S", "DRIVES", "STRAINED_S", "CarrySim", "CarryStep", "RobotCommand",
           "grip_reference"]

#: The arm's drives: joint torque motors, or MyoSuite's muscles (the "arm" extra).
DRIVES: tuple[str, ...] = HUMAN_DRIVES
_REACH_ERROR_MAX_M = 0.01  # [m] + 0.2 m/rad: the arm's IK error at a reset


class CarrySim(SceneRig):
    """The robot, the whole human arm and the object of a scenario, stepped at 25 Hz.

    Args:
        graph: The scenario's task graph (supports, states, the human's routes).
        drive: "torque" (joint torque motors) or "muscle" (MyoSuite's arm, the "arm" extra).
        design: Physical design (default: the scenario's).
        max_step_m, max_step_rad: The largest grip target offset per step (an action of
            ±1) [m], [rad].
        sensor: Overrides of the wrist sensor model: ``noise_n``, ``bias_n``, ``delay_s``.

    Raises:
        ConfigError: An unknown drive.
        MissingExtraError: ``drive="muscle"`` without the "arm" extra (myo-sim).

    Attributes:
        handle_force_adr, handle_torque_adr: The handle's force and torque sensors' addresses
            in ``sensordata`` (the object on the handle, in the handle's frame).
        lowest_z: [m] the lowest support point of the scenario's layout (below it by
            :data:`~hri_envs.physics.carry.faults.DROP_BELOW_M`: dropped).
        period_forces, period_velocities: (1, 5), (1, 5, 3) the last step's samples per
            control period of the hand's force on the handle and the object's velocity.
    """

    def __init__(self, graph: TaskGraph, drive: str = "torque",
                 design: PhysicsDesign | None = None, max_step_m: float = 0.02,
                 max_step_rad: float = 0.06, sensor: Mapping[str, float] | None = None) -> None:
        if drive not in DRIVES:
            raise ConfigError(f"unknown arm drive {drive!r}; allowed: {', '.join(DRIVES)}",
                              field="drive")
        self.graph, self.drive_name = graph, drive
        self.design = design = design if design is not None else design_for(graph)
        self.scenario = graph.scenario
        self.rest_quat = self.scenario.orientations[0]
        self.max_step_m, self.max_step_rad = max_step_m, max_step_rad
        if drive == "torque":
            self.scene = build_scene(self.scenario, design, functools.partial(
                add_whole_arm, design=design, rest_quat=self.rest_quat))
            self.model = self.scene.model
            self.arm = WholeArm(self.model, ARM_JOINTS)
            acts = np.array([mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)
                             for n in ARM_JOINTS])
            self.arm_drive: ArmDrive = TorqueDrive(self.model, acts,
                                                   np.array(list(TORQUE_LIMITS.values())))
            coupling = self.arm.coupling
            posture = COMFORT_POSTURE
            self.body: ArmBody | None = ArmBody(self.model, self.arm)
        else:
            from hri_envs.physics.carry.human import muscles  # noqa: PLC0415

            self.scene, self.arm, self.arm_drive, coupling, posture = muscles.build(
                self.scenario, design, self.rest_quat)
            self.body = None
            self.model = self.scene.model
        self.init_data()
        self.dt_step = stages.PERIODS * self.dt_control
        self.posture = np.asarray(posture, dtype=float)
        self.coupling = coupling
        self.controller = ImpedanceController(self.scene)
        self.seats = Seats(self.scenario, design)
        self.observer = StateObserver(graph, self.scenario, design.lever)
        sensor = dict(sensor or {})
        self.sensor = WristSensor(self.scene, SensorModel(
            sensor.get("noise_n", design.sensor_noise_n),
            sensor.get("bias_n", design.sensor_bias_n),
            sensor.get("delay_s", design.sensor_delay_s), design.sensor_torque_lever_m,
            self.dt_control))
        n, n_base = len(self.scene.robot_dofs), 3 if design.mobile_base else 0
        self.n_base = n_base
        home = np.zeros(n)
        home[n_base:] = design.home
        self.home = home
        self.ik = ReferenceIK(build_robot_model(design), n, n_base, home)
        self.base_offset = self.mount_offset() if n_base else np.zeros(3)
        self.grip_in_object = Pose(design.grip_pos, design.grip_quat)
        self.handle_pos = np.asarray(design.handle_pos, dtype=float)
        self.handle_quat = handle_quat_in_object(self.rest_quat)
        m = self.model
        self._site_pos = m.site_pos[self.scene.grip_site].copy()
        self._site_quat = m.site_quat[self.scene.grip_site].copy()
        for name in ("human_handle_force", "human_handle_torque"):
            if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name) < 0:
                raise AssertionError(f"the scene lacks the sensor {name!r}")
        self.handle_force_adr, self.handle_torque_adr = (
            int(m.sensor_adr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SENSOR, name)])
            for name in ("human_handle_force", "human_handle_torque"))
        self.params = HumanParams()
        self.human = IntentionHuman(design, self.params, design.lever)
        self.impedance = HandImpedance(m, self.arm, coupling, self.posture, self.hand_gains())
        self.robot_holds = True
        self.human_holds = True
        self.start, self.goal = 0, 1
        self.q_ref = home.copy()
        self.left_start = False
        self._strained = np.zeros(1)  # the end-of-step rules' timers (carry.rules), (1,)
        self._calm = np.zeros(1)
        self.lowest_z = 0.0
        self.time = 0.0
        self.sensed = np.zeros(6)
        self.sat_counts = np.zeros(len(self.posture))
        self.meter = InteractionMeter(1, self.dt_control)
        self.period_forces = np.zeros((1, stages.PERIODS))
        self.period_velocities = np.zeros((1, stages.PERIODS, 3))
        self._interaction: StepInteraction | None = None
        self.periods = CarryPeriods(self)
        self._joint_names = self.joint_names()

    # ------------------------------------------------------------------ set-up
    def hand_gains(self) -> tuple[float, float, float, float]:
        """The hand impedance's (K, D, K_r, D_r) of the human's stiffness now."""
        d, k = self.design, self.params.stiffness
        return (k * d.human_stiffness, k * d.human_damping, k * d.human_rot_stiffness,
                k * d.human_rot_damping)

    def route(self, start: int, goal: int) -> list[Pose]:
        """The object poses of the human's route from ``start`` to ``goal``."""
        states = route_states(self.graph, start, goal, self.params.preference)
        return [Pose(*self.observer.pose(s)) for s in states]

    def reset(self, start: int, goal: int, rng: np.random.Generator,
              scenario: Scenario | None = None, human: HumanParams | None = None,
              robot_holds: bool = True) -> None:
        """The object on support ``start``, both partners holding it (the robot only if
        ``robot_holds``), the human meaning to bring it to ``goal``.

        The human's body (``human.sex``, ``stature_m``, ``body_mass_kg``) is written into
        the model (:class:`~hri_envs.physics.carry.human.body.ArmBody`: only when it changes).

        Raises:
            IKFailure: The robot cannot reach its grip (a layout it cannot serve), or the
                human's arm cannot reach the handle.
            ConfigError: A human of another drive than the sim's, or a body other than the
                default for the muscle drive (MyoSuite's arm has one anatomy).
        """
        model, data, sc, design = self.model, self.data, self.scene, self.design
        params = human if human is not None else HumanParams()
        self._set_body(params)
        mujoco.mj_resetData(model, data)
        self.set_scenario(scenario if scenario is not None else self.graph.scenario)
        self.params = params
        self.human = IntentionHuman(design, self.params, design.lever)
        self.impedance.gains = self.hand_gains()
        self.arm_drive.set_strength(self.params.strength * self.params.body.strength_scale())
        grip_force = (self.params.grip_force_n if self.params.grip_force_n is not None
                      else default_grip_force(design))
        self.arm.set_grip_force(grip_force)
        self.sensor.reset(rng.spawn(1)[0])
        self.start, self.goal = start, goal
        self.human.plan(self.route(start, goal))
        s0 = self.graph.support_state(start, BOTH)
        pos, quat = self.observer.pose(s0)
        data.qpos[sc.object_qpos] = np.concatenate([pos, quat])
        grip = compose(Pose(pos, quat), *self.grip_in_object)
        q0 = self.home.copy()
        if self.n_base:
            q0[:3] = grip.pos + self.base_offset - design.base_pos
        self.ik.reset(q0)
        if self.ik.solve(grip, iterations=300) > design.reset_grip_ik_error_max_m:
            raise IKFailure(f"the robot cannot reach its grip on support {start}")
        self.q_ref = self.ik.q
        data.qpos[sc.robot_qpos] = self.q_ref
        data.qpos[sc.finger_qpos] = FINGER_ON_GRIP_M
        self.robot_holds = robot_holds
        self.weld(robot_holds)
        if not robot_holds:  # the robot's hand waits out of the way
            data.qpos[sc.robot_qpos] = self.home if not self.n_base else q0
        # The human: torso in reach, arm on the handle, fingers closed.
        mujoco.mj_kinematics(model, data)
        hand = self._hand_pose(Pose(pos, quat))
        data.qpos[self.arm.torso_qpos] = self.arm.torso_target(
            hand.pos, self.arm.yaw_of(quat, self.rest_quat))
        data.ctrl[self.arm.torso_actuators] = data.qpos[self.arm.torso_qpos]
        reach = self.arm.solve_ik(data, hand.pos, hand.quat, self.posture)
        if reach > _REACH_ERROR_MAX_M:
            raise IKFailure(f"the human's arm cannot put its hand on the handle on support "
                            f"{start} (error {reach:.3f} m + 0.2 m/rad)")
        self.arm.close(data, True)
        data.qpos[self.arm.fingers_qpos] = 0.0
        self.human_holds = True
        if sc.platform_mocap >= 0:
            data.mocap_pos[sc.platform_mocap] = [*data.qpos[:2] + design.base_pos[:2], 0.1]
        mujoco.mj_forward(model, data)
        self.left_start, self.time = False, 0.0
        self._calm, self._strained = np.zeros(1), np.zeros(1)
        self.sensed = np.zeros(6)
        self.sat_counts[:] = 0.0
        self.meter.reset(slice(None))

    def _set_body(self, params: HumanParams) -> None:
        """Check the human's drive and put their body into the model."""
        if params.drive is not None and params.drive != self.drive_name:
            raise ConfigError(f"a human of drive {params.drive!r} cannot be simulated by a "
                              f"CarrySim of drive {self.drive_name!r}; allowed: "
                              f"{self.drive_name!r}", field="human")
        if self.body is not None:
            self.body.apply(params.body, self.data)
        elif not params.body.is_default:
            raise ConfigError("the muscle-driven arm (MyoSuite's myoarm_r) has one anatomy: "
                              "sex, stature_m and body_mass_kg must be the defaults "
                              f"({BodySize()}), got {params.body}", field="human")

    def weld(self, on: bool) -> None:
        """The robot's grasp on (the weld at the nominal grip, the fingers closed on the
        grip) or off (the fingers open); the robot fingers' contacts stay off.
        """
        sc, m, data = self.scene, self.model, self.data
        if on:
            inv_q = np.array([self._site_quat[0], *-self._site_quat[1:]])
            lever = np.empty(3)
            mujoco.mju_rotVecQuat(lever, self._site_pos, inv_q)
            rel = compose(self.grip_in_object, -lever, inv_q)
            m.eq_data[sc.weld, 0:3] = 0.0
            m.eq_data[sc.weld, 3:6] = rel.pos
            m.eq_data[sc.weld, 6:10] = rel.quat
        data.eq_active[sc.weld] = int(on)
        data.ctrl[sc.finger_actuators] = FINGER_ON_GRIP_M if on else FINGER_OPEN_M
        m.geom_contype[sc.finger_geoms.ravel()] = 0

    # ------------------------------------------------------------------ poses
    def object_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """The object's linear and angular velocity (world frame) now."""
        v = self.data.qvel[self.scene.object_dofs]
        w = np.empty(3)
        mujoco.mju_rotVecQuat(w, np.ascontiguousarray(v[3:]),
                              self.data.xquat[self.scene.object_body].copy())
        return v[:3].copy(), w

    def robot_joints(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's joint positions and velocities now."""
        n = len(self.scene.robot_dofs)
        return self.data.qpos[:n].copy(), self.data.qvel[:n].copy()

    def observation_state(self) -> np.ndarray:
        """What the continuous envs observe of the simulation, in one array (20 + 2n,): the
        object's position, quaternion (w >= 0), linear and angular velocity; the grip's
        position and quaternion (w >= 0); the robot's joint positions and velocities.
        """
        return self.periods.observe()

    def seat_positions(self) -> np.ndarray:
        """(K, 3) the supports' seats in the current layout."""
        return self.seats.pos

    def progress(self) -> float:
        """The object's progress along the human's route now."""
        return self.periods.progress(*self.object_pose())

    def _hand_pose(self, obj: Pose) -> Pose:
        """The human's grip frame when it holds the handle of the object at ``obj``."""
        return compose(obj, self.handle_pos, self.handle_quat)

    def human_grip_reference(self) -> Pose:
        """Where the robot's grip would be with the object at the human's reference now
        (what an upper reference that knows the intention follows).
        """
        return Pose(*self.periods.grip_reference(self.grip_in_object))

    def command(self, action: np.ndarray) -> RobotCommand:
        """The robot's command for an action in [-1, 1]^7 (grip offset, rotation, stiffness)."""
        a = np.asarray(action, dtype=float)
        out = np.empty(7)
        g = self.scene.grip_site
        laws.grip_target(self.data.site_xpos[g:g + 1], self.data.site_xmat[g:g + 1], a[None],
                         self.max_step_m, self.max_step_rad, out[None])
        return RobotCommand(Pose(out[:3], out[3:]), (float(a[6]) + 1.0) / 2.0)

    # ------------------------------------------------------------------ step
    def human_command(self, action: np.ndarray) -> RobotCommand:
        """The human agent's command for an action in [-1, 1]^7: a target for their hand's
        grip frame relative to where it is (like the robot's) and their stiffness scale.
        """
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.data.site_xmat[self.arm.grip_site])
        hand = Pose(self.data.site_xpos[self.arm.grip_site].copy(), q)
        a = np.asarray(action, dtype=float)
        return RobotCommand(Pose(hand.pos + self.max_step_m * a[:3],
                                 _rotate(hand.quat, self.max_step_rad * a[3:6])),
                            (float(a[6]) + 1.0) / 2.0)

    def step(self, cmd: RobotCommand, human_cmd: RobotCommand | None = None) -> CarryStep:
        """Simulate one 40 ms step with the robot's command; ``human_cmd`` (the human
        seat's agent, :meth:`human_command`) replaces the scripted human's reference for
        the step (their impedance's stiffness scaled by its stiffness).
        """
        data, sc, lever = self.data, self.scene, self.design.lever
        motion = np.empty(19)  # the grip now, the translation and rotation, their rates
        g = sc.grip_site
        laws.grip_motion(data.site_xpos[g:g + 1], data.site_xmat[g:g + 1],
                         np.asarray(cmd.target.pos, float)[None],
                         np.asarray(cmd.target.quat, float)[None], self.dt_step, motion[None])
        start_grip = Pose(motion[:3], motion[3:7])
        stiff = cmd.stiffness > 1e-3 and self.robot_holds
        robot_q = data.qpos[:len(sc.robot_qpos)]
        try:
            if stiff:
                self.q_ref = self.ik.step(cmd.target, self.dt_step).copy()
            else:
                self.ik.reset(robot_q.copy())
                self.q_ref = self.ik.step(start_grip, self.dt_step).copy()
        except IKFailure as exc:
            self._interaction = None
            return self._result(0.0, 0.0, 0.0, f"ik_failure: {exc}")
        weight = self.design.object_mass * 9.81
        start_obj = data.xpos[sc.object_body].copy()
        command, gains = None, tuple(self.impedance.gains)
        if human_cmd is not None:
            q = np.empty(4)
            mujoco.mju_mat2Quat(q, data.site_xmat[self.arm.grip_site])
            hand0 = Pose(data.site_xpos[self.arm.grip_site].copy(), q)
            command = np.concatenate([hand0.pos, hand0.quat, human_cmd.target.pos - hand0.pos,
                                      rotation_error(human_cmd.target.quat, hand0.quat)])
            gains = tuple(g * human_cmd.stiffness for g in self.hand_gains())
        res = self.periods.run(motion, min(cmd.stiffness, 1.0), stiff, command, gains)
        self.sensed = res.sensed
        fault = check_faults(self, data.xpos[sc.object_body], res)
        self.time += self.dt_step
        self.sat_counts = res.sat
        self._interaction = StepInteraction(*(np.array([x]) for x in res.interaction))
        if fault is None and not self.robot_holds:
            weak = rules.strain_update(self._strained, res.sat[None], start_obj[None],
                                       self.object_pose().pos[None], self.dt_step, weight,
                                       lambda _: np.array([self.max_lift_n()]))
            if weak[0]:
                fault = rules.fault_message(rules.FAULT_TOO_WEAK, why=why_slipped(self))
        if sc.platform_mocap >= 0:
            data.mocap_pos[sc.platform_mocap, :2] = data.qpos[:2] + self.design.base_pos[:2]
        return self._result(res.lin, res.ang, res.disagree, fault, lever, res)

    def handle_wrench(self) -> tuple[np.ndarray, np.ndarray]:
        """The hand's force [N] and torque [N m] on the handle, in the world (torque about
        the handle's centre).
        """
        d, site = self.data, self.arm.handle_site
        rot = d.site_xmat[site].reshape(3, 3)
        f, t = self.handle_force_adr, self.handle_torque_adr
        return -rot.dot(d.sensordata[f:f + 3]), -rot.dot(d.sensordata[t:t + 3])

    def joint_names(self) -> list[str]:
        """The names of the arm's driven joints."""
        return [mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_JOINT, int(j))
                for j in self.arm.arm_joints]

    def max_lift_n(self) -> float:
        """The largest upward force [N] the hand can hold statically in the current posture
        within the human's strength (:func:`~hri_envs.physics.carry.faults.max_lift_n`).
        """
        return max_lift_n(self)

    def _result(self, lin: float, ang: float, disagree: float, fault: str | None,
                lever: float | None = None, res: PeriodsResult | None = None) -> CarryStep:
        lever = self.design.lever if lever is None else lever
        if res is not None:  # the step's periods measured it all
            progress, seat, slow = res.progress, res.seat, res.slow
        else:
            pose = self.object_pose()
            progress = self.periods.progress(pose.pos, pose.quat)
            seat = self.seats.engaged(pose.pos, pose.quat)
            v = self.data.qvel[self.scene.object_dofs]
            slow = (float(v[:3].dot(v[:3])) < stages.VEL_SQ_MAX
                    and float(v[3:].dot(v[3:])) < stages.ANGVEL_SQ_MAX)
        placed = np.empty(1, np.int64)
        rules.calm_update(self._calm, np.array([seat]), np.array([self.left_start]),
                          np.array([slow]), self.dt_step, placed)
        sat = tuple(rules.saturated_joints(self._joint_names, self.sat_counts,
                                           stages.PERIODS / 2))
        inter = self._interaction
        extra = (0.0, 0.0, 0.0) if inter is None else (
            float(inter.peak_force[0]), float(inter.force_sq[0]), float(inter.jerk_sq[0]))
        return CarryStep(progress, lin + ang / lever, lin, ang, disagree, self.sensed.copy(),
                         int(placed[0]), fault, sat, *extra)


def default_grip_force(design: PhysicsDesign) -> float:
    """The default grip force [N]: enough for the object's weight about 4 times over with
    friction 1 on palm and fingers.
    """
    return max(20.0, 8.0 * design.object_mass * 9.81)
