"""The physics backend's core: one abstract step of both agents on the simulated Panda.

:class:`PandaSim` owns the MuJoCo model and data. :meth:`PandaSim.step` takes the observed
abstract state and both agents' abstract actions and runs them physically:

1. *grasp toggles*: the robot approaches its grip on the object and closes its fingers; the
   grasp holds (weld on) only once both fingers press on the object's grip geometry, else
   it fails; or it opens (weld off) and retreats; the human's grasp welds their hand on or
   off;
2. an action that is not valid in the state after the toggles is refused by its agent's
   skill layer, and a refused action aborts the step's motion for both (the graph's rule);
   with ``physics={"attempt_invalid": True}`` the robot's skill layer refuses nothing: it
   tries any grasp toggle or motion (:meth:`PandaSim.motion_target`) and the physics
   decides what happens (the human still refuses what is invalid for them);
3. *motions*: the robot tracks a straight line from the actual grip pose to the target
   state's pose with the impedance controller; the simulated human's arm pulls it towards
   their own target; disagreement makes the robot yield (:class:`Disagreement`);
4. the step ends when the object has settled (slow for ``settle_calm_time_s`` with both
   agents done), or at a time limit; the observed state is the closest abstract state, and
   the human's action is inferred from the transition.

The robot senses the human only through its wrist force/torque sensor
(:mod:`~hri_envs.physics.scene.sensing`): the disagreement-aware impedance, the human-action
inference and the reported impulses use the sensed wrench; the true ones are reported beside
them (``*_true``).

Faults end the step with ``fault`` set (``"<kind>: <detail>"``) instead of raising; their
kinds, the step's plan and its result are in :mod:`~hri_envs.physics.panda.steps`. The
robot's grasp (the weld, closing on the grip) is the base :class:`~hri_envs.physics.panda.
grasp.PandaGrasp`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np

from hri_envs.physics.panda.grasp import PandaGrasp
from hri_envs.physics.panda.human import SimulatedHuman
from hri_envs.physics.panda.human_arm import HandleSensor, HumanArm, add_human_arm
from hri_envs.physics.panda.options import PhysicsParams, PhysicsSettings
from hri_envs.physics.panda.steps import (
    PHYSICAL_FAULTS,
    StepFault,
    StepPlan,
    StepResult,
    StepTotals,
    plan_step,
)
from hri_envs.physics.scene.build import (
    FINGER_ON_GRIP_M,
    FINGER_OPEN_M,
    build_robot_model,
    build_scene,
)
from hri_envs.physics.scene.contacts import touches
from hri_envs.physics.scene.controller import Disagreement, ImpedanceController
from hri_envs.physics.scene.design import PhysicsDesign, design_for
from hri_envs.physics.scene.ik import IKFailure, ReferenceIK
from hri_envs.physics.scene.kinematics import Pose, StraightLine, TrajectorySample, compose
from hri_envs.physics.scene.observer import StateObserver, infer_human_action
from hri_envs.physics.scene.seats import Seats
from hri_envs.physics.scene.sensing import SensorModel, WristSensor
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import (
    BOTH,
    HUMAN_BIT,
    PUT_ON,
    ROBOT_BIT,
    TAKE_OFF,
    TOGGLE,
    WAIT,
    TaskGraph,
)

__all__ = ["PHYSICAL_FAULTS",
           "PandaSim", "StepPlan", "StepResult", "plan_step"]

# Physical thresholds and times are fields of PhysicsDesign; these are fixed by the model.
_PLATFORM_Z_M = 0.1  # [m] height of the mobile base's floor platform mocap (scene.py)
# Numerical method: iterations of the reset IK solve onto the grip and the waiting pose.
_RESET_GRIP_IK_ITERATIONS = 300
_RESET_PREGRASP_IK_ITERATIONS = 200


class PandaSim(PandaGrasp):
    """A simulated Panda and a simulated human carrying the scenario's object.

    Args:
        graph: The task graph (state and action numbering, transitions).
        design: Physical design (default: :func:`design_for` the graph's scenario).
        ik_rate: Rate [Hz] of the IK reference updates.
        options: Validated ``physics`` options (:mod:`~hri_envs.physics.panda.options`; keys
            listed in docs/physics.md), applied at each :meth:`reset`.

    Attributes:
        lowest_z: [m] the lowest support point of the scenario's layout.
    """

    def __init__(self, graph: TaskGraph, design: PhysicsDesign | None = None,
                 ik_rate: float = 25.0, options: Mapping[str, Any] | None = None) -> None:
        self.graph = graph
        self.design = design = design if design is not None else design_for(graph)
        self.scenario = graph.scenario
        self.scene = build_scene(self.scenario, design,
                                 functools.partial(add_human_arm, design=design))
        self.model = self.scene.model
        self.init_data()
        # IK reference updates, in control periods.
        self.ik_every = max(1, round(1.0 / (ik_rate * self.dt_control)))
        self.controller = ImpedanceController(self.scene)
        self.davi = Disagreement(design)
        self.human = SimulatedHuman(design, np.random.default_rng(0))
        self.arm = HumanArm(self.model, design, self.scenario.orientations[0])
        self.seats = Seats(self.scenario, design)
        self.observer = StateObserver(graph, self.scenario, design.lever)
        self.settings = PhysicsSettings(design, options)
        self.sensor = WristSensor(self.scene, SensorModel(
            design.sensor_noise_n, design.sensor_bias_n, design.sensor_delay_s,
            design.sensor_torque_lever_m, self.dt_control))
        self.handle = HandleSensor(self.model, design.hold_touch_min_n)
        self.params = PhysicsParams.of(design)
        self._apply(self.settings.base)
        n, n_base = len(self.scene.robot_dofs), 3 if design.mobile_base else 0
        self.n_base = n_base
        home = np.zeros(n)
        home[n_base:] = design.home
        self.ik = ReferenceIK(build_robot_model(design), n, n_base, home)
        self.home = home
        self.base_offset = self.mount_offset() if n_base else np.zeros(3)
        self.init_grasp()
        self.on_frame: Callable[[], None] | None = None
        self.frame_every = 50
        self.state = 0
        self.holding = False
        self.q_ref = home.copy()

    # ------------------------------------------------------------------ poses
    def state_grip_pose(self, state: int) -> Pose:
        """The grip frame when the object is at abstract ``state``."""
        pos, quat = self.observer.pose(state)
        return compose(Pose(pos, quat), *self.grip_in_object)

    # ------------------------------------------------------------------ reset
    def _apply(self, params: PhysicsParams) -> None:
        """Use ``params`` from now on: the true human, seats, mass and the sensor model."""
        self.params = params
        true = params.true_design(self.design)
        self.human.design = true
        self.arm.apply(true)
        self.seats.design = true
        b = self.scene.object_body
        self.model.body_mass[b] = true.object_mass
        self.model.body_inertia[b] = true.object_inertia
        self.sensor.model = SensorModel(params.sensor_noise_n, params.sensor_bias_n,
                                        params.sensor_delay_s,
                                        self.design.sensor_torque_lever_m, self.dt_control)

    def reset(self, start: int, scenario: Scenario | None = None,
              rng: np.random.Generator | None = None, state: int | None = None) -> int:
        """Object on support ``start`` (μ = 0), the robot's hand waiting next to its grip.

        Args:
            start: The support the episode starts on.
            scenario: The episode's geometry (default: the graph's).
            rng: Generator of the human's force noise (and, through streams spawned from
                it, of the sensor's noise and bias and of randomised physics options).
            state: Place the object in this abstract state instead (for tests and tools):
                held as its μ says, the robot's hand on its grip when the robot holds.

        Returns:
            The observed abstract state.

        Raises:
            IKFailure: The robot cannot reach its pose (a layout it cannot serve).
        """
        model, data, sc, design = self.model, self.data, self.scene, self.design
        mujoco.mj_resetData(model, data)
        self.set_scenario(scenario if scenario is not None else self.graph.scenario)
        rng = rng if rng is not None else np.random.default_rng(0)
        sensor_rng, options_rng, handle_rng = rng.spawn(3)
        self._apply(self.settings.draw(options_rng))
        self.human.reset(rng)
        self.sensor.reset(sensor_rng)
        self.handle.reset(handle_rng, self.params.handle_noise_n)
        self.davi.reset()
        s0 = self.graph.support_state(start, 0) if state is None else int(state)
        mu = int(self.graph.grasp[s0])
        pos, quat = self.observer.pose(s0)
        data.qpos[sc.object_qpos] = np.concatenate([pos, quat])
        grip = self.state_grip_pose(s0)
        target = grip if mu & ROBOT_BIT else self.pregrasp(grip)
        q0 = self.home.copy()
        if self.n_base:
            q0[:3] = target.pos + self.base_offset - design.base_pos
        self.ik.reset(q0)
        # Reach the grip first, then back off to the waiting pose (a hand-held retreat);
        # the waiting pose only needs to be near, the grasp approach starts from it.
        grip_error_m = self.ik.solve(grip, iterations=_RESET_GRIP_IK_ITERATIONS)
        if grip_error_m > design.reset_grip_ik_error_max_m or (
                target is not grip
                and self.ik.solve(target, iterations=_RESET_PREGRASP_IK_ITERATIONS)
                > design.reset_pregrasp_ik_error_max_m):
            raise IKFailure(f"the robot cannot reach its pose in state {s0}")
        self.q_ref = self.ik.q
        data.qpos[sc.robot_qpos] = self.q_ref
        data.qpos[sc.finger_qpos] = FINGER_ON_GRIP_M if mu & ROBOT_BIT else FINGER_OPEN_M
        data.eq_active[sc.weld] = 0
        self.weld(bool(mu & ROBOT_BIT))
        self.human.holding = bool(mu & HUMAN_BIT)
        self.arm.place(data, pos, quat, self.human.holding)
        if sc.platform_mocap >= 0:
            data.mocap_pos[sc.platform_mocap] = [*data.qpos[:2] + design.base_pos[:2],
                                                 _PLATFORM_Z_M]
        mujoco.mj_forward(model, data)
        self.state = s0
        return s0

    # ------------------------------------------------------------------ step
    def step(self, s: int, a_r: int, a_h: int) -> StepResult:
        """Run one abstract step with the robot's action ``a_r`` and the human's ``a_h``.

        Args:
            s: The abstract state observed before the step (the last step's ``state``).
            a_r: The robot's abstract action.
            a_h: The simulated human's true abstract action.

        Returns:
            The observed next state, the inferred human action, the graph's prediction,
            impulses, duration and, if the simulation cannot go on, the fault.
        """
        g = self.graph
        t0 = float(self.data.time)
        totals = StepTotals()
        fault: str | None = None
        yielded = settled = False
        toggle_ok = bool(g.valid[s, TOGGLE])
        attempt = self.settings.attempt_invalid
        robot_toggle = a_r == TOGGLE and (toggle_ok or attempt)
        human_toggle, s1, robot_moves, human_moves = plan_step(g, s, a_r, a_h, attempt)
        try:
            if robot_toggle:
                self._robot_toggle(totals)
            if human_toggle:  # grasp or let go, as the human meant from the state they see
                self.human.holding = bool(g.grasp[int(g.next_state[s, WAIT, TOGGLE])]
                                          & HUMAN_BIT)
            self.arm.hold(self.data, self.human.holding)  # the hand's weld is the grasp bit
            line = None
            if robot_moves:
                goal = self.state_grip_pose(self.motion_target(s1, a_r))
                design = self.design
                line = StraightLine(self.grip_pose(), goal, design.linear_speed,
                                    design.angular_speed, design.motion_min_duration_s)
            if human_moves:
                pos, quat = self.observer.pose(int(g.next_state[s1, WAIT, a_h]))
                self.human.reach(self.object_pose(), Pose(pos, quat))
            else:
                self.human.stop()
            # Holding and not moving: passive (the human may move the object); idle: stiff.
            hold = None if (self.holding or robot_moves) else self.grip_pose()
            settled, yielded = self._run(line, hold, totals, self.design.step_time_limit)
        except StepFault as exc:
            fault = str(exc)
        except IKFailure as exc:
            fault = f"ik_failure: {exc}"
        self.human.stop()
        pose = self.object_pose()
        grasp = (ROBOT_BIT if self.holding else 0) | (HUMAN_BIT if self.human.holding else 0)
        # The robot knows its own grasp and reads the human's off the handle's touch sensor.
        human_seen = self.handle.human_holds(self.data)
        seat = self.seats.engaged(pose.pos, pose.quat)
        obs = self.observer.observe(pose.pos, pose.quat, seat,
                                    (grasp & ROBOT_BIT) | (HUMAN_BIT if human_seen else 0))
        design = self.design
        far = (obs.position_error > design.timeout_fault_factor * design.position_tolerance
               or obs.angle_error > design.timeout_fault_factor * design.angle_tolerance)
        if fault is None and seat < 0 and not grasp:
            fault = "dropped: nobody holds the object and no support carries it"
        if fault is None and seat < 0 and grasp not in (0, BOTH):  # attempted actions only
            fault = ("off_support: only the " + ("robot" if grasp == ROBOT_BIT else "human")
                     + " holds the object away from every support")
        if fault is None and far:
            fault = ("off_support: the object " + ("settled" if settled else "stopped")
                     + " far from every abstract state")
        if not np.all(np.isfinite(self.data.qpos)):
            fault = "unstable: the simulation diverged (NaN)"
        graph_next = int(g.next_state[s, a_r, a_h])
        a_h_seen = infer_human_action(g, s, a_r, obs.state, float(totals.human_work),
                                      design.human_work_min_j)
        self.state = obs.state
        return StepResult(obs.state, a_h_seen, graph_next, obs.state == graph_next, settled,
                          float(self.data.time) - t0, float(totals.linear_impulse),
                          float(totals.angular_impulse), yielded, obs.position_error,
                          obs.angle_error, fault, float(totals.linear_impulse_true),
                          float(totals.angular_impulse_true), self.human.holding, human_seen)

    def motion_target(self, s: int, a: int) -> int:
        """The abstract state whose pose the robot's motion ``a`` aims at from ``s``.

        A valid motion aims where the graph leads. An invalid one (tried only with
        ``physics={"attempt_invalid": True}``) aims where it would lead if it were valid:
        from a support as if both held the object (take off: to the mounting; the other
        motions: from the mounting), put on from elsewhere than the mounting: straight onto
        the column's support; any other: where the object already is (no motion).
        """
        g = self.graph
        if g.valid[s, a]:
            return int(g.next_state[s, a, WAIT])
        k = int(g.support[s])
        if k >= 0:
            mount = int(g.next_state[g.support_state(k, BOTH), TAKE_OFF, WAIT])
            return mount if a == TAKE_OFF else int(g.next_state[mount, a, WAIT])
        if a == PUT_ON:
            return g.support_state(int(g.column[s]), BOTH)
        return s

    def _run(self, line: StraightLine | None, hold: Pose | None, totals: StepTotals,
             limit_s: float, min_time_s: float | None = None) -> tuple[bool, bool]:
        """Simulate until settled or ``limit_s`` seconds; (settled, robot yielded).

        ``min_time_s`` (default: the design's ``settle_min_time_s``) is the shortest time
        before the motion can settle; ``totals`` accumulates the human's impulses and work.
        The control loop runs once per control period (``control_every_steps`` physics
        steps): it reads the state, sets the robot's torques, the seat's wrench and the
        human's actuator references, and MuJoCo runs the period's physics steps in C.
        """
        model, data, sc, design = self.model, self.data, self.scene, self.design
        dt_c, k, body = self.dt_control, self.control_every, sc.object_body
        if min_time_s is None:
            min_time_s = design.settle_min_time_s
        vel_sq_max, angvel_sq_max = (design.settle_vel_sq_max_m2_s2,
                                     design.settle_angvel_sq_max_rad2_s2)
        drop_z = self.lowest_z - design.drop_margin_m
        sensor, overload, human, arm = self.sensor, 0.0, self.human, self.arm
        # Periodic work, in control periods.
        check_every = max(1, design.stability_check_every_steps // k)
        platform_every = max(1, design.platform_update_every_steps // k)
        frame_every = max(1, round(self.frame_every / k))
        ik_every, dt_ik = self.ik_every, self.ik_every * dt_c
        self.davi.reset()
        hold_ref = None if hold is None else TrajectorySample(hold.pos, hold.quat, np.zeros(3),
                                                              np.zeros(3))
        xfrc = data.xfrc_applied[body]
        xfrc[:] = 0.0  # no seat wrench left over from the last run
        # Views into data's arrays (their memory is fixed), set up once per run: pos and
        # quat follow the simulation; qv, vel and angvel are copies taken each period.
        pos, quat = data.xpos[body], data.xquat[body]
        rot = data.xmat[body].reshape(3, 3)
        dof0 = int(sc.object_dofs[0])
        qvel_object = data.qvel[dof0:dof0 + 6]  # a free joint's dofs are contiguous
        qv = np.empty(6)
        vel, angvel = qv[:3], np.empty(3)
        acts = sc.robot_actuators
        ctrl = (data.ctrl[acts[0]:acts[0] + len(acts)]
                if np.array_equal(acts, np.arange(acts[0], acts[0] + len(acts))) else None)
        robot_q = data.qpos[:len(sc.robot_qpos)]  # they lead qpos (ImpedanceController)
        platform = sc.platform_mocap >= 0
        controller = self.controller
        seat_on = yielded = False
        t_line = elapsed = calm = ik_bad = 0.0
        i = 0
        while elapsed < limit_s:
            mujoco.mj_step1(model, data)
            qv[:] = qvel_object
            mujoco.mju_rotVecQuat(angvel, qv[3:], quat)
            # The human: their reference drives the arm's actuators (MuJoCo applies them).
            ref_h = human.advance(dt_c)
            arm.drive(data, pos, quat, human.holding, ref_h, human.noise)
            w_h = arm.wrench(data, pos)  # the muscles' wrench of the last physics step
            # What the robot senses (the reading of the last physics step): the external
            # wrench on the held object, compensated, biased, noisy, delayed.
            sensed = sensor.external(data, self.holding, pos, rot)
            if self.holding:
                overload = self._grip_overload(overload)
            seat_on = self._seat_wrench(xfrc, pos, quat, vel, angvel, seat_on)
            scale, ref = 1.0, hold_ref
            if line is not None and not yielded:
                scale, ref = self._follow(line, t_line, sensed)
                yielded = self.davi.yielded
                t_line += dt_c * scale
            if yielded:
                ref = None
            if i % ik_every == 0:
                ik_bad = self._update_ik(ref, line is not None, dt_ik, ik_bad, robot_q)
            tau = controller.torques(data, ref, self.q_ref, scale, self.holding)
            if ctrl is not None:
                ctrl[:] = tau
            else:
                data.ctrl[acts] = tau
            mujoco.mj_step2(model, data)
            if k > 1:  # the rest of the control period, torques and references held
                mujoco.mj_step(model, data, nstep=k - 1)
            elapsed += dt_c
            i += 1
            totals.add(sensed, w_h, vel, angvel, dt_c)
            if platform and i % platform_every == 0:
                data.mocap_pos[sc.platform_mocap, :2] = data.qpos[:2] + design.base_pos[:2]
            if self.on_frame is not None and i % frame_every == 0:
                self.on_frame()
            if i % check_every == 0:
                self._check_in_place(pos, drop_z)
            slow = vel.dot(vel) < vel_sq_max and angvel.dot(angvel) < angvel_sq_max
            robot_done = line is None or yielded or t_line >= line.duration
            if slow and robot_done and elapsed >= min_time_s and human.at_target(pos, quat):
                calm += dt_c
                if calm >= design.settle_calm_time_s:
                    return True, yielded
            else:
                calm = 0.0
        self._check_stable()
        return False, yielded

    def _grip_overload(self, overload: float) -> float:
        """How long [s] the held grip has been pulled beyond its hold, one control period on
        from ``overload`` (0 while the pull is within it).

        Raises:
            StepFault: ``pulled_out`` past ``grip_overload_time_s`` (the weld lets go).
        """
        f_true, design = self.sensor.true_wrench[:3], self.design
        overload = (overload + self.dt_control
                    if f_true.dot(f_true) > design.grip_hold_force_n ** 2 else 0.0)
        if overload > design.grip_overload_time_s:
            self.weld(False)
            raise StepFault(f"pulled_out: {np.sqrt(f_true @ f_true):.0f} N on the grip")
        return overload

    def _seat_wrench(self, xfrc: np.ndarray, pos: np.ndarray, quat: np.ndarray,
                     vel: np.ndarray, angvel: np.ndarray, seat_on: bool) -> bool:
        """The engaged seat's wrench on the object into ``xfrc`` (cleared when the seat that
        acted lets go); whether a seat acts.
        """
        seat = self.seats.engaged(pos, quat)
        if seat >= 0:  # the seat acts at the centre of mass: no lever, no stiff coupling
            f_seat, t_seat = self.seats.wrench(seat, pos, quat, vel, angvel)
            xfrc[:3] = f_seat
            xfrc[3:] = t_seat
            return True
        if seat_on:
            xfrc[:] = 0.0
        return False

    def _follow(self, line: StraightLine, t_line: float, sensed: np.ndarray
                ) -> tuple[float, TrajectorySample]:
        """The robot's reference on ``line`` at ``t_line`` and the disagreement-aware
        impedance's scale for the ``sensed`` wrench (0 along an ended line's direction).
        """
        davi, zero = self.davi, np.zeros(3)
        moving = t_line < line.duration
        u = line.direction if moving else zero
        a = line.axis if moving else zero
        scale = davi.update(davi.force(sensed[:3], sensed[3:], u, a), self.dt_control)
        return scale, line.sample(t_line)

    def _update_ik(self, ref: TrajectorySample | None, tracking: bool, dt_ik: float,
                   ik_bad: float, robot_q: np.ndarray) -> float:
        """The IK reference ``q_ref`` one update on, towards ``ref`` (None: the grip where it
        is); how long [s] the IK has been too far from a tracked line, from ``ik_bad``.

        Raises:
            IKFailure: It is too far for longer than ``ik_error_time_max_s``.
        """
        ik, design = self.ik, self.design
        if ref is None:  # passive: the posture reference starts from the actual arm (no
            ik.reset(robot_q)  # self-motion runs away)
        target = Pose(ref.pos, ref.quat) if ref is not None else self.grip_pose()
        self.q_ref = ik.step(target, dt_ik).copy()
        if ref is not None and tracking:
            ik_bad = (ik_bad + dt_ik if ik.error() > design.ik_error_max_m else 0.0)
            if ik_bad > design.ik_error_time_max_s:
                raise IKFailure("the IK reference cannot follow the trajectory")
        return ik_bad

    def _check_in_place(self, pos: np.ndarray, drop_z: float) -> None:
        """Stable, and the object off the floor and above ``drop_z``.

        Raises:
            StepFault: ``unstable`` or ``dropped``.
        """
        self._check_stable()
        floor = touches(self.data, self.scene.floor_geom)
        if floor or pos[2] < drop_z:
            raise StepFault("dropped: the object " + ("hit the floor" if floor
                                                      else "fell below every state"))

    def _check_stable(self) -> None:
        data = self.data
        if (data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
                or data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number > 0):
            raise StepFault("unstable: MuJoCo reported bad accelerations or velocities")
        if (not np.all(np.isfinite(data.qvel))
                or np.abs(data.qvel).max() > self.design.diverged_qvel_max):
            raise StepFault("unstable: the simulation diverged")
