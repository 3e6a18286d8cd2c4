"""Cartesian impedance control with disagreement-aware variable impedance (DAVI).

Joint torques (all controlled joints: the wheel's base joints, then the arm)::

    τ = Jᵀ [K (x_ref - x) + D (ẋ_ref - ẋ)]          Cartesian impedance of the grip frame
      + c(q, q̇)                                    gravity and Coriolis compensation
      + J_cᵀ m g ẑ                                  payload: the held object's weight
      + (I - Jᵀ Λ J M⁻¹) [K_n (q_ref - q) - D_n q̇]  null-space posture towards the IK reference

clipped to the joint torque limits. In *passive mode* the stiffness is zero (gravity and
payload compensation with a little damping: the human drags the robot around). While
tracking, :class:`Disagreement` watches the interaction wrench: when the human pushes
against the robot's intended motion, the stiffness fades out and, if the disagreement
persists, the robot gives up its action and turns passive (paper Sect. 4.3: the human is
always in control).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import TrajectorySample, rotation_error

__all__ = ["LAMBDA_INV_REGULARIZATION", "Disagreement", "ImpedanceController"]

#: Numerical method: Tikhonov regularisation of J M⁻¹ Jᵀ before it is inverted.
LAMBDA_INV_REGULARIZATION = 1e-6


class ImpedanceController:
    """Computes the robot's joint torques from the state in ``data``.

    Args:
        scene: The compiled scene (ids, limits, design).
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        design: PhysicsDesign = scene.design
        m = scene.model
        self.dofs = scene.robot_dofs
        n = len(self.dofs)
        self._jacp = np.zeros((3, m.nv))
        self._jacr = np.zeros((3, m.nv))
        self._jacc = np.zeros((3, m.nv))
        self._quat = np.zeros(4)
        self._rhs = np.zeros((7, m.nv))
        self._minv = np.zeros((7, m.nv))
        self._jac = np.zeros((6, n))
        self._wrench = np.zeros(6)
        self._reg = LAMBDA_INV_REGULARIZATION * np.eye(6)
        self._lam_inv = np.zeros((6, 6))
        self._lam_x = np.zeros(6)
        # The robot's joints lead the model and are contiguous in qpos and qvel (no ball or
        # free joints): plain slices instead of index arrays.
        if not (np.array_equal(self.dofs, np.arange(n))
                and np.array_equal(scene.robot_qpos, np.arange(n))):
            raise ValueError("the robot's joints must come first in the model")
        self.sl = slice(0, n)
        self.kn = np.full(n, design.posture_stiffness)
        self.dn = np.full(n, design.posture_damping)
        n_base = n - 7  # the Panda arm has 7 joints
        self.kn[:n_base], self.dn[:n_base] = design.base_stiffness, design.base_damping
        self.weight = design.object_mass * -m.opt.gravity
        self.grip_pos_in_object = design.grip_pos
        self.com_in_object = design.object_com
        self._tau_hi = np.asarray(scene.torque_limit, dtype=float)
        self._tau_lo = -self._tau_hi
        self._data: mujoco.MjData | None = None

    def _bind(self, data: mujoco.MjData) -> None:
        """Views into ``data``'s arrays that :meth:`torques` reads each control period
        (MuJoCo's arrays keep their memory for the life of ``data``).
        """
        sc, sl = self.scene, self.sl
        self._data = data
        self._qd = data.qvel[sl]
        self._q = data.qpos[sl]
        self._bias = data.qfrc_bias[sl]
        self._site_xmat = data.site_xmat[sc.grip_site]
        self._site_xpos = data.site_xpos[sc.grip_site]
        self._object_xipos = data.xipos[sc.object_body]

    def torques(self, data: mujoco.MjData, ref: TrajectorySample | None, q_ref: np.ndarray,
                stiffness_scale: float, payload: bool) -> np.ndarray:
        """Joint torques (n,) for the controlled joints.

        Args:
            data: Simulation state (kinematics computed, e.g. after ``mj_step1``).
            ref: Cartesian reference of the grip frame; None for passive mode.
            q_ref: (n,) null-space posture reference.
            stiffness_scale: DAVI factor in [0, 1] on the Cartesian stiffness.
            payload: Compensate the weight of the held object.

        Returns:
            (n,) torques [N m; N for the base's slides], within the joints' limits.
        """
        if data is not self._data:
            self._bind(data)
        sc, design, m, sl = self.scene, self.scene.design, self.scene.model, self.sl
        mujoco.mj_jacSite(m, data, self._jacp, self._jacr, sc.grip_site)
        jac = self._jac  # (6, n)
        jac[:3] = self._jacp[:, sl]
        jac[3:] = self._jacr[:, sl]
        qd = self._qd
        # ndarray.dot: the same BLAS routine as @ at half the call's cost.
        twist = jac.dot(qd)
        # The 6-vector arithmetic in plain floats: element by element the same operations
        # as numpy's, hence the same numbers, without numpy's per-call cost.
        v0, v1, v2, w0, w1, w2 = twist.tolist()
        if ref is None:
            d_p, d_r = design.passive_damping
            self._wrench[:] = (-d_p * v0, -d_p * v1, -d_p * v2, -d_r * w0, -d_r * w1,
                               -d_r * w2)
        else:
            s = stiffness_scale
            k_p, k_r = design.stiffness[0] * s, design.stiffness[1] * s
            d_p = s * design.damping[0] + (1 - s) * design.passive_damping[0]
            d_r = s * design.damping[1] + (1 - s) * design.passive_damping[1]
            mujoco.mju_mat2Quat(self._quat, self._site_xmat)
            p0, p1, p2 = ref.pos.tolist()
            x0, x1, x2 = self._site_xpos.tolist()
            u0, u1, u2 = ref.vel.tolist()
            e0, e1, e2 = rotation_error(ref.quat, self._quat).tolist()
            o0, o1, o2 = ref.angvel.tolist()
            self._wrench[:] = (k_p * (p0 - x0) + d_p * (s * u0 - v0),
                               k_p * (p1 - x1) + d_p * (s * u1 - v1),
                               k_p * (p2 - x2) + d_p * (s * u2 - v2),
                               k_r * e0 + d_r * (s * o0 - w0),
                               k_r * e1 + d_r * (s * o1 - w1),
                               k_r * e2 + d_r * (s * o2 - w2))
        tau = jac.T.dot(self._wrench)
        tau += self._bias
        if payload:
            mujoco.mj_jac(m, data, self._jacc, None, self._object_xipos, sc.hand_body)
            tau += self._jacc[:, sl].T.dot(self.weight)
        # Null-space posture, dynamically consistent: N = I - Jᵀ Λ J M⁻¹, Λ = (J M⁻¹ Jᵀ)⁻¹,
        # so it produces no acceleration of the grip frame.
        tau0 = self.kn * (q_ref - self._q)
        tau0 -= self.dn * qd
        rhs = self._rhs
        rhs[:6, sl] = jac
        rhs[6, sl] = tau0
        mujoco.mj_solveM(m, data, self._minv, rhs)
        minv_jt = self._minv[:6, sl]  # (6, n) = (M⁻¹ Jᵀ)ᵀ
        lam_inv = self._lam_inv  # J M⁻¹ Jᵀ + ε I, symmetric positive definite: Cholesky
        minv_jt.dot(jac.T, out=lam_inv)
        lam_inv += self._reg
        mujoco.mju_cholFactor(lam_inv, 0.0)
        mujoco.mju_cholSolve(self._lam_x, lam_inv, jac.dot(self._minv[6, sl]))
        tau0 -= jac.T.dot(self._lam_x)
        tau += tau0
        np.maximum(tau, self._tau_lo, out=tau)
        return np.minimum(tau, self._tau_hi, out=tau)  # = np.clip(tau, lo, hi)


class Disagreement:
    """Disagreement-aware variable impedance (after Van der Spaa et al., 2022).

    The disagreement force is the part of the human's wrench that does not push along the
    robot's intended motion: its component across the motion plus whatever opposes the
    motion beyond a slack (``disagree_slack_factor`` × ``disagree_force[0]``, so that a
    partner who is a little slower is not taken for one who disagrees); torques count as
    force × ``lever``. The stiffness scale ``1 - α`` follows the disagreement between
    ``disagree_force[0]`` (stiff) and ``[1]`` (soft) with the time constants
    ``disagree_rise_time_s`` and ``disagree_fall_time_s``; when α stays above
    ``disagree_yield_alpha`` for ``disagree_yield_time_s`` the robot *yields*: it abandons
    its action and is passive until the step ends.

    Args:
        design: Thresholds, time constants and lever.
    """

    def __init__(self, design: PhysicsDesign) -> None:
        self.f0, self.f1 = design.disagree_force
        self.lever = design.lever
        self.slack = design.disagree_slack_factor * self.f0
        self.rise_time_s = design.disagree_rise_time_s
        self.fall_time_s = design.disagree_fall_time_s
        self.yield_alpha = design.disagree_yield_alpha
        self.yield_time_s = design.disagree_yield_time_s
        self.alpha = 0.0
        self.yielded = False
        self._high = 0.0

    def reset(self) -> None:
        """Stiff again (a new action)."""
        self.alpha, self.yielded, self._high = 0.0, False, 0.0

    def force(self, force: np.ndarray, torque: np.ndarray, direction: np.ndarray,
              axis: np.ndarray) -> float:
        """Disagreement force [N] of a human wrench against a motion (unit vectors or 0)."""
        along = float(force.dot(direction))
        across_v = force - along * direction
        across = math.sqrt(across_v.dot(across_v))  # = np.linalg.norm, bit for bit
        t_along = float(torque.dot(axis))
        t_across_v = torque - t_along * axis
        t_across = math.sqrt(t_across_v.dot(t_across_v))
        return (across + max(-along - self.slack, 0.0)
                + (t_across + max(-t_along - self.slack * self.lever, 0.0)) / self.lever)

    def update(self, disagreement: float, dt: float) -> float:
        """Advance by ``dt`` [s] with the current disagreement force; the stiffness scale."""
        target = min(max((disagreement - self.f0) / (self.f1 - self.f0), 0.0), 1.0)
        tau = self.rise_time_s if target > self.alpha else self.fall_time_s
        self.alpha += (target - self.alpha) * min(dt / tau, 1.0)
        self._high = self._high + dt if self.alpha > self.yield_alpha else 0.0
        if self._high >= self.yield_time_s:
            self.yielded = True
        return 0.0 if self.yielded else 1.0 - self.alpha
