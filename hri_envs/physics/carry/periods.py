"""A :class:`~hri_envs.physics.carry.sim.CarrySim`'s control periods: the compiled stages bound to
its model, data, indices and buffers.

:class:`CarryPeriods` runs a step's five control periods with
:func:`~hri_envs.physics.carry.stages.carry_step` (one compiled call) for the torque-driven
arm, and period by period through the same stages for the muscle-driven arm, whose drive
solves a least-squares problem in Python (scipy) each period. It holds the human's route as
arrays (:class:`~hri_envs.physics.carry.human.laws.RouteArrays`, brought up to date with the
simulation's :class:`~hri_envs.physics.carry.human.intention.IntentionHuman` at each call).

The wrist sensor's model (bias, white noise, delay line,
:class:`~hri_envs.physics.scene.sensing.SensorModel`) is applied to the five compensated wrenches
in order, as each period would have (only the last reading is the step's): in the compiled
step without a delay line (the noise of the five periods drawn at once, the same numbers),
by the model itself otherwise.
"""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from hri_envs.physics.carry.human import laws as hl
from hri_envs.physics.carry.stages import (
    ANGVEL_SQ_MAX,
    PERIODS,
    VEL_SQ_MAX,
    after_stage,
    carry_step,
    human_stage,
    object_angvel,
    observe,
    robot_stage,
    tail_stage,
)
from hri_envs.physics.scene import laws

if TYPE_CHECKING:
    from hri_envs.physics.carry.sim import CarrySim

__all__ = ["CarryPeriods", "PeriodsResult"]


class PeriodsResult:
    """What a step's control periods did (one world).

    Attributes:
        lin, ang, disagree: ∫ |F| dt [N s], ∫ |τ| dt [N m s], ∫ max(0, -(F·v + τ·ω)) dt [J]
            of the hand's wrench on the handle.
        sat: (n,) how many periods each arm joint was at its strength limit.
        sensed: (6,) the wrist's last reading; true: (5, 6) the compensated wrenches.
        finite: The state is finite; off, angle: the handle off the hand's grip [m], [rad].
        progress: The route progress; seat: the seat holding the object (-1: none); slow:
            the object is slow.
        interaction: The step's peak force, ∫ |F|² dt and ∫ |jerk|² dt (samples in the
            simulation's ``period_forces``, ``period_velocities``).
    """

    def __init__(self, acc: np.ndarray, sat: np.ndarray, sensed: np.ndarray,
                 true: np.ndarray, post: np.ndarray) -> None:
        self.lin, self.ang, self.disagree = acc[0].tolist()
        self.sat, self.sensed, self.true = sat, sensed, true
        f, self.off, self.angle, self.progress, seat, slow, *self.interaction = post.tolist()
        self.finite, self.seat, self.slow = f > 0.0, int(seat), slow > 0.0


class CarryPeriods:
    """A :class:`~hri_envs.physics.carry.sim.CarrySim`'s control periods, compiled.

    Args:
        sim: The simulation (its model, data, scene, arm, drive, controller, sensor, seats;
            the human is read at each step: a reset makes a new one).
    """

    def __init__(self, sim: CarrySim) -> None:
        m, d, sc, arm, design = sim.model, sim.data, sim.scene, sim.arm, sim.design
        self.sim = sim
        self.torque = sim.drive_name == "torque"
        self.k, self.dt_c, self.dt_step = sim.control_every, sim.dt_control, sim.dt_step
        self.data = (d.qpos, d.qvel, d.xpos, d.xquat, d.xmat, d.xipos, d.site_xpos,
                     d.site_xmat, d.subtree_com, d.sensordata, d.qfrc_bias, d.ctrl,
                     d.xfrc_applied)
        sensor = sim.sensor
        self.ids = np.array([sc.object_body, sc.object_dofs[0], arm.grip_site, sensor.site,
                             sc.hand_body, sensor.force_adr, sensor.torque_adr, sc.grip_site,
                             sim.handle_force_adr, sim.handle_torque_adr, arm.handle_site],
                            dtype=np.int64)
        if not np.array_equal(sc.object_dofs, sc.object_dofs[0] + np.arange(6)):
            raise ValueError("the object's free joint must have consecutive dofs")
        self.torso_acts = np.asarray(arm.torso_actuators, dtype=np.int64)
        acts = getattr(sim.arm_drive, "actuators", np.zeros(0))
        self.arm_acts = np.asarray(acts, dtype=np.int64)
        self.arm_qpos = np.asarray(arm.arm_qpos, dtype=np.int64)
        self.arm_dofs = np.asarray(arm.arm_dofs, dtype=np.int64)
        self.robot_acts = np.asarray(sc.robot_actuators, dtype=np.int64)
        n = len(self.arm_qpos)
        self.coupling = np.eye(n)[None]  # the torque-driven arm's own coordinates
        self.route = hl.RouteArrays(1, design.lever)
        imp = sim.impedance
        self.human_k = np.concatenate([sim.handle_pos, sim.handle_quat,
                                       sim.rest_quat]).astype(float)
        self.posture, self.kn_h, self.dn_h = imp.posture, float(imp.kn), float(imp.dn)
        self.weight_n = design.object_mass * 9.81
        self.sensor_k = np.concatenate([sensor.hand_weight, sensor.object_weight,
                                        sensor.object_com]).astype(float)
        seats = sim.seats
        self.capture, self.max_angle = float(seats.capture), float(seats.max_angle)
        self.seat_gains = np.array([design.seat_stiffness, design.seat_damping,
                                    design.seat_rot_stiffness, design.seat_rot_damping,
                                    design.seat_fade_m], dtype=float)
        self.hold = np.array([design.seat_hold], dtype=float)
        ctl = sim.controller
        self.robot_gains = np.array([*design.stiffness, *design.damping,
                                     *design.passive_damping], dtype=float)
        self.weight = np.asarray(ctl.weight, dtype=float)
        self.kn, self.dn = ctl.kn, ctl.dn
        self.tau_hi = np.asarray(sc.torque_limit, dtype=float)
        nv = m.nv
        self.hjac, self.rjac = np.zeros((1, 6, nv)), np.zeros((1, 6, nv))
        self.cjac = np.zeros((1, 3, nv))
        self.rhs, self.minv = np.zeros((1, 7, nv)), np.zeros((1, 7, nv))
        self.addr = (m._address, d._address)
        self._bind_args()

    def _bind_args(self) -> None:
        """:func:`carry_step`'s arguments that stay (a list, the step's set in place)."""
        sim, r, meter = self.sim, self.route, self.sim.meter
        names = list(inspect.signature(getattr(carry_step, "py_func", carry_step)).parameters)
        self._slot = {name: i for i, name in enumerate(names)}
        self._true, self._acc = np.zeros((PERIODS, 6)), np.zeros((1, 3))
        self._sat, self._left = np.zeros((1, len(self.arm_qpos))), np.zeros(1, dtype=np.bool_)
        self._sensed, self._post = np.zeros(6), np.zeros(9)
        fixed = dict(
            k=self.k, dt_c=self.dt_c, dt_step=self.dt_step, m=self.addr[0], d=self.addr[1],
            **dict(zip(("qpos", "qvel", "xpos", "xquat", "xmat", "xipos", "site_xpos",
                        "site_xmat", "subtree_com", "sensordata", "qfrc_bias", "ctrl", "xfrc"),
                       self.data, strict=True)),
            ids=self.ids, torso_acts=self.torso_acts, arm_acts=self.arm_acts,
            arm_qpos=self.arm_qpos, arm_dofs=self.arm_dofs, robot_acts=self.robot_acts,
            coupling=self.coupling, grid=r.grid, phase=r.phase, lever=r.lever,
            human_k=self.human_k, weight_n=self.weight_n, posture=self.posture,
            kn_h=self.kn_h, dn_h=self.dn_h, sensor_k=self.sensor_k, capture=self.capture,
            max_angle=self.max_angle, seat_gains=self.seat_gains, hold=self.hold,
            robot_gains=self.robot_gains, weight=self.weight, kn=self.kn, dn=self.dn,
            tau_hi=self.tau_hi, hjac=self.hjac, rjac=self.rjac, cjac=self.cjac, rhs=self.rhs,
            minv=self.minv, noise_lever=sim.sensor.model.lever, v_prev=meter.v_prev,
            a_prev=meter.a_prev, samples=meter.samples, true=self._true, acc=self._acc,
            forces=sim.period_forces, velocities=sim.period_velocities, sat=self._sat,
            left=self._left,
            sensed=self._sensed, post=self._post)
        self._args: list[Any] = [None] * len(names)
        for name, value in fixed.items():
            self._args[self._slot[name]] = value

    def _human_args(self, command: np.ndarray) -> tuple[Any, ...]:
        r = self.route
        return (r.index, r.t, r.done, r.n_lines, r.hesitation, r.start, r.delta, r.rotvec,
                r.q0, r.q1, r.dur, r.grid, r.phase, r.lever, command)

    def run(self, motion: np.ndarray, scale: float, stiff: bool,
            command: np.ndarray | None, gains: tuple[float, ...]) -> PeriodsResult:
        """The step's five control periods.

        Args:
            motion: (19,) the robot grip's line: start position, quaternion, translation,
                rotation vector, linear and angular velocity (used when ``stiff``).
            scale: The robot's stiffness scale (0-1).
            stiff: The robot tracks the line (else passive).
            command: (13,) the human agent's hand command (start position, quaternion,
                translation, rotation), or None for the scripted human.
            gains: The hand impedance's (K, D, K_r, D_r) for the step.
        """
        sim, r, model = self.sim, self.route, self.sim.sensor.model
        r.bind(0, sim.human)
        cmd = np.zeros((1, 13)) if command is None else np.asarray(command, float)[None]
        drive, seats = sim.arm_drive, sim.seats
        noisy = model.delay_steps == 0 and model.noise_n > 0.0
        step = dict(
            scripted=command is None, robot_holds=sim.robot_holds, stiff=stiff, scale=scale,
            r_index=r.index, r_t=r.t, r_done=r.done, r_n=r.n_lines, r_hes=r.hesitation,
            r_start=r.start, r_delta=r.delta, r_rotvec=r.rotvec, r_q0=r.q0, r_q1=r.q1,
            r_dur=r.dur, r_length=r.length, command=cmd, gains=np.asarray(gains, float)[None],
            lo=drive.lo[None], hi=drive.hi[None], seat_pos=seats.pos[None],
            seat_exit=seats.exit[None], seat_quat=seats.quat[None], motion=motion[None],
            q_ref=sim.q_ref[None], hand_in_torso=np.asarray(sim.arm.hand_in_torso, float),
            torso_height=float(sim.arm.torso_height_m), noisy=noisy, bias=model.bias,
            noise=model.noise_n,
            z=model.rng.standard_normal((PERIODS, 6)) if noisy else self._true)
        args, slot = self._args, self._slot
        for name, value in step.items():
            args[slot[name]] = value
        if self.torque:
            carry_step(*args)
        else:
            self._run_python(args)
        r.store(0)
        if self._left[0]:
            sim.left_start = True
        sim.sensor.true_wrench[:] = self._true[-1]
        sensed = self._sensed.copy() if noisy else model.apply_all(self._true)
        return PeriodsResult(self._acc, self._sat[0].copy(), sensed, self._true, self._post)

    def observe(self) -> np.ndarray:
        """(20 + 2n,) the object's pose and velocity, the grip's pose, the robot's joints
        (:func:`~hri_envs.physics.carry.stages.observe`).
        """
        d, ids, n = self.sim.data, self.ids, len(self.robot_acts)
        out = np.empty(20 + 2 * n)
        observe(d.qpos, d.qvel, d.xpos, d.xquat, d.site_xpos, d.site_xmat, ids[0], ids[1],
                ids[7], n, out)
        return out

    def progress(self, pos: np.ndarray, quat: np.ndarray, tolerance_m: float = 0.05) -> float:
        """The object's progress along the human's route (IntentionHuman.progress)."""
        r = self.route
        r.bind(0, self.sim.human)
        out = np.empty(1)
        hl.route_progress(np.zeros(1, np.int64), np.asarray(pos, float)[None],
                          np.asarray(quat, float)[None], r.n_lines, r.start, r.delta, r.rotvec,
                          r.q0, r.length, r.lever, tolerance_m, out)
        return float(out[0])

    def grip_reference(self, local: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray,
                                                                           np.ndarray]:
        """Position and quaternion of the frame ``local`` (position, quaternion in the
        object) with the object at the human's reference now (``carry.grip_reference``).
        """
        r = self.route
        r.bind(0, self.sim.human)
        out = np.empty((1, 7))
        hl.route_frame(np.zeros(1, np.int64), r.index, r.t, r.done, r.n_lines, r.start,
                       r.delta, r.rotvec, r.q0, r.q1, r.dur, np.asarray(local[0], float),
                       np.asarray(local[1], float), out)
        return out[0, :3], out[0, 3:]

    def _run_python(self, args: list[Any]) -> None:
        """:func:`carry_step` (its arguments) period by period, the drive (the muscles'
        least squares) applied in Python between the stages.
        """
        v = {name: args[i] for name, i in self._slot.items()}
        sim = self.sim
        model, data, drive, coupling = sim.model, sim.data, sim.arm_drive, sim.coupling
        (qpos, qvel, xpos, xquat, xmat, xipos, site_xpos, site_xmat, subtree_com, sensordata,
         qfrc_bias, ctrl, xfrc) = self.data
        body, obj_dof, hsite, wrist, hand_body, f_adr, t_adr, grip, hf, ht, handle = (
            int(x) for x in self.ids)
        hk, sk = self.human_k, self.sensor_k
        cols = np.asarray(coupling.dofs, dtype=np.int64)
        tau = np.empty((1, len(self.arm_qpos)))
        sat, true, left, acc = self._sat, self._true, self._left, self._acc
        sat[:], left[:], acc[:] = 0.0, False, 0.0
        for i in range(PERIODS):
            s = (i + 1) / PERIODS
            mujoco.mj_step1(model, data)
            angvel = object_angvel(qvel, xquat, body, obj_dof)
            human_args: list[Any] = [
                s, self.dt_c, self.dt_step, v["scripted"], v["robot_holds"], False, *self.addr,
                qpos, qvel, xpos, xquat, xipos, site_xpos, site_xmat, ctrl, body, hsite,
                self.torso_acts, self.arm_acts, self.arm_qpos, self.arm_dofs, cols,
                np.asarray(coupling.update(data), float)[None],
                *self._human_args(v["command"]), hk[0:3], hk[3:7], hk[7:11],
                v["hand_in_torso"], v["torso_height"], v["gains"], self.weight_n,
                self.posture, self.kn_h, self.dn_h, v["lo"], v["hi"], self.hjac, tau, sat]
            human_stage(*human_args)
            made = drive.apply(data, tau[0])
            sat[0] += (made <= drive.lo + 1e-9) | (made >= drive.hi - 1e-9)
            robot_args: list[Any] = [
                s, v["robot_holds"], v["stiff"], v["scale"], *self.addr, qpos, qvel, xpos,
                xquat, xmat, xipos, site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias,
                ctrl, xfrc, body, obj_dof, wrist, hand_body, f_adr, t_adr, grip,
                self.robot_acts, sk[0:3], sk[3:6], sk[6:9], v["seat_pos"], v["seat_exit"],
                v["seat_quat"], self.capture, self.max_angle, self.seat_gains, self.hold,
                v["motion"], v["q_ref"], self.robot_gains, self.weight, self.kn, self.dn,
                self.tau_hi, self.rjac, self.cjac, self.rhs, self.minv, true[i:i + 1], left,
                angvel]
            robot_stage(*robot_args)
            mujoco.mj_step2(model, data)
            if self.k > 1:
                mujoco.mj_step(model, data, nstep=self.k - 1)
            after_stage(sensordata, site_xmat, qvel, hf, ht, handle, obj_dof, angvel,
                        self.dt_c, acc, v["forces"][:, i], v["velocities"][:, i])
        if v["noisy"]:
            laws.sensor_noise(true[-1:], v["bias"][None], np.full(1, v["noise"]), v["z"][-1:],
                              v["noise_lever"], self._sensed[None])
        meter = sim.meter
        tail_args: list[Any] = [
            qpos, qvel, xpos, xquat, site_xpos, site_xmat, body, obj_dof, hsite, handle,
            v["r_n"], v["r_start"], v["r_delta"], v["r_rotvec"], v["r_q0"], v["r_length"],
            self.route.lever, v["seat_pos"], v["seat_exit"], v["seat_quat"], self.capture,
            self.max_angle, VEL_SQ_MAX, ANGVEL_SQ_MAX, v["forces"], v["velocities"],
            meter.v_prev, meter.a_prev, meter.samples, self.dt_c, self._post]
        tail_stage(*tail_args)
