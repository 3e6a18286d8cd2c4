"""The robot's IK reference for N worlds at once: one batched mink-warp step, :class:`BatchIK`.

The C backends' :class:`~hri_envs.physics.scene.ik.ReferenceIK` (mink, QP solver daqp) takes one
differential-IK step of the robot-only model towards the grip frame's reference, under the
joint limits, with a posture task. Here the same problem (the same tasks, costs, damping and
limit gain) is one mink-warp problem per world, solved for all the worlds together.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.scene.warp.device import require_warp

__all__ = ["IK_ADMM_ITERATIONS", "BatchIK"]

#: ADMM iterations of mink-warp's box-constrained IK step. The IK reference steers the arm's
#: null space, so an unconverged QP lets a redundant arm drift away from the C backend's
#: (mink's daqp solves the QP exactly): on the wheel's human-led move down from A′ (10
#: joints) the object ended 18 mm from the C backend's with mink-warp's default 30
#: iterations, 1.6 mm with 100, 26 µm with 300 and 1.6 µm with 1000; the C IK itself in
#: place of mink-warp gave 0.3 µm.
IK_ADMM_ITERATIONS = 300


class BatchIK:
    """``n`` IK references on the robot-only model, one per world.

    Args:
        model: The robot-only model (:func:`hri_envs.physics.scene.build.build_robot_model`).
        n: The number of worlds.
        n_base: How many of the leading joints are mobile-base joints.
        home: (nq,) the full home configuration (the C reference's ``home``).
        device: The Warp device.

    Attributes:
        q: (n, nq) each world's reference configuration.
        target: (n, nq) each world's posture target.
        pose: (n, 7) each world's last frame target (quaternion, position).
    """

    def __init__(self, model: mujoco.MjModel, n: int, n_base: int, home: np.ndarray,
                 device: str) -> None:
        wp, _, mink_warp = require_warp()
        self._wp, self.device, self.model = wp, device, model
        with wp.ScopedDevice(device):
            self.config = mink_warp.Configuration(model, nworld=n, device=device)
            self.frame = mink_warp.FrameTask("grip", "site", position_cost=1.0,
                                             orientation_cost=0.5, lm_damping=1e-3)
            cost = np.full(model.nv, 1e-2)
            cost[:n_base] = 1e-4
            self.posture = mink_warp.PostureTask(model, cost=cost)
            self.solver = mink_warp.ConstrainedSolver(
                self.config, [mink_warp.ConfigurationLimit(model, gain=0.9)],
                damping=1e-4, admm_iters=IK_ADMM_ITERATIONS)
        self.q = np.repeat(np.asarray(home, float)[None], n, axis=0)
        self.target = self.q.copy()
        self.pose = np.zeros((n, 7))
        self.pose[:, 0] = 1.0

    def step(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray,
             dt: float) -> np.ndarray:
        """One differential-IK step of ``dt`` [s] of the worlds ``rows`` towards the grip
        poses (pos, quat); the others keep their reference. Returns the (R,) error of
        mink's ``ReferenceIK.error`` (position + 0.1 m/rad x orientation of the frame task).
        """
        wp = self._wp
        self.pose[rows, :4] = quat
        self.pose[rows, 4:] = pos
        with wp.ScopedDevice(self.device):
            self.config.update(self.q)
            self.frame.set_target(self.pose)
            self.posture.set_target(self.target)
            v = self.solver.solve([self.frame, self.posture], dt)
            self.config.integrate_inplace(v, dt)
            q_new = self.config.q.numpy().astype(float)
            error = self.frame.compute_error(self.config).numpy().astype(float)
        self.q[rows] = q_new[rows]
        e = error[rows]
        return np.linalg.norm(e[:, :3], axis=1) + 0.1 * np.linalg.norm(e[:, 3:], axis=1)

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` take world ``src``'s reference, posture target and pose."""
        for value in (self.q, self.target, self.pose):
            value[rows] = value[src]
