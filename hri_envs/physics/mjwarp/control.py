"""The control period's laws over a leading axis of worlds: what the C backends compute for one
world each control period, on ``(R, ...)`` arrays of the worlds ``rows`` that run it.

* :class:`RobotImpedance`: :class:`~hri_envs.physics.controller.ImpedanceController`'s
  torques (site Jacobians from the joint axes, ``M⁻¹`` by MuJoCo Warp's ``solve_m``, the
  6 × 6 operational-space inverse by batched solves);
* :class:`WristSensors`: :class:`~hri_envs.physics.sensing.WristSensor` and its
  :class:`~hri_envs.physics.sensing.SensorModel` (compensation, bias, noise, delay), with
  each world's bias, delay line and noise generator;
* :class:`WarpSeats`: :class:`~hri_envs.physics.seats.Seats` (which seat holds the object,
  its force law), each world with its own layout;
* :func:`disagreement`, :func:`davi`: :class:`~hri_envs.physics.controller.Disagreement`.

The formulas and their order are the C code's, so a world follows the C backend's arithmetic
up to rounding (the physics on MuJoCo Warp is float32).
"""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np

from hri_envs.physics.controller import _LAMBDA_INV_REGULARIZATION, ImpedanceController
from hri_envs.physics.design import PhysicsDesign
from hri_envs.physics.mjwarp import batchmath as bm
from hri_envs.physics.mjwarp.model import WarpModel
from hri_envs.physics.scene import Scene
from hri_envs.physics.seats import Seats
from hri_envs.physics.sensing import SensorModel, WristSensor

__all__ = ["RobotImpedance", "WarpSeats", "WristSensors", "chain_jacobian", "davi",
           "disagreement"]



def chain_jacobian(wm: WarpModel, rows: np.ndarray, joints: np.ndarray, hinge: np.ndarray,
                   point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, 6, n) Jacobian of ``point`` (R, 3) w.r.t. the 1-dof ``joints`` (n,) that move it
    (``hinge`` (n,) bool: hinge, else slide), from the joints' world axes and anchors; also
    the axes and anchors (R, n, 3).
    """
    anchor = wm._get("xanchor")[rows][:, joints].astype(float)  # (R, n, 3)
    axis = wm._get("xaxis")[rows][:, joints].astype(float)
    h = hinge[None, :, None]
    jac = np.empty((len(rows), 6, len(joints)))
    jac[:, :3] = np.where(h, np.cross(axis, point[:, None] - anchor), axis).transpose(0, 2, 1)
    jac[:, 3:] = np.where(h, axis, 0.0).transpose(0, 2, 1)
    return jac, axis, anchor


class RobotImpedance:
    """The robot's Cartesian impedance controller, per world.

    Args:
        model: The C model (joint axes' types).
        scene: The scene (ids, torque limits).
        controller: The C controller (its posture gains and the payload's weight).
        design: Stiffness, damping.
    """

    def __init__(self, model: mujoco.MjModel, scene: Scene, controller: ImpedanceController,
                 design: PhysicsDesign) -> None:
        self.scene, self.design = scene, design
        self.n = len(scene.robot_dofs)
        jnt = [int(np.flatnonzero(model.jnt_dofadr == d)[0]) for d in scene.robot_dofs]
        self.joints = np.array(jnt)
        self.hinge = model.jnt_type[self.joints] == mujoco.mjtJoint.mjJNT_HINGE
        self.weight = controller.weight
        self.kn, self.dn = controller.kn, controller.dn
        self.tau_hi = np.asarray(scene.torque_limit, float)

    def torques(self, wm: WarpModel, rows: np.ndarray, q: np.ndarray, qd: np.ndarray,
                ref: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                has_ref: np.ndarray, scale: np.ndarray, payload: np.ndarray,
                q_ref: np.ndarray) -> np.ndarray:
        """ImpedanceController.torques per world: (R, n) torques of the robot's joints.

        Args:
            wm: The worlds (kinematics of this period computed).
            rows: (R,) the worlds.
            q: (R, n) the robot's joint positions.
            qd: (R, n) their velocities.
            ref: (R, 3), (R, 4), (R, 3), (R, 3) the grip frame's reference.
            has_ref: (R,) bool, tracking (else passive).
            scale: (R,) the stiffness scale.
            payload: (R,) bool, compensate the held object's weight.
            q_ref: (R, n) the null-space posture reference.
        """
        sc, design = self.scene, self.design
        site = wm._get("site_xpos")[rows, sc.grip_site].astype(float)
        site_quat = bm.mat_to_quat(wm._get("site_xmat")[rows, sc.grip_site].astype(float))
        jac, axis, anchor = chain_jacobian(wm, rows, self.joints, self.hinge, site)
        hinge = self.hinge[None, :, None]
        twist = np.einsum("rij,rj->ri", jac, qd)
        v, w = twist[:, :3], twist[:, 3:]
        d_pp, d_pr = design.passive_damping
        s = np.where(has_ref, scale, 0.0)[:, None]
        k_p, k_r = design.stiffness[0] * s, design.stiffness[1] * s
        d_p = s * design.damping[0] + (1 - s) * d_pp
        d_r = s * design.damping[1] + (1 - s) * d_pr
        p_ref, quat_ref, v_ref, w_ref = ref
        e_rot = bm.rotation_error(quat_ref, site_quat)
        active = has_ref[:, None]
        wrench = np.concatenate([
            np.where(active, k_p * (p_ref - site) + d_p * (s * v_ref - v), -d_pp * v),
            np.where(active, k_r * e_rot + d_r * (s * w_ref - w), -d_pr * w)], axis=1)
        tau = np.einsum("rij,ri->rj", jac, wrench)
        tau += wm._get("qfrc_bias")[rows, :self.n].astype(float)
        if payload.any():
            com = wm._get("xipos")[rows, sc.object_body].astype(float)
            jc = np.where(hinge, np.cross(axis, com[:, None] - anchor), axis)  # (R, n, 3)
            tau += np.where(payload[:, None], np.einsum("rji,i->rj", jc, self.weight), 0.0)
        tau0 = self.kn * (q_ref - q) - self.dn * qd
        # M⁻¹ [Jᵀ | τ₀] by MuJoCo Warp's factorised mass matrix (all worlds, 7 solves).
        minv = wm.solve_m(rows, [jac[:, c] for c in range(6)] + [tau0], self.n)
        minv_jt = minv[:, :6]  # (R, 6, n) = (M⁻¹ Jᵀ)ᵀ
        lam_inv = np.einsum("rin,rjn->rij", minv_jt, jac) + _LAMBDA_INV_REGULARIZATION * np.eye(6)
        lam_x = np.linalg.solve(lam_inv, np.einsum("rin,rn->ri", jac, minv[:, 6])[..., None])
        tau0 = tau0 - np.einsum("rin,ri->rn", jac, lam_x[..., 0])
        return np.clip(tau + tau0, -self.tau_hi, self.tau_hi)


class WristSensors:
    """The wrist sensor of every world: its compensation and each world's sensor model.

    Args:
        n: The number of worlds.
        sensor: The C template's sensor (addresses, the known weights).
        lever: The torque noise and bias lever [m].

    Attributes:
        noise: (n,) the white noise [N]; bias: (n, 6) the constant bias.
        true_wrench: (n, 6) the last noise-free estimate.
        delay: (n,) the delay [control periods]; queues: each world's delay line.
        rngs: Each world's noise generator (None: never reset).
    """

    def __init__(self, n: int, sensor: WristSensor, lever: float) -> None:
        self.adr_force, self.adr_torque = sensor.force_adr, sensor.torque_adr
        self.site, self.hand = sensor.site, sensor.hand
        self.hand_weight, self.object_weight = sensor.hand_weight, sensor.object_weight
        self.object_com = np.asarray(sensor.object_com, float)
        self.lever = lever
        self.noise = np.zeros(n)
        self.bias = np.zeros((n, 6))
        self.true_wrench = np.zeros((n, 6))
        self.delay = np.zeros(n, dtype=np.int64)
        self.queues: list[deque[np.ndarray]] = [deque() for _ in range(n)]
        self.rngs: list[np.random.Generator | None] = [None] * n

    def reset_world(self, i: int, model: SensorModel) -> None:
        """World ``i`` takes a C sensor model just reset (its bias and generator)."""
        self.noise[i], self.bias[i] = model.noise_n, model.bias
        self.delay[i] = model.delay_steps
        self.rngs[i] = model._rng
        self.queues[i] = deque()
        self.true_wrench[i] = 0.0

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` take world ``src``'s sensor state, each its own generator
        (seeded by its index).
        """
        for value in (self.noise, self.bias, self.true_wrench, self.delay):
            value[rows] = value[src]
        for i in rows:
            self.queues[int(i)] = deque(self.queues[src])
            self.rngs[int(i)] = np.random.default_rng([int(i), 1])

    def _rng(self, i: int) -> np.random.Generator:
        rng = self.rngs[int(i)]
        if rng is None:
            raise RuntimeError(f"world {i} was never reset")
        return rng

    def external(self, wm: WarpModel, rows: np.ndarray, sensordata: np.ndarray,
                 holding: np.ndarray, pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """WristSensor.external per world: (R, 6) the sensed external wrench on the object.

        Args:
            wm: The worlds (kinematics of this period).
            rows: (R,) the worlds.
            sensordata: (R, nsensordata) the sensors after the last physics step.
            holding: (R,) the robot holds the object (else the true estimate is zero).
            pos: (R, 3) the object's position.
            rot: (R, 3, 3) its orientation.
        """
        smat = wm._get("site_xmat")[rows, self.site].astype(float)
        f_raw = np.einsum("rij,rj->ri", smat, sensordata[:, self.adr_force:self.adr_force + 3])
        t_raw = np.einsum("rij,rj->ri", smat,
                          sensordata[:, self.adr_torque:self.adr_torque + 3])
        site = wm._get("site_xpos")[rows, self.site].astype(float)
        hand_com = wm._get("subtree_com")[rows, self.hand].astype(float)
        com = pos + np.einsum("rij,j->ri", rot, self.object_com)
        gw, ow = self.hand_weight, self.object_weight
        f_ext = -f_raw - gw - ow
        t_ext = (-t_raw - np.cross(hand_com - site, gw) - np.cross(com - site, ow)
                 - np.cross(pos - site, f_ext))
        true = np.where(holding[:, None], np.concatenate([f_ext, t_ext], axis=1), 0.0)
        self.true_wrench[rows] = true
        out = true.copy()
        for j in np.flatnonzero(self.delay[rows] > 0):
            i = int(rows[j])
            queue = self.queues[i]
            queue.append(true[j].copy())
            out[j] = queue.popleft() if len(queue) > self.delay[i] else queue[0]
        out += self.bias[rows]
        noisy = self.noise[rows] > 0.0
        if noisy.any():
            z = np.stack([self._rng(i).standard_normal(6) for i in rows[noisy]])
            k = self.noise[rows[noisy]][:, None]
            z[:, 3:] *= self.lever
            out[noisy] += k * z
        return out


class WarpSeats:
    """The seats of every world (each world's layout: the wheel's stands move).

    Args:
        n: The number of worlds.
        seats: The C template's seats (the seat orientations, the same in every layout).
        design: Stiffness, damping, capture region, fade.

    Attributes:
        pos, exit: (n, K, 3) each world's seat positions and exit directions.
        quat: (n, K, 4) the seats' orientations.
        hold: (n,) each world's detent force [N].
    """

    def __init__(self, n: int, seats: Seats, design: PhysicsDesign) -> None:
        self.design = design
        self.pos = np.zeros((n, len(seats.pos), 3))
        self.exit = np.zeros_like(self.pos)
        self.quat = np.repeat(seats.quat[None], n, axis=0)
        self.hold = np.zeros(n)

    def set_world(self, i: int, seats: Seats, hold: float) -> None:
        """World ``i``'s layout: that of the C ``seats`` (set to the world's scenario)."""
        self.pos[i], self.exit[i], self.hold[i] = seats.pos, seats.exit, hold

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` take world ``src``'s layout."""
        for value in (self.pos, self.exit, self.quat, self.hold):
            value[rows] = value[src]

    def engaged(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(R,) the support whose seat holds the object in each world of ``rows``, or -1."""
        design = self.design
        cap, max_angle = design.seat_capture_m, design.seat_capture_angle_rad
        e = self.pos[rows] - pos[:, None]  # (R, K, 3)
        along = -np.einsum("rkj,rkj->rk", e, self.exit[rows])
        across2 = np.einsum("rkj,rkj->rk", e, e) - along * along
        inside = (np.abs(along) < cap) & (across2 < cap * cap)
        n_k = e.shape[1]
        out = np.full(len(rows), -1)
        for k in range(n_k - 1, -1, -1):  # the first seat that holds wins
            hit = inside[:, k]
            if hit.any():
                r = bm.rotation_error(self.quat[rows[hit], k], quat[hit])
                ok = np.linalg.norm(r, axis=1) < max_angle
                idx = np.flatnonzero(hit)[ok]
                out[idx] = k
        return out

    def wrench(self, rows: np.ndarray, k: np.ndarray, pos: np.ndarray, quat: np.ndarray,
               vel: np.ndarray, angvel: np.ndarray) -> np.ndarray:
        """Seats.wrench per world: (R, 6) force and torque of seat ``k`` on the object."""
        design = self.design
        e = self.pos[rows, k] - pos
        force = design.seat_stiffness * e - design.seat_damping * vel
        n = self.exit[rows, k]
        f_out = bm.dot(force, n)
        along = -bm.dot(e, n)
        fade = np.clip((design.seat_capture_m - along) / design.seat_fade_m, 0.0, 1.0)
        force = (force + (np.maximum(f_out, -self.hold[rows]) - f_out)[:, None] * n)
        torque = (design.seat_rot_stiffness * bm.rotation_error(self.quat[rows, k], quat)
                  - design.seat_rot_damping * angvel)
        return np.concatenate([force, torque], axis=1) * fade[:, None]

    def apply(self, wm: WarpModel, rows: np.ndarray, body: int, pos: np.ndarray,
              quat: np.ndarray, vel: np.ndarray, angvel: np.ndarray) -> np.ndarray:
        """The seats' wrenches on the object ``body`` as its applied force (``xfrc_applied``
        of the worlds ``rows``, the others' unchanged); (R,) the seat of each, or -1.
        """
        seat = self.engaged(rows, pos, quat)
        xfrc = wm._get("xfrc_applied")
        wrench = np.zeros((len(rows), 6))
        on = seat >= 0
        if on.any():
            wrench[on] = self.wrench(rows[on], seat[on], pos[on], quat[on], vel[on],
                                     angvel[on])
        xfrc[rows, body] = wrench
        wm._put("xfrc_applied", xfrc)
        return seat


def disagreement(design: PhysicsDesign, force: np.ndarray, torque: np.ndarray, u: np.ndarray,
                 axis: np.ndarray) -> np.ndarray:
    """Disagreement.force per world [N]."""
    f0 = design.disagree_force[0]
    slack = design.disagree_slack_factor * f0
    lever = design.lever
    along = bm.dot(force, u)
    across = np.linalg.norm(force - along[:, None] * u, axis=1)
    t_along = bm.dot(torque, axis)
    t_across = np.linalg.norm(torque - t_along[:, None] * axis, axis=1)
    return (across + np.maximum(-along - slack, 0.0)
            + (t_across + np.maximum(-t_along - slack * lever, 0.0)) / lever)


def davi(design: PhysicsDesign, rows: np.ndarray, force: np.ndarray, dt: float,
         alpha: np.ndarray, high: np.ndarray, yielded: np.ndarray) -> np.ndarray:
    """Disagreement.update per world (``alpha``, ``high``, ``yielded``: (N,) arrays of all
    the worlds, updated at ``rows``); the stiffness scales (R,).
    """
    f0, f1 = design.disagree_force
    target = np.clip((force - f0) / (f1 - f0), 0.0, 1.0)
    a = alpha[rows]
    tau = np.where(target > a, design.disagree_rise_time_s, design.disagree_fall_time_s)
    a = a + (target - a) * np.minimum(dt / tau, 1.0)
    alpha[rows] = a
    h = np.where(a > design.disagree_yield_alpha, high[rows] + dt, 0.0)
    high[rows] = h
    yielded[rows] |= h >= design.disagree_yield_time_s
    return np.where(yielded[rows], 0.0, 1.0 - a)
