"""How the whole arm turns the human's reference into joint torques, and how they are made.

:class:`HandImpedance` is the human's controller: a Cartesian spring-damper on the hand's
grip frame towards its reference, plus a null-space pull towards a comfortable posture::

    w = [K (x_ref - x) + D (ẋ_ref - ẋ) + f_ff ;  K_r e(R_ref, R) + D_r (ω_ref - ω) + t_ff]
    τ = Jᵀ w + (I - Jᵀ (J Jᵀ)⁻¹ J) [K_n (q_0 - q) - D_n q̇]

with J the grip frame's Jacobian in the arm's *independent* coordinates (for the muscle
model, whose shoulder girdle follows the shoulder through equality constraints, the chain
rule through those couplings, :class:`Coupling`), and ``f_ff``, ``t_ff`` a feed-forward of
the object's weight when the human carries it alone. A *drive* then produces the torques:
:class:`TorqueDrive` clips them to the arm's strength and hands them to joint torque
motors; the muscle drive (:class:`~hri_envs.physics.carry.human.muscles.MuscleDrive`) finds muscle
activations that produce them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import mujoco
import numpy as np

from hri_envs.physics.carry.human.whole_arm import Coupling, WholeArm
from hri_envs.physics.scene.kinematics import TrajectorySample, rotation_error

__all__ = ["POSTURE_REGULARIZATION", "ArmDrive", "HandImpedance", "TorqueDrive"]

#: [-] added to the hand Jacobian's J Jᵀ before it is inverted for the null-space posture term.
POSTURE_REGULARIZATION = 1e-4


class ArmDrive(ABC):
    """Produces the joint torques the human's controller asks for."""

    #: The strength limits (n,) per direction [N m], scaled by the human's strength.
    lo: np.ndarray
    hi: np.ndarray

    @abstractmethod
    def apply(self, data: mujoco.MjData, tau: np.ndarray) -> np.ndarray:
        """Set the actuators for the (n,) desired torques; the torques the arm will make."""

    def set_strength(self, scale: float) -> None:
        """Scale the strength limits (1: the adult's)."""


class TorqueDrive(ArmDrive):
    """Joint torque motors, clipped to the adult's torque limits times the strength.

    Args:
        model: The scene.
        actuators: (n,) the arm's motor actuators.
        limits: (n, 2) the adult's limits [N m] (negative, positive direction).
    """

    def __init__(self, model: mujoco.MjModel, actuators: np.ndarray,
                 limits: np.ndarray) -> None:
        self.model, self.actuators = model, np.asarray(actuators)
        self.limits = np.asarray(limits, dtype=float)
        self.set_strength(1.0)

    def set_strength(self, scale: float) -> None:
        """Scale the limits (and the motors' control ranges)."""
        self.lo, self.hi = -scale * self.limits[:, 0], scale * self.limits[:, 1]
        self.model.actuator_ctrlrange[self.actuators, 0] = self.lo
        self.model.actuator_ctrlrange[self.actuators, 1] = self.hi

    def apply(self, data: mujoco.MjData, tau: np.ndarray) -> np.ndarray:
        """Ctrl = the clipped torques."""
        out = np.clip(tau, self.lo, self.hi)
        data.ctrl[self.actuators] = out
        return out


class HandImpedance:
    """The human's hand impedance and posture term, in the arm's independent coordinates.

    Args:
        model: The scene.
        arm: The whole arm's indices.
        coupling: Independent coordinates and their dofs.
        posture: (n,) the comfortable posture [rad].
        gains: (K, D, K_r, D_r): [N/m], [N s/m], [N m/rad], [N m s/rad].
        posture_gains: (K_n, D_n) of the null-space term [N m/rad], [N m s/rad].
    """

    def __init__(self, model: mujoco.MjModel, arm: WholeArm, coupling: Coupling,
                 posture: np.ndarray, gains: tuple[float, float, float, float],
                 posture_gains: tuple[float, float] = (5.0, 0.5)) -> None:
        self.model, self.arm, self.coupling = model, arm, coupling
        self.posture = np.asarray(posture, dtype=float)
        self.gains = gains
        self.kn, self.dn = posture_gains
        self._jac = np.zeros((6, model.nv))
        self._jacp, self._jacr = self._jac[:3], self._jac[3:]  # contiguous row blocks
        self._reg = POSTURE_REGULARIZATION * np.eye(6)
        self._quat = np.zeros(4)
        self.wrench = np.zeros(6)  # the last task wrench [N, N m] the hand aims to apply

    def torques(self, data: mujoco.MjData, ref: TrajectorySample,
                feedforward: np.ndarray | None = None) -> np.ndarray:
        """(n,) joint torques [N m] for the hand's reference ``ref`` (grip frame pose and
        velocity) plus an optional (6,) feed-forward wrench.
        """
        m, arm = self.model, self.arm
        mujoco.mj_jacSite(m, data, self._jacp, self._jacr, arm.grip_site)
        jac_full = self._jac  # (6, nv)
        twist = jac_full.dot(data.qvel)
        c = self.coupling.update(data)
        jac = jac_full[:, self.coupling.dofs].dot(c)  # (6, n)
        k, d, kr, dr = self.gains
        mujoco.mju_mat2Quat(self._quat, data.site_xmat[arm.grip_site])
        w = self.wrench
        w[:3] = k * (ref.pos - data.site_xpos[arm.grip_site]) + d * (ref.vel - twist[:3])
        w[3:] = kr * rotation_error(ref.quat, self._quat) + dr * (ref.angvel - twist[3:])
        if feedforward is not None:
            w += feedforward
        tau = jac.T.dot(w)
        q = data.qpos[arm.arm_qpos]
        qd = data.qvel[arm.arm_dofs]
        tau0 = self.kn * (self.posture - q) - self.dn * qd
        # The posture torque without its part along the task: (I - Jᵀ (J Jᵀ)⁻¹ J) τ₀, with a
        # little regularisation near singular postures.
        tau += tau0 - jac.T.dot(np.linalg.solve(jac.dot(jac.T) + self._reg, jac.dot(tau0)))
        return tau
