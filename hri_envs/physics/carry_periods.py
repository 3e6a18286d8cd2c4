"""The C backend's control periods of one continuous step (40 ms), compiled (numba).

:meth:`CarrySim.step <hri_envs.physics.carry.CarrySim.step>` simulates five control periods
of 8 ms; each is MuJoCo's ``mj_step1``, the human's reference, torso targets, hand impedance
and drive (:mod:`~hri_envs.physics.human_laws`), the wrist sensor's compensation, the seats'
law and the robot's impedance controller (:mod:`~hri_envs.physics.laws`), ``mj_step2`` and
three more ``mj_step``, then the hand's wrench on the handle. :func:`carry_step` runs all
five periods in one compiled call, calling MuJoCo's C functions directly
(:mod:`~hri_envs.physics.mjc`) and the laws with one world; :class:`CarryPeriods` binds it to
a :class:`~hri_envs.physics.carry.CarrySim` (its model, data, indices and buffers, the
human's route as arrays) and runs the muscle-driven arm, whose drive solves a least-squares
problem in Python (scipy) each period, period by period through the same stages
(:func:`human_stage`, :func:`robot_stage`, :func:`after_stage`).

The wrist sensor's model (bias, noise, delay line) is applied afterwards by
:class:`~hri_envs.physics.sensing.SensorModel` to the five compensated wrenches in order, as
each period would have (only the last reading is the step's).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from hri_envs.physics import human_laws as hl
from hri_envs.physics import lawmath as lm
from hri_envs.physics import laws
from hri_envs.physics.arm_control import POSTURE_REGULARIZATION
from hri_envs.physics.controller import _LAMBDA_INV_REGULARIZATION
from hri_envs.physics.jit import kernel
from hri_envs.physics.mjc import mj_jac, mj_jacSite, mj_solveM, mj_step, mj_step1, mj_step2
from hri_envs.physics.whole_arm import _TORSO_HEIGHT_M

if TYPE_CHECKING:
    from hri_envs.physics.carry import CarrySim

__all__ = ["CarryPeriods", "after_stage", "carry_step", "human_stage", "robot_stage"]

PERIODS = 5  # control periods (125 Hz) per step (25 Hz)


@kernel
def human_stage(s, dt_c, dt_step, scripted, robot_holds, torque, m, d, qpos, qvel, xpos,
                xquat, xipos, site_xpos, site_xmat, ctrl, body, site, torso_acts, arm_acts,
                arm_qpos, arm_dofs, cols, coupling, r_index, r_t, r_done, r_n, r_hes,
                r_start, r_delta, r_rotvec, r_q0, r_q1, r_dur, grid, phase, lever, command,
                handle_pos, handle_quat, rest_quat, hand_in_torso, gains, weight_n, posture,
                kn, dn, lo, hi, jac, tau, sat):
    """The human's part of a control period (after ``mj_step1``) for one world: their
    reference (scripted, advancing along the route, or the human agent's ``command`` (1, 13):
    start position, quaternion, translation and rotation of the step, at the fraction ``s``),
    the torso's targets, the hand impedance's torques ``tau`` (1, n) and, with the ``torque``
    drive, the clipped torques into ``ctrl`` (``sat`` (1, n) counts joints at a limit).
    The arguments are :class:`CarryPeriods`'s (see :meth:`CarryPeriods.run`).
    """
    pos, quat = xpos[body:body + 1], xquat[body:body + 1]
    href = np.empty((1, 13))
    obj_quat = np.empty((1, 4))
    if scripted:
        ref = np.empty((1, 13))
        hl.intention_advance(np.zeros(1, np.int64), dt_c, pos, quat, r_index, r_t, r_done,
                             r_n, r_hes, r_start, r_delta, r_rotvec, r_q0, r_q1, r_dur,
                             lever, grid, phase, ref)
        hl.hand_reference(ref, handle_pos, handle_quat, href)
        obj_quat[0] = ref[0, 3:7]
    else:
        hl.commanded_reference(command[:, 0:3], command[:, 3:7], command[:, 7:10],
                               command[:, 10:13], s, dt_step, handle_quat, href, obj_quat)
    torso = np.empty((1, 4))
    hl.torso_target(href[:, :3], obj_quat, rest_quat, hand_in_torso, _TORSO_HEIGHT_M, torso)
    for c in range(4):
        ctrl[torso_acts[c]] = torso[0, c]
    ff = np.zeros((1, 6))
    if not robot_holds:  # carrying alone: hold up the object's weight
        r = (xipos[body, 0] - site_xpos[site, 0], xipos[body, 1] - site_xpos[site, 1],
             xipos[body, 2] - site_xpos[site, 2])
        t = lm.cross3(r, (0.0, 0.0, weight_n))
        ff[0, 2], ff[0, 3], ff[0, 4], ff[0, 5] = weight_n, t[0], t[1], t[2]
    mj_jacSite(m, d, jac[0, :3].ctypes.data, jac[0, 3:].ctypes.data, site)
    n = len(arm_qpos)
    q, qd = np.empty((1, n)), np.empty((1, n))
    for c in range(n):
        q[0, c], qd[0, c] = qpos[arm_qpos[c]], qvel[arm_dofs[c]]
    hl.hand_impedance(jac, qvel.reshape((1, -1)), cols, coupling, site_xpos[site:site + 1],
                      site_xmat[site:site + 1], href, gains, ff, q, qd, posture, kn, dn,
                      POSTURE_REGULARIZATION, tau)
    if torque:
        made = np.empty((1, n))
        hl.torque_drive(tau, lo, hi, made, sat)
        for c in range(n):
            ctrl[arm_acts[c]] = made[0, c]


@kernel
def robot_stage(s, robot_holds, stiff, scale, m, d, qpos, qvel, xpos, xquat, xmat, xipos,
                site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias, ctrl, xfrc, body,
                obj_dof, wrist, hand_body, force_adr, torque_adr, grip, robot_acts,
                hand_weight, object_weight, object_com, seat_pos, seat_exit, seat_quat,
                capture, max_angle, seat_gains, hold, motion, q_ref, robot_gains, weight,
                kn, dn, tau_hi, jac, jac_com, rhs, minv, true, left, angvel):
    """The robot's part of a control period for one world: the wrist sensor's compensated
    wrench into ``true`` (1, 6), the seats' wrench on the object into ``xfrc`` (``left``
    (1,) set when no seat holds it), the impedance controller's torques into ``ctrl``
    (tracking the line ``motion`` (1, 19): start position, quaternion, translation,
    rotation, linear and angular velocity of the step, at the fraction ``s``, when
    ``stiff``); ``angvel`` (1, 3): the object's angular velocity (world). The arguments
    are :class:`CarryPeriods`'s (see :meth:`CarryPeriods.run`).
    """
    pos, quat = xpos[body:body + 1], xquat[body:body + 1]
    holding = np.full(1, robot_holds)
    laws.wrist_wrench(holding, sensordata[force_adr:force_adr + 3].reshape((1, 3)),
                      sensordata[torque_adr:torque_adr + 3].reshape((1, 3)),
                      site_xpos[wrist:wrist + 1], site_xmat[wrist:wrist + 1],
                      subtree_com[hand_body:hand_body + 1], pos, xmat[body:body + 1],
                      hand_weight, object_weight, object_com, true)
    vel = qvel[obj_dof:obj_dof + 3].copy().reshape((1, 3))
    seat = laws.seat_wrench(pos, quat, vel, angvel, seat_pos, seat_exit, seat_quat, capture,
                            max_angle, seat_gains, hold, xfrc[body:body + 1])
    if seat[0] < 0:
        left[0] = True
    n = len(robot_acts)
    mj_jacSite(m, d, jac[0, :3].ctypes.data, jac[0, 3:].ctypes.data, grip)
    if robot_holds:
        mj_jac(m, d, jac_com[0].ctypes.data, 0, xipos[body].ctypes.data, hand_body)
    ref = np.zeros((1, 13))
    if stiff:
        p = lm.rotate_by(lm.quat4(motion[0, 3:7]), (s * motion[0, 10], s * motion[0, 11],
                                                     s * motion[0, 12]))
        for c in range(3):
            ref[0, c] = motion[0, c] + s * motion[0, 7 + c]
            ref[0, 7 + c] = motion[0, 13 + c]
            ref[0, 10 + c] = motion[0, 16 + c]
        for c in range(4):
            ref[0, 3 + c] = p[c]
    tau = np.empty((1, n))
    rj, rh = jac[:, :, :n], rhs[:, :, :n]
    laws.robot_task(rj, qvel[:n].reshape((1, n)), site_xpos[grip:grip + 1],
                    site_xmat[grip:grip + 1], ref, np.full(1, stiff), np.full(1, scale),
                    robot_gains, qfrc_bias[:n].reshape((1, n)), holding, jac_com[:, :, :n],
                    weight, qpos[:n].reshape((1, n)), q_ref, kn, dn, tau, rh)
    mj_solveM(m, d, minv.ctypes.data, rhs.ctypes.data, 7)
    out = np.empty((1, n))
    laws.robot_null_space(rj, minv[:, :, :n], rh, tau, _LAMBDA_INV_REGULARIZATION, -tau_hi,
                          tau_hi, out)
    for c in range(n):
        ctrl[robot_acts[c]] = out[0, c]


@kernel
def after_stage(sensordata, site_xmat, qvel, hf, ht, handle, obj_dof, angvel, dt_c, acc,
                force, velocity):
    """After a control period's physics, for one world: the hand's wrench on the handle
    integrated into ``acc`` (1, 3) and sampled into ``force`` (1,), ``velocity`` (1, 3)
    (:func:`~hri_envs.physics.laws.handle_sample`).
    """
    laws.handle_sample(sensordata[hf:hf + 3].reshape((1, 3)),
                       sensordata[ht:ht + 3].reshape((1, 3)), site_xmat[handle:handle + 1],
                       qvel[obj_dof:obj_dof + 3].reshape((1, 3)), angvel, dt_c, acc, force,
                       velocity)


@kernel
def object_angvel(qvel, xquat, body, obj_dof):
    """(1, 3) the object's angular velocity in the world (its free joint's is local)."""
    w = lm.rotate_vec((qvel[obj_dof + 3], qvel[obj_dof + 4], qvel[obj_dof + 5]),
                      lm.quat4(xquat[body]))
    out = np.empty((1, 3))
    out[0, 0], out[0, 1], out[0, 2] = w[0], w[1], w[2]
    return out


@kernel
def carry_step(k, dt_c, dt_step, scripted, robot_holds, stiff, scale, m, d, qpos, qvel, xpos,
               xquat, xmat, xipos, site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias,
               ctrl, xfrc, ids, torso_acts, arm_acts, arm_qpos, arm_dofs, robot_acts,
               coupling, r_index, r_t, r_done, r_n, r_hes, r_start, r_delta, r_rotvec, r_q0,
               r_q1, r_dur, grid, phase, lever, command, human_k, gains, weight_n, posture,
               kn_h, dn_h, lo, hi, sensor_k, seat_pos, seat_exit, seat_quat, capture,
               max_angle, seat_gains, hold, motion, q_ref, robot_gains, weight, kn, dn,
               tau_hi, hjac, rjac, cjac, rhs, minv, true, acc, forces, velocities, sat, left):
    """The five control periods of a step of one world with the torque-driven arm: per
    period ``mj_step1``, :func:`human_stage`, :func:`robot_stage`, ``mj_step2`` and ``k - 1``
    more ``mj_step``, :func:`after_stage`. ``true`` (5, 6) receives each period's
    compensated wrist wrench, ``forces`` (1, 5) and ``velocities`` (1, 5, 3) the samples.
    The arguments are :meth:`CarryPeriods.run`'s.
    """
    body, obj_dof, hsite, wrist, hand_body, f_adr, t_adr, grip, hf, ht, handle = ids
    handle_pos, handle_quat, rest_quat, hand_in_torso = (human_k[0:3], human_k[3:7],
                                                         human_k[7:11], human_k[11:14])
    hand_weight, object_weight, object_com = sensor_k[0:3], sensor_k[3:6], sensor_k[6:9]
    cols = arm_dofs
    tau = np.empty((1, len(arm_qpos)))
    for i in range(PERIODS):
        s = (i + 1) / PERIODS
        mj_step1(m, d)
        angvel = object_angvel(qvel, xquat, body, obj_dof)
        human_stage(s, dt_c, dt_step, scripted, robot_holds, True, m, d, qpos, qvel, xpos,
                    xquat, xipos, site_xpos, site_xmat, ctrl, body, hsite, torso_acts,
                    arm_acts, arm_qpos, arm_dofs, cols, coupling, r_index, r_t, r_done, r_n,
                    r_hes, r_start, r_delta, r_rotvec, r_q0, r_q1, r_dur, grid, phase, lever,
                    command, handle_pos, handle_quat, rest_quat, hand_in_torso, gains,
                    weight_n, posture, kn_h, dn_h, lo, hi, hjac, tau, sat)
        robot_stage(s, robot_holds, stiff, scale, m, d, qpos, qvel, xpos, xquat, xmat, xipos,
                    site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias, ctrl, xfrc,
                    body, obj_dof, wrist, hand_body, f_adr, t_adr, grip, robot_acts,
                    hand_weight, object_weight, object_com, seat_pos, seat_exit, seat_quat,
                    capture, max_angle, seat_gains, hold, motion, q_ref, robot_gains, weight,
                    kn, dn, tau_hi, rjac, cjac, rhs, minv, true[i:i + 1], left, angvel)
        mj_step2(m, d)
        for _ in range(k - 1):
            mj_step(m, d)
        after_stage(sensordata, site_xmat, qvel, hf, ht, handle, obj_dof, angvel, dt_c, acc,
                    forces[:, i], velocities[:, i])


class PeriodsResult:
    """What a step's control periods did (one world).

    Attributes:
        lin, ang, disagree: ∫ |F| dt [N s], ∫ |τ| dt [N m s], ∫ max(0, -(F·v + τ·ω)) dt [J]
            of the hand's wrench on the handle.
        forces: (1, 5) |F| at each period's end; velocities: (1, 5, 3) the object's velocity.
        sat: (n,) how many periods each arm joint was at its strength limit.
        sensed: (6,) the wrist's last reading; true: (5, 6) the compensated wrenches.
    """

    def __init__(self, acc: np.ndarray, forces: np.ndarray, velocities: np.ndarray,
                 sat: np.ndarray, sensed: np.ndarray, true: np.ndarray) -> None:
        self.lin, self.ang, self.disagree = (float(x) for x in acc[0])
        self.forces, self.velocities = forces, velocities
        self.sat, self.sensed, self.true = sat, sensed, true


class CarryPeriods:
    """A :class:`~hri_envs.physics.carry.CarrySim`'s control periods, compiled.

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
                             sim._hf, sim._ht, arm.handle_site], dtype=np.int64)
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
        self.human_k = np.concatenate([sim.handle_pos, sim.handle_quat, sim.rest_quat,
                                       arm.hand_in_torso]).astype(float)
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
        self.kn, self.dn, self.tau_hi = ctl.kn, ctl.dn, ctl._tau_hi
        nv = m.nv
        self.hjac, self.rjac = np.zeros((1, 6, nv)), np.zeros((1, 6, nv))
        self.cjac = np.zeros((1, 3, nv))
        self.rhs, self.minv = np.zeros((1, 7, nv)), np.zeros((1, 7, nv))
        self.addr = (m._address, d._address)

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
        sim = self.sim
        self.route.bind(0, sim.human)
        n = len(self.arm_qpos)
        true = np.zeros((PERIODS, 6))
        acc, forces = np.zeros((1, 3)), np.zeros((1, PERIODS))
        velocities, sat = np.zeros((1, PERIODS, 3)), np.zeros((1, n))
        left = np.zeros(1, dtype=np.bool_)
        cmd = np.zeros((1, 13)) if command is None else np.asarray(command, float)[None]
        drive, seats = sim.arm_drive, sim.seats
        args = (self.dt_c, self.dt_step, command is None, sim.robot_holds, stiff, scale,
                *self.addr)
        if self.torque:
            step_args: list[Any] = [
                self.k, *args, *self.data, self.ids, self.torso_acts, self.arm_acts,
                self.arm_qpos, self.arm_dofs, self.robot_acts, self.coupling,
                *self._human_args(cmd), self.human_k, np.asarray(gains, float)[None],
                self.weight_n, self.posture, self.kn_h, self.dn_h, drive.lo[None],
                drive.hi[None], self.sensor_k, seats.pos[None], seats.exit[None],
                seats.quat[None], self.capture, self.max_angle, self.seat_gains, self.hold,
                motion[None], sim.q_ref[None], self.robot_gains, self.weight, self.kn, self.dn,
                self.tau_hi, self.hjac, self.rjac, self.cjac, self.rhs, self.minv, true, acc,
                forces, velocities, sat, left]
            carry_step(*step_args)
        else:
            self._run_python(args, np.asarray(gains, float)[None], cmd, motion[None], true,
                             acc, forces, velocities, sat, left)
        self.route.store(0)
        if left[0]:
            sim.left_start = True
        sensor = sim.sensor
        sensor.true_wrench[:] = true[-1]
        return PeriodsResult(acc, forces, velocities, sat[0], sensor.model.apply_all(true), true)

    def progress(self, pos: np.ndarray, quat: np.ndarray, tolerance_m: float = 0.05) -> float:
        """The object's progress along the human's route (IntentionHuman.progress)."""
        r = self.route
        r.bind(0, self.sim.human)
        out = np.empty(1)
        hl.route_progress(np.zeros(1, np.int64), np.asarray(pos, float)[None],
                          np.asarray(quat, float)[None], r.n_lines, r.start, r.delta, r.rotvec,
                          r.q0, r.length, r.lever, tolerance_m, out)
        return float(out[0])

    def slip(self) -> tuple[bool, float, float]:
        """Whether the state is finite, and how far [m] and by what angle [rad] the handle is
        off the hand's grip now.
        """
        d, arm = self.sim.data, self.sim.arm
        out = np.empty(3)
        _slip(d.qpos, d.site_xpos, d.site_xmat, arm.grip_site, arm.handle_site, out)
        return bool(out[0]), float(out[1]), float(out[2])

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

    def _run_python(self, args: tuple[Any, ...], gains: np.ndarray, command: np.ndarray,
                    motion: np.ndarray, true: np.ndarray, acc: np.ndarray,
                    forces: np.ndarray, velocities: np.ndarray, sat: np.ndarray,
                    left: np.ndarray) -> None:
        """:func:`carry_step` period by period, the muscle drive between the stages."""
        sim = self.sim
        model, data, drive, coupling, seats = (sim.model, sim.data, sim.arm_drive,
                                               sim.coupling, sim.seats)
        dt_c, dt_step, scripted, holds, stiff, scale, m, d = args
        (qpos, qvel, xpos, xquat, xmat, xipos, site_xpos, site_xmat, subtree_com, sensordata,
         qfrc_bias, ctrl, xfrc) = self.data
        body, obj_dof, hsite, wrist, hand_body, f_adr, t_adr, grip, hf, ht, handle = (
            int(x) for x in self.ids)
        hk, sk = self.human_k, self.sensor_k
        cols = np.asarray(coupling.dofs, dtype=np.int64)
        tau = np.empty((1, len(self.arm_qpos)))
        for i in range(PERIODS):
            s = (i + 1) / PERIODS
            mujoco.mj_step1(model, data)
            angvel = object_angvel(qvel, xquat, body, obj_dof)
            human_args: list[Any] = [
                s, dt_c, dt_step, scripted, holds, False, m, d, qpos, qvel, xpos, xquat, xipos,
                site_xpos, site_xmat, ctrl, body, hsite, self.torso_acts, self.arm_acts,
                self.arm_qpos, self.arm_dofs, cols,
                np.asarray(coupling.update(data), float)[None], *self._human_args(command),
                hk[0:3], hk[3:7], hk[7:11], hk[11:14], gains, self.weight_n, self.posture,
                self.kn_h, self.dn_h, drive.lo[None], drive.hi[None], self.hjac, tau, sat]
            human_stage(*human_args)
            made = drive.apply(data, tau[0])
            sat[0] += (made <= drive.lo + 1e-9) | (made >= drive.hi - 1e-9)
            robot_stage(s, holds, stiff, scale, m, d, qpos, qvel, xpos, xquat, xmat, xipos,
                        site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias, ctrl, xfrc,
                        body, obj_dof, wrist, hand_body, f_adr, t_adr, grip, self.robot_acts,
                        sk[0:3], sk[3:6], sk[6:9], seats.pos[None], seats.exit[None],
                        seats.quat[None], self.capture, self.max_angle, self.seat_gains,
                        self.hold, motion, sim.q_ref[None], self.robot_gains, self.weight,
                        self.kn, self.dn, self.tau_hi, self.rjac, self.cjac, self.rhs,
                        self.minv, true[i:i + 1], left, angvel)
            mujoco.mj_step2(model, data)
            if self.k > 1:
                mujoco.mj_step(model, data, nstep=self.k - 1)
            after_stage(sensordata, site_xmat, qvel, hf, ht, handle, obj_dof, angvel, dt_c, acc,
                        forces[:, i], velocities[:, i])


@kernel
def _slip(qpos, site_xpos, site_xmat, grip, handle, out):
    """``out`` (3,): 1 if ``qpos`` is finite (else 0), the handle's distance [m] and angle
    [rad] off the hand's grip (:func:`~hri_envs.physics.laws.handle_slip`).
    """
    finite = 1.0
    for v in qpos:
        if not math.isfinite(v):
            finite = 0.0
    off, angle = np.empty(1), np.empty(1)
    laws.handle_slip(site_xpos[grip:grip + 1], site_xmat[grip:grip + 1],
                     site_xpos[handle:handle + 1], site_xmat[handle:handle + 1], off, angle)
    out[0], out[1], out[2] = finite, off[0], angle[0]
