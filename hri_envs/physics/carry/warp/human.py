"""The continuous envs' whole human arm over a leading axis of worlds on MuJoCo Warp
(:class:`WarpArms`): its indices, each world's gains, strength and body, and its hand
impedance's torques by the compiled law the C backend runs with one world
(:func:`~hri_envs.physics.carry.human.laws.hand_impedance`), the grip frame's Jacobian from the
torso's and the arm's joint axes.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.carry.human import laws as hl
from hri_envs.physics.carry.human.arm_control import POSTURE_REGULARIZATION
from hri_envs.physics.carry.human.whole_arm import WholeArm
from hri_envs.physics.scene.warp.control import chain_jacobian, host
from hri_envs.physics.scene.warp.model import WarpModel

__all__ = ["WarpArms"]


class WarpArms:
    """The whole arm's indices and the human's controller, per world.

    Args:
        n: The number of worlds.
        model: The C scene.
        arm: The C sim's :class:`~hri_envs.physics.carry.human.whole_arm.WholeArm`.
        posture: (7,) the comfortable posture; posture_gains: (K_n, D_n).
        actuators: (7,) the arm's torque motors.
        rest_quat: The object's rest orientation; handle_pos, handle_quat: the handle in
            the object's frame.

    Attributes:
        gains: (n, 4) each world's hand impedance (K, D, K_r, D_r).
        lo, hi: (n, 7) each world's strength limits [N m].
        hand_in_torso: (n, 3) each world's comfortable hand in the torso frame.
        torso_height: (n,) each world's torso height [m] (the human's body size,
            :class:`~hri_envs.physics.carry.human.body.ArmBody`).
    """

    def __init__(self, n: int, model: mujoco.MjModel, arm: WholeArm, posture: np.ndarray,
                 posture_gains: tuple[float, float], actuators: np.ndarray,
                 rest_quat: np.ndarray, handle_pos: np.ndarray, handle_quat: np.ndarray) -> None:
        a = arm
        self.grip_site, self.handle_site = a.grip_site, a.handle_site
        self.arm_qpos, self.arm_dofs = a.arm_qpos, a.arm_dofs
        self.torso_actuators = a.torso_actuators
        self.hand_in_torso = np.tile(np.asarray(a.hand_in_torso, float), (n, 1))
        self.torso_height = np.full(n, a.torso_height_m)
        torso_joints = [int(np.flatnonzero(model.jnt_dofadr == d)[0]) for d in a.torso_dofs]
        self.joints = np.array([*torso_joints, *a.arm_joints])
        self.dofs = model.jnt_dofadr[self.joints]
        self.hinge = model.jnt_type[self.joints] == mujoco.mjtJoint.mjJNT_HINGE
        self.n_torso = len(torso_joints)
        self.posture = np.asarray(posture, float)
        self.kn, self.dn = float(posture_gains[0]), float(posture_gains[1])
        self.actuators = np.asarray(actuators)
        self.rest_quat = np.asarray(rest_quat, float)
        self.handle_pos = np.asarray(handle_pos, float)
        self.handle_quat = np.asarray(handle_quat, float)
        n_j = len(self.posture)
        # The arm's columns of the chain's Jacobian, in the arm's own coordinates.
        self.cols = np.arange(self.n_torso, self.n_torso + n_j, dtype=np.int64)
        self.coupling = np.tile(np.eye(n_j), (n, 1, 1))
        self.gains = np.ones((n, 4))
        self.lo, self.hi = -np.ones((n, n_j)), np.ones((n, n_j))

    def jacobian(self, wm: WarpModel, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, 6, 4 + 7) the grip frame's Jacobian in the torso's and the arm's joints, and
        (R, 3) the grip frame's position.
        """
        site = host(wm, "site_xpos", rows, self.grip_site)
        jac, _, _ = chain_jacobian(wm, rows, self.joints, self.hinge, site)
        return jac, site

    def torques(self, wm: WarpModel, rows: np.ndarray, ref: np.ndarray,
                feedforward: np.ndarray, gains: np.ndarray) -> np.ndarray:
        """HandImpedance.torques per world (``hand_impedance`` of
        :mod:`~hri_envs.physics.carry.human.laws`): (R, 7) joint torques for the hand's references
        (R, 13), plus the (R, 6) feed-forward wrenches, with the (R, 4) gains.
        """
        jac, site = self.jacobian(wm, rows)
        qvel = host(wm, "qvel", rows)
        q = np.ascontiguousarray(host(wm, "qpos", rows)[:, self.arm_qpos])
        out = np.empty((len(rows), len(self.posture)))
        hl.hand_impedance(jac, np.ascontiguousarray(qvel[:, self.dofs]), self.cols,
                          self.coupling[:len(rows)], site,
                          host(wm, "site_xmat", rows, self.grip_site), ref,
                          np.ascontiguousarray(gains, dtype=float), feedforward, q,
                          np.ascontiguousarray(qvel[:, self.arm_dofs]), self.posture, self.kn,
                          self.dn, POSTURE_REGULARIZATION, out)
        return out

    def max_lift(self, wm: WarpModel, rows: np.ndarray) -> np.ndarray:
        """CarrySim.max_lift_n per world: (R,) the greatest upward force [N] at the hand."""
        jac, _ = self.jacobian(wm, rows)
        moment = np.abs(jac[:, 2, self.n_torso:])
        lim = np.minimum(-self.lo[rows], self.hi[rows])
        with np.errstate(divide="ignore"):
            ratio = np.where(moment > 1e-9, lim / np.where(moment > 1e-9, moment, 1.0), np.inf)
        return ratio.min(axis=1)
