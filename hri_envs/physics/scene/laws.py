"""The continuous envs' control-period laws, compiled (numba), over a leading axis of worlds.

What :class:`~hri_envs.physics.carry.sim.CarrySim` computes each 8 ms control period besides
MuJoCo's own functions, written once over ``(R, ...)`` arrays (R worlds; one on the C
backend), as MuJoCo Playground and mjlab write an env over worlds. The human's laws are in
:mod:`~hri_envs.physics.carry.human.laws` (their reference along the route, the hand's and the
torso's targets, the hand impedance, the torque drive); here:

* :func:`wrist_wrench` and :func:`sensor_noise`:
  :meth:`~hri_envs.physics.scene.sensing.WristSensor.external` (the compensation) and
  :meth:`~hri_envs.physics.scene.sensing.SensorModel.apply` without its delay line (bias, white
  noise from draws made outside);
* :func:`seat_wrench`: :class:`~hri_envs.physics.scene.seats.Seats` (which seat holds the object
  and its force law);
* :func:`robot_task` and :func:`robot_null_space`:
  :meth:`~hri_envs.physics.scene.controller.ImpedanceController.torques` before and after
  ``M⁻¹`` (MuJoCo's ``mj_solveM`` on the C backend, MuJoCo Warp's ``solve_m`` over worlds);
* :func:`handle_sample`: the hand's wrench on the handle after the physics, what a step
  integrates (effort, disagreement) and samples (the interaction measures);
  :func:`handle_slip`: how far the handle is off the hand's grip;
* :func:`grip_target`, :func:`grip_motion`, :func:`robot_reference`: a command's grip target,
  the grip's straight line over a step and its reference at a fraction of the step;
  :func:`world_angvel`: the object's angular velocity in the world.

The numpy classes they mirror stay the discrete Panda backend's (:class:`~hri_envs.physics.
panda.sim.PandaSim`) and the muscle-driven arm's. Formulas and their order are those classes',
element by element (:mod:`~hri_envs.physics.scene.lawmath`), so the results agree to the last
bits (a dot product's summation order, libm against numpy). Jacobians, sensor readings and
frames come in as arrays: MuJoCo's ``mj_jacSite`` and ``mjData`` on the C backend
(:mod:`~hri_envs.physics.carry.periods`), the joint axes and MuJoCo Warp's arrays there.
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.scene import lawmath as lm
from hri_envs.physics.scene.jit import kernel

__all__ = ["grip_motion", "grip_target", "handle_sample", "handle_slip", "robot_null_space",
           "robot_reference", "robot_task", "seat_engaged", "seat_wrench", "sensor_noise",
           "world_angvel", "wrist_wrench"]


@kernel
def wrist_wrench(holding: np.ndarray, force: np.ndarray, torque: np.ndarray,
                 site_pos: np.ndarray, site_mat: np.ndarray, hand_com: np.ndarray,
                 obj_pos: np.ndarray, obj_mat: np.ndarray, hand_weight: np.ndarray,
                 object_weight: np.ndarray, object_com: np.ndarray, true: np.ndarray) -> None:
    """WristSensor.external's compensation per world into ``true`` (R, 6): the external
    wrench on the object (force, torque at its origin) from the flange's reading.

    Args:
        holding: (R,) bool, the robot holds the object (else the estimate is zero).
        force: (R, 3) the sensor's force reading, flange frame.
        torque: (R, 3) its torque reading.
        site_pos: (R, 3) the flange (the sensor's site).
        site_mat: (R, 9) its orientation.
        hand_com: (R, 3) the centre of mass of link 7's subtree.
        obj_pos: (R, 3) the object's origin.
        obj_mat: (R, 9) its orientation.
        hand_weight: (3,) the hand's known weight [N].
        object_weight: (3,) the object's nominal weight [N].
        object_com: (3,) its nominal centre of mass in its frame.
        true: (R, 6) the estimate.
    """
    g = lm.vec3(hand_weight)
    wo = lm.vec3(object_weight)
    for r in range(force.shape[0]):
        if not holding[r]:
            for c in range(6):
                true[r, c] = 0.0
            continue
        f = lm.mat_vec(site_mat[r], lm.vec3(force[r]))
        t = lm.mat_vec(site_mat[r], lm.vec3(torque[r]))
        p = lm.vec3(site_pos[r])
        o = lm.vec3(obj_pos[r])
        cm = lm.mat_vec(obj_mat[r], lm.vec3(object_com))
        cm = (o[0] + cm[0], o[1] + cm[1], o[2] + cm[2])
        f_ext = (-f[0] - g[0] - wo[0], -f[1] - g[1] - wo[1], -f[2] - g[2] - wo[2])
        ah = lm.cross3((hand_com[r, 0] - p[0], hand_com[r, 1] - p[1], hand_com[r, 2] - p[2]), g)
        bo = lm.cross3((cm[0] - p[0], cm[1] - p[1], cm[2] - p[2]), wo)
        rf = lm.cross3((o[0] - p[0], o[1] - p[1], o[2] - p[2]), f_ext)
        for c in range(3):
            true[r, c] = f_ext[c]
            true[r, 3 + c] = (-t[c] - ah[c] - bo[c]) - rf[c]


@kernel
def sensor_noise(true: np.ndarray, bias: np.ndarray, noise: np.ndarray, z: np.ndarray,
                 lever: float, out: np.ndarray) -> None:
    """SensorModel.apply without its delay per world into ``out`` (R, 6): the wrench
    ``true`` plus the ``bias`` (R, 6) and ``noise`` (R,) [N] times the standard normal
    draws ``z`` (R, 6) (torques times ``lever`` [m]).
    """
    for r in range(true.shape[0]):
        k = noise[r]
        for c in range(6):
            v = true[r, c] + bias[r, c]
            if k > 0.0:
                v = v + (k * z[r, c] * lever if c >= 3 else k * z[r, c])
            out[r, c] = v


@kernel
def seat_engaged(pos: np.ndarray, quat: np.ndarray, seat_pos: np.ndarray,
                 seat_exit: np.ndarray, seat_quat: np.ndarray, capture: float,
                 max_angle: float) -> np.ndarray:
    """Seats.engaged per world: (R,) the support whose seat holds the object, or -1.

    Args:
        pos: (R, 3) the object's position.
        quat: (R, 4) its orientation.
        seat_pos: (R, K, 3) the seats.
        seat_exit: (R, K, 3) their exit directions.
        seat_quat: (R, K, 4) their orientations.
        capture: The capture distance [m].
        max_angle: The capture angle [rad].
    """
    seat = np.full(pos.shape[0], -1)
    for r in range(pos.shape[0]):
        x, y, z = pos[r, 0], pos[r, 1], pos[r, 2]
        q = lm.quat4(quat[r])
        for k in range(seat_pos.shape[1]):
            ex, ey, ez = seat_pos[r, k, 0] - x, seat_pos[r, k, 1] - y, seat_pos[r, k, 2] - z
            n = lm.vec3(seat_exit[r, k])
            along = -(ex * n[0] + ey * n[1] + ez * n[2])
            if abs(along) < capture and (ex * ex + ey * ey + ez * ez) - along * along \
                    < capture * capture:
                e = lm.rotation_error(lm.quat4(seat_quat[r, k]), q)
                if math.sqrt(lm.dot3(e, e)) < max_angle:
                    seat[r] = k
                    break
    return seat


@kernel
def seat_wrench(pos: np.ndarray, quat: np.ndarray, vel: np.ndarray, angvel: np.ndarray,
                seat_pos: np.ndarray, seat_exit: np.ndarray, seat_quat: np.ndarray,
                capture: float, max_angle: float, gains: np.ndarray, hold: np.ndarray,
                out: np.ndarray) -> np.ndarray:
    """Seats.engaged and Seats.wrench per world: ``out`` (R, 6) the seat's force and torque
    on the object (zero off the seats); returns (R,) the seat that holds it, or -1.

    Args:
        pos: (R, 3) the object's position.
        quat: (R, 4) its orientation.
        vel: (R, 3) its linear velocity.
        angvel: (R, 3) its angular velocity (world).
        seat_pos: (R, K, 3) the seats.
        seat_exit: (R, K, 3) their exit directions.
        seat_quat: (R, K, 4) their orientations.
        capture: The capture distance [m].
        max_angle: The capture angle [rad].
        gains: (5,) stiffness, damping, rotational stiffness and damping, fade length [m].
        hold: (R,) the detent force [N].
        out: (R, 6) the wrench.
    """
    seat = seat_engaged(pos, quat, seat_pos, seat_exit, seat_quat, capture, max_angle)
    ks, kd, kr, dr, fade_m = gains[0], gains[1], gains[2], gains[3], gains[4]
    for r in range(pos.shape[0]):
        k = seat[r]
        if k < 0:
            for c in range(6):
                out[r, c] = 0.0
            continue
        e = (seat_pos[r, k, 0] - pos[r, 0], seat_pos[r, k, 1] - pos[r, 1],
             seat_pos[r, k, 2] - pos[r, 2])
        n = lm.vec3(seat_exit[r, k])
        f = (ks * e[0] - kd * vel[r, 0], ks * e[1] - kd * vel[r, 1], ks * e[2] - kd * vel[r, 2])
        f_out = lm.dot3(f, n)
        along = -lm.dot3(e, n)
        fade = min(max((capture - along) / fade_m, 0.0), 1.0)
        extra = max(f_out, -hold[r]) - f_out
        er = lm.rotation_error(lm.quat4(seat_quat[r, k]), lm.quat4(quat[r]))
        for c in range(3):
            out[r, c] = (f[c] + extra * n[c]) * fade
            out[r, 3 + c] = (kr * er[c] - dr * angvel[r, c]) * fade
    return seat


@kernel
def robot_task(jac: np.ndarray, qd: np.ndarray, site_pos: np.ndarray, site_mat: np.ndarray,
               ref: np.ndarray, tracking: np.ndarray, scale: np.ndarray, gains: np.ndarray,
               bias: np.ndarray, payload: np.ndarray, jac_com: np.ndarray,
               weight: np.ndarray, q: np.ndarray, q_ref: np.ndarray, kn: np.ndarray,
               dn: np.ndarray, tau: np.ndarray, rhs: np.ndarray) -> None:
    """ImpedanceController.torques per world, up to ``M⁻¹``: ``tau`` (R, n) the Cartesian
    impedance, bias and payload torques; ``rhs`` (R, 7, n) the rows [J; τ₀] for ``M⁻¹``
    (τ₀ the posture torque towards ``q_ref``).

    Args:
        jac: (R, 6, n) the grip frame's Jacobian in the robot's joints.
        qd: (R, n) the joints' velocities.
        site_pos: (R, 3) the grip frame's position.
        site_mat: (R, 9) its orientation.
        ref: (R, 13) its reference.
        tracking: (R,) bool, track ``ref`` (else passive).
        scale: (R,) the stiffness scale (0-1).
        gains: (6,) translational and rotational stiffness, damping, passive damping.
        bias: (R, n) gravity and Coriolis torques.
        payload: (R,) bool, compensate the held object's weight.
        jac_com: (R, 3, n) the Jacobian of the object's centre of mass on the hand.
        weight: (3,) the object's weight [N].
        q: (R, n) the joints' positions.
        q_ref: (R, n) the posture reference.
        kn: (n,) the posture stiffness.
        dn: (n,) the posture damping.
        tau: (R, n) the torques so far.
        rhs: (R, 7, n) the rows for ``M⁻¹``.
    """
    n = jac.shape[2]
    kp0, kr0, dp0, dr0, dpp, drp = gains[0], gains[1], gains[2], gains[3], gains[4], gains[5]
    for r in range(jac.shape[0]):
        tw = np.zeros(6)
        for i in range(6):
            v = 0.0
            for c in range(n):
                v += jac[r, i, c] * qd[r, c]
            tw[i] = v
        w = np.empty(6)
        if not tracking[r]:
            for c in range(3):
                w[c] = -dpp * tw[c]
                w[3 + c] = -drp * tw[3 + c]
        else:
            s = scale[r]
            k_p, k_r = kp0 * s, kr0 * s
            d_p, d_r = s * dp0 + (1 - s) * dpp, s * dr0 + (1 - s) * drp
            e = lm.rotation_error(lm.quat4(ref[r, 3:7]), lm.mat_to_quat(site_mat[r]))
            for c in range(3):
                w[c] = k_p * (ref[r, c] - site_pos[r, c]) + d_p * (s * ref[r, 7 + c] - tw[c])
                w[3 + c] = k_r * e[c] + d_r * (s * ref[r, 10 + c] - tw[3 + c])
        for c in range(n):
            v = 0.0
            for i in range(6):
                v += jac[r, i, c] * w[i]
            v += bias[r, c]
            if payload[r]:
                v += (jac_com[r, 0, c] * weight[0] + jac_com[r, 1, c] * weight[1]
                      + jac_com[r, 2, c] * weight[2])
            tau[r, c] = v
            for i in range(6):
                rhs[r, i, c] = jac[r, i, c]
            rhs[r, 6, c] = kn[c] * (q_ref[r, c] - q[r, c]) - dn[c] * qd[r, c]


@kernel
def robot_null_space(jac: np.ndarray, minv: np.ndarray, rhs: np.ndarray, tau: np.ndarray,
                     reg: float, lo: np.ndarray, hi: np.ndarray, out: np.ndarray) -> None:
    """ImpedanceController.torques per world, after ``M⁻¹``: ``out`` (R, n) = ``tau`` plus the
    dynamically consistent null-space posture torque (I - Jᵀ Λ J M⁻¹) τ₀, clipped.

    Args:
        jac: (R, 6, n) the grip frame's Jacobian.
        minv: (R, 7, n) ``M⁻¹`` applied to the rows of ``rhs``.
        rhs: (R, 7, n) [J; τ₀] (:func:`robot_task`).
        tau: (R, n) :func:`robot_task`'s torques.
        reg: The regularisation added to J M⁻¹ Jᵀ.
        lo: (n,) the lower torque limits.
        hi: (n,) the upper ones.
        out: (R, n) the torques.
    """
    n = jac.shape[2]
    a = np.empty((6, 6))
    b = np.empty(6)
    x = np.empty(6)
    for r in range(jac.shape[0]):
        for i in range(6):
            for i2 in range(6):
                v = 0.0
                for c in range(n):
                    v += minv[r, i, c] * jac[r, i2, c]
                a[i, i2] = v + (reg if i == i2 else 0.0)
            v = 0.0
            for c in range(n):
                v += jac[r, i, c] * minv[r, 6, c]
            b[i] = v
        lm.cholesky_solve(a, b, x)
        for c in range(n):
            v = 0.0
            for i in range(6):
                v += jac[r, i, c] * x[i]
            t = tau[r, c] + (rhs[r, 6, c] - v)
            out[r, c] = min(max(t, lo[c]), hi[c])


@kernel
def handle_sample(f_sensor: np.ndarray, t_sensor: np.ndarray, handle_mat: np.ndarray,
                  obj_vel: np.ndarray, angvel: np.ndarray, dt: float, acc: np.ndarray,
                  force: np.ndarray, velocity: np.ndarray) -> None:
    """What a control period adds to a step after the physics, per world.

    Args:
        f_sensor: (R, 3) the handle's force sensor (the object on the handle, in the handle's
            frame: minus the hand's force).
        t_sensor: (R, 3) its torque sensor.
        handle_mat: (R, 9) the handle's frame.
        obj_vel: (R, 3) the object's linear velocity after the physics.
        angvel: (R, 3) its angular velocity (world) before it.
        dt: The control period [s].
        acc: (R, 3) ∫ |F| dt, ∫ |τ| dt, ∫ max(0, -(F·v + τ·ω)) dt of the hand's wrench on
            the handle (added to).
        force: (R,) |F| now.
        velocity: (R, 3) the object's velocity now.
    """
    for r in range(f_sensor.shape[0]):
        fm = lm.mat_vec(handle_mat[r], lm.vec3(f_sensor[r]))
        tm = lm.mat_vec(handle_mat[r], lm.vec3(t_sensor[r]))
        f = (-fm[0], -fm[1], -fm[2])
        t = (-tm[0], -tm[1], -tm[2])
        f_norm = math.sqrt(lm.dot3(f, f))
        acc[r, 0] += f_norm * dt
        acc[r, 1] += math.sqrt(lm.dot3(t, t)) * dt
        v = lm.vec3(obj_vel[r])
        power = lm.dot3(f, v) + lm.dot3(t, lm.vec3(angvel[r]))
        acc[r, 2] += max(0.0, -power) * dt
        force[r] = f_norm
        for c in range(3):
            velocity[r, c] = v[c]


@kernel
def handle_slip(grip_pos: np.ndarray, grip_mat: np.ndarray, handle_pos: np.ndarray,
                handle_mat: np.ndarray, off: np.ndarray, angle: np.ndarray) -> None:
    """How far the handle is off the hand's grip, per world: ``off`` (R,) [m] and ``angle``
    (R,) [rad] between the frames (``CarrySim._check``).

    Args:
        grip_pos: (R, 3) the hand's grip frame's position.
        grip_mat: (R, 9) its orientation.
        handle_pos: (R, 3) the handle's frame's position.
        handle_mat: (R, 9) its orientation.
        off: (R,) out: the distance [m].
        angle: (R,) out: the angle [rad].
    """
    for r in range(grip_pos.shape[0]):
        dx, dy, dz = (grip_pos[r, 0] - handle_pos[r, 0], grip_pos[r, 1] - handle_pos[r, 1],
                      grip_pos[r, 2] - handle_pos[r, 2])
        off[r] = math.sqrt(dx * dx + dy * dy + dz * dz)
        e = lm.rotation_error(lm.mat_to_quat(grip_mat[r]), lm.mat_to_quat(handle_mat[r]))
        angle[r] = math.sqrt(lm.dot3(e, e))


@kernel
def world_angvel(quat: np.ndarray, local: np.ndarray, out: np.ndarray) -> None:
    """``out`` (R, 3): the angular velocities ``local`` (R, 3) in the bodies' frames (a free
    joint's) turned into the world by the bodies' orientations ``quat`` (R, 4).
    """
    for r in range(quat.shape[0]):
        w = lm.rotate_vec((local[r, 0], local[r, 1], local[r, 2]), lm.quat4(quat[r]))
        out[r, 0], out[r, 1], out[r, 2] = w[0], w[1], w[2]


@kernel
def grip_target(site_pos: np.ndarray, site_mat: np.ndarray, action: np.ndarray,
                max_step_m: float, max_step_rad: float, out: np.ndarray) -> None:
    """CarrySim.command's target per world for actions (R, 7) in [-1, 1]: ``out`` (R, 7)
    the grip frame's position ``site_pos`` (R, 3) moved by ``max_step_m`` x a[0:3] and its
    quaternion (of ``site_mat`` (R, 9)) turned by ``max_step_rad`` x a[3:6] (world frame).
    """
    for r in range(site_pos.shape[0]):
        q = lm.rotate_by(lm.mat_to_quat(site_mat[r]),
                         (max_step_rad * action[r, 3], max_step_rad * action[r, 4],
                          max_step_rad * action[r, 5]))
        for c in range(3):
            out[r, c] = site_pos[r, c] + max_step_m * action[r, c]
        for c in range(4):
            out[r, 3 + c] = q[c]


@kernel
def grip_motion(site_pos: np.ndarray, site_mat: np.ndarray, target_pos: np.ndarray,
                target_quat: np.ndarray, dt_step: float, out: np.ndarray) -> None:
    """The robot grip's line for a step towards its target per world, ``out`` (R, 19): the
    grip's position ``site_pos`` (R, 3) and quaternion (of ``site_mat`` (R, 9)) now, the
    translation and rotation vector to the target (``target_pos`` (R, 3), ``target_quat``
    (R, 4)), and their rates over ``dt_step`` (CarrySim.step).
    """
    for r in range(site_pos.shape[0]):
        q = lm.mat_to_quat(site_mat[r])
        e = lm.rotation_error(lm.quat4(target_quat[r]), q)
        for c in range(3):
            d = target_pos[r, c] - site_pos[r, c]
            out[r, c] = site_pos[r, c]
            out[r, 7 + c] = d
            out[r, 10 + c] = e[c]
            out[r, 13 + c] = d / dt_step
            out[r, 16 + c] = e[c] / dt_step
        for c in range(4):
            out[r, 3 + c] = q[c]


@kernel
def robot_reference(motion: np.ndarray, s: float, stiff: np.ndarray, ref: np.ndarray) -> None:
    """The grip frame's reference (R, 13) per world a fraction ``s`` of the way along its
    line ``motion`` (R, 19) (:func:`grip_motion`) where ``stiff`` (R,) (zero elsewhere):
    position, quaternion, linear and angular velocity.
    """
    for r in range(motion.shape[0]):
        if not stiff[r]:
            for c in range(13):
                ref[r, c] = 0.0
            continue
        p = lm.rotate_by(lm.quat4(motion[r, 3:7]), (s * motion[r, 10], s * motion[r, 11],
                                                     s * motion[r, 12]))
        for c in range(3):
            ref[r, c] = motion[r, c] + s * motion[r, 7 + c]
            ref[r, 7 + c] = motion[r, 13 + c]
            ref[r, 10 + c] = motion[r, 16 + c]
        for c in range(4):
            ref[r, 3 + c] = p[c]
