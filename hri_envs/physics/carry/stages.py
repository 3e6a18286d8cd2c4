"""The C backend's control periods of one continuous step, compiled (numba): the stages.

:func:`carry_step` runs a step's five control periods of one world in one compiled call:
per period MuJoCo's ``mj_step1`` (called directly, :mod:`~hri_envs.physics.carry.mjc`),
:func:`human_stage` (the human's reference, torso targets, hand impedance and torque drive:
:mod:`~hri_envs.physics.carry.human.laws`), :func:`robot_stage` (the wrist sensor's compensation,
the seats' law, the robot's impedance controller: :mod:`~hri_envs.physics.scene.laws`),
``mj_step2`` and three more ``mj_step``, :func:`after_stage` (the hand's wrench on the
handle); then :func:`tail_stage` (what the step reports). The laws get one world, as (1, ...)
arrays. :class:`~hri_envs.physics.carry.periods.CarryPeriods` binds it to a simulation and
runs the muscle-driven arm period by period through the same stages.
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.carry.human import laws as hl
from hri_envs.physics.carry.human.arm_control import POSTURE_REGULARIZATION
from hri_envs.physics.carry.interaction import meter_step
from hri_envs.physics.carry.mjc import mj_jac, mj_jacSite, mj_solveM, mj_step, mj_step1, mj_step2
from hri_envs.physics.scene import lawmath as lm
from hri_envs.physics.scene import laws
from hri_envs.physics.scene.controller import LAMBDA_INV_REGULARIZATION
from hri_envs.physics.scene.jit import kernel

__all__ = ["ANGVEL_SQ_MAX", "PERIODS", "VEL_SQ_MAX", "after_stage", "carry_step",
           "human_stage", "object_angvel", "observe", "robot_stage", "slip", "tail_stage"]

#: Control periods (125 Hz) per step (25 Hz).
PERIODS = 5
#: [m²/s²], [rad²/s²]: a placed object is slower than these (squared speeds).
VEL_SQ_MAX, ANGVEL_SQ_MAX = 1e-4, 2.5e-3


@kernel
def human_stage(s, dt_c, dt_step, scripted, robot_holds, torque, m, d, qpos, qvel, xpos,
                xquat, xipos, site_xpos, site_xmat, ctrl, body, site, torso_acts, arm_acts,
                arm_qpos, arm_dofs, cols, coupling, r_index, r_t, r_done, r_n, r_hes,
                r_start, r_delta, r_rotvec, r_q0, r_q1, r_dur, grid, phase, lever, command,
                handle_pos, handle_quat, rest_quat, hand_in_torso, torso_height, gains,
                weight_n, posture, kn, dn, lo, hi, jac, tau, sat):
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
    hl.torso_target(href[:, :3], obj_quat, rest_quat, hand_in_torso.reshape((1, 3)),
                    np.full(1, torso_height), torso)
    for c in range(4):
        ctrl[torso_acts[c]] = torso[0, c]
    ff = np.empty((1, 6))
    hl.carried_weight(np.full(1, not robot_holds), xipos[body:body + 1],
                      site_xpos[site:site + 1], weight_n, ff)
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
    ref = np.empty((1, 13))
    laws.robot_reference(motion, s, np.full(1, stiff), ref)
    tau = np.empty((1, n))
    rj, rh = jac[:, :, :n], rhs[:, :, :n]
    laws.robot_task(rj, qvel[:n].reshape((1, n)), site_xpos[grip:grip + 1],
                    site_xmat[grip:grip + 1], ref, np.full(1, stiff), np.full(1, scale),
                    robot_gains, qfrc_bias[:n].reshape((1, n)), holding, jac_com[:, :, :n],
                    weight, qpos[:n].reshape((1, n)), q_ref, kn, dn, tau, rh)
    mj_solveM(m, d, minv.ctypes.data, rhs.ctypes.data, 7)
    out = np.empty((1, n))
    laws.robot_null_space(rj, minv[:, :, :n], rh, tau, LAMBDA_INV_REGULARIZATION, -tau_hi,
                          tau_hi, out)
    for c in range(n):
        ctrl[robot_acts[c]] = out[0, c]


@kernel
def after_stage(sensordata, site_xmat, qvel, hf, ht, handle, obj_dof, angvel, dt_c, acc,
                force, velocity):
    """After a control period's physics, for one world: the hand's wrench on the handle
    integrated into ``acc`` (1, 3) and sampled into ``force`` (1,), ``velocity`` (1, 3)
    (:func:`~hri_envs.physics.scene.laws.handle_sample`).
    """
    laws.handle_sample(sensordata[hf:hf + 3].reshape((1, 3)),
                       sensordata[ht:ht + 3].reshape((1, 3)), site_xmat[handle:handle + 1],
                       qvel[obj_dof:obj_dof + 3].reshape((1, 3)), angvel, dt_c, acc, force,
                       velocity)


@kernel
def tail_stage(qpos, qvel, xpos, xquat, site_xpos, site_xmat, body, obj_dof, grip, handle,
               r_n, r_start, r_delta, r_rotvec, r_q0, r_length, lever, seat_pos, seat_exit,
               seat_quat, capture, max_angle, vel_sq_max, angvel_sq_max, forces, velocities,
               v_prev, a_prev, samples, dt_c, post):
    """After a step's periods, for one world, what the step reports into ``post`` (9,): 1 if
    the state is finite (else 0), the handle's distance [m] and angle [rad] off the hand's
    grip, the route progress, the seat holding the object (-1: none), 1 if the object is
    slow (squared speeds below ``vel_sq_max``, ``angvel_sq_max``), and the interaction
    measures of the step's samples (peak force, ∫ |F|² dt, ∫ |jerk|² dt;
    :func:`~hri_envs.physics.carry.interaction.meter_step`, whose state arrays are updated).
    """
    slip(qpos, site_xpos, site_xmat, grip, handle, post[0:3])
    rows = np.zeros(1, np.int64)
    pos, quat = xpos[body:body + 1], xquat[body:body + 1]
    hl.route_progress(rows, pos, quat, r_n, r_start, r_delta, r_rotvec, r_q0, r_length, lever,
                      0.05, post[3:4])
    post[4] = laws.seat_engaged(pos, quat, seat_pos, seat_exit, seat_quat, capture,
                                max_angle)[0]
    v, w = qvel[obj_dof:obj_dof + 3], qvel[obj_dof + 3:obj_dof + 6]
    v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2]
    post[5] = 1.0 if v2 < vel_sq_max and w2 < angvel_sq_max else 0.0
    out = np.empty((3, 1))
    meter_step(rows, forces, velocities, v_prev, a_prev, samples, dt_c, out)
    post[6], post[7], post[8] = out[0, 0], out[1, 0], out[2, 0]


@kernel
def object_angvel(qvel, xquat, body, obj_dof):
    """(1, 3) the object's angular velocity in the world (its free joint's is local;
    :func:`~hri_envs.physics.scene.laws.world_angvel`).
    """
    out = np.empty((1, 3))
    laws.world_angvel(xquat[body:body + 1], qvel[obj_dof + 3:obj_dof + 6].reshape((1, 3)),
                      out)
    return out


@kernel
def carry_step(k, dt_c, dt_step, scripted, robot_holds, stiff, scale, m, d, qpos, qvel, xpos,
               xquat, xmat, xipos, site_xpos, site_xmat, subtree_com, sensordata, qfrc_bias,
               ctrl, xfrc, ids, torso_acts, arm_acts, arm_qpos, arm_dofs, robot_acts,
               coupling, r_index, r_t, r_done, r_n, r_hes, r_start, r_delta, r_rotvec, r_q0,
               r_q1, r_dur, r_length, grid, phase, lever, command, human_k, hand_in_torso,
               torso_height, gains, weight_n, posture, kn_h, dn_h, lo, hi, sensor_k, seat_pos,
               seat_exit, seat_quat, capture, max_angle, seat_gains, hold, motion, q_ref,
               robot_gains, weight, kn, dn, tau_hi, hjac, rjac, cjac, rhs, minv, noisy, bias,
               noise, z, noise_lever, v_prev, a_prev, samples, true, acc, forces, velocities,
               sat, left, sensed, post):
    """The five control periods of a step of one world with the torque-driven arm: per
    period ``mj_step1``, :func:`human_stage`, :func:`robot_stage`, ``mj_step2`` and ``k - 1``
    more ``mj_step``, :func:`after_stage`; then :func:`tail_stage` and, if ``noisy`` (a
    sensor without a delay line), the wrist's reading into ``sensed`` (6,)
    (:func:`~hri_envs.physics.scene.laws.sensor_noise` of the last period's wrench and draws
    ``z`` (5, 6)). ``true`` (5, 6) receives each period's compensated wrist wrench,
    ``forces`` (1, 5) and ``velocities`` (1, 5, 3) the samples, ``acc``, ``sat``, ``left``
    start from zero. The arguments are :meth:`CarryPeriods.run`'s.
    """
    body, obj_dof, hsite, wrist, hand_body, f_adr, t_adr, grip, hf, ht, handle = ids
    handle_pos, handle_quat, rest_quat = human_k[0:3], human_k[3:7], human_k[7:11]
    hand_weight, object_weight, object_com = sensor_k[0:3], sensor_k[3:6], sensor_k[6:9]
    acc[:], sat[:], left[:] = 0.0, 0.0, False
    tau = np.empty((1, len(arm_qpos)))
    for i in range(PERIODS):
        s = (i + 1) / PERIODS
        mj_step1(m, d)
        angvel = object_angvel(qvel, xquat, body, obj_dof)
        human_stage(s, dt_c, dt_step, scripted, robot_holds, True, m, d, qpos, qvel, xpos,
                    xquat, xipos, site_xpos, site_xmat, ctrl, body, hsite, torso_acts,
                    arm_acts, arm_qpos, arm_dofs, arm_dofs, coupling, r_index, r_t, r_done,
                    r_n, r_hes, r_start, r_delta, r_rotvec, r_q0, r_q1, r_dur, grid, phase,
                    lever, command, handle_pos, handle_quat, rest_quat, hand_in_torso,
                    torso_height, gains, weight_n, posture, kn_h, dn_h, lo, hi, hjac, tau, sat)
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
    if noisy:
        laws.sensor_noise(true[PERIODS - 1:], bias.reshape((1, 6)), np.full(1, noise),
                          z[PERIODS - 1:], noise_lever, sensed.reshape((1, 6)))
    tail_stage(qpos, qvel, xpos, xquat, site_xpos, site_xmat, body, obj_dof, hsite, handle,
               r_n, r_start, r_delta, r_rotvec, r_q0, r_length, lever, seat_pos, seat_exit,
               seat_quat, capture, max_angle, VEL_SQ_MAX, ANGVEL_SQ_MAX, forces, velocities,
               v_prev, a_prev, samples, dt_c, post)


@kernel
def slip(qpos, site_xpos, site_xmat, grip, handle, out):
    """``out`` (3,): 1 if ``qpos`` is finite (else 0), the handle's distance [m] and angle
    [rad] off the hand's grip (:func:`~hri_envs.physics.scene.laws.handle_slip`).
    """
    finite = 1.0
    for v in qpos:
        if not math.isfinite(v):
            finite = 0.0
    off, angle = np.empty(1), np.empty(1)
    laws.handle_slip(site_xpos[grip:grip + 1], site_xmat[grip:grip + 1],
                     site_xpos[handle:handle + 1], site_xmat[handle:handle + 1], off, angle)
    out[0], out[1], out[2] = finite, off[0], angle[0]


@kernel
def observe(qpos, qvel, xpos, xquat, site_xpos, site_xmat, body, obj_dof, grip, n, out):
    """The simulation's part of the continuous envs' observation into ``out`` (20 + 2n,):
    the object's position, quaternion (w >= 0), linear and angular velocity (world); the
    robot grip's position and quaternion (w >= 0); the robot's n joint positions and
    velocities (:meth:`~hri_envs.physics.carry.env.CarryEnv._observation`'s order).
    """
    q = lm.quat4(xquat[body])
    sign = 1.0 if q[0] >= 0 else -1.0
    w = lm.rotate_vec((qvel[obj_dof + 3], qvel[obj_dof + 4], qvel[obj_dof + 5]), q)
    g = lm.mat_to_quat(site_xmat[grip])
    gsign = 1.0 if g[0] >= 0 else -1.0
    for c in range(3):
        out[c] = xpos[body, c]
        out[7 + c] = qvel[obj_dof + c]
        out[10 + c] = w[c]
        out[13 + c] = site_xpos[grip, c]
    for c in range(4):
        out[3 + c] = sign * q[c]
        out[16 + c] = gsign * g[c]
    for c in range(n):
        out[20 + c] = qpos[c]
        out[20 + n + c] = qvel[c]


def preload() -> None:
    """Compile (or load) the kernels one step of each continuous scenario uses, with the
    torque-driven arm (``make test`` runs it before the tests' processes would each compile
    them at once; :mod:`hri_envs.physics.scene.jit`).
    """
    from hri_envs.physics.carry.env import CarryEnv  # noqa: PLC0415
    from hri_envs.task.scenarios import SCENARIOS  # noqa: PLC0415

    for spec in SCENARIOS.values():
        if spec.continuous_id is None:
            continue
        env = CarryEnv(spec.name)
        env.reset(seed=0)
        env.sim.human_grip_reference()
        env.step([0.0] * 7)
        env.close()
