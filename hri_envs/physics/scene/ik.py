"""Reference joint configurations from mink differential IK (QP solver daqp).

At 25 Hz the reference configuration takes one differential-IK step towards the current
Cartesian reference of the grip frame, under the joint limits, with a posture task that
keeps the arm near its nominal configuration (and lets a mobile base do the travelling).
The controller pulls the arm towards this configuration in the null space of the Cartesian
task (paper Sect. 4.2 uses a GP-learned IK for the same purpose).
"""

from __future__ import annotations

from ctypes import c_int

import daqp
import mink
import mujoco
import numpy as np

from hri_envs.errors import PhysicsFault
from hri_envs.physics.scene.kinematics import Pose, slerp

__all__ = ["IKFailure", "ReferenceIK"]

_C_INT = np.dtype(c_int)  # daqp's constraint senses


class IKFailure(PhysicsFault):
    """The IK problem has no solution, or the reference cannot follow its target.

    A :class:`~hri_envs.errors.PhysicsFault`, hence still a :class:`RuntimeError`.
    """


class ReferenceIK:
    """Differential IK on the robot-only model.

    Args:
        model: The robot-only model (:func:`hri_envs.physics.scene.build.build_robot_model`).
        n_joints: Number of controlled joints (leading qpos entries: base, then arm).
        n_base: How many of them are mobile-base joints.
        home: (n_joints,) nominal configuration (posture task target for the arm).
        site: Name of the grip site.
    """

    def __init__(self, model: mujoco.MjModel, n_joints: int, n_base: int, home: np.ndarray,
                 site: str = "grip") -> None:
        self.model, self.n, self.n_base = model, n_joints, n_base
        self.configuration = mink.Configuration(model)
        self.frame = mink.FrameTask(site, "site", position_cost=1.0, orientation_cost=0.5,
                                    lm_damping=1e-3)
        cost = np.full(model.nv, 1e-2)
        cost[:n_base] = 1e-4
        self.posture = mink.PostureTask(model, cost=cost)
        self.limits = [mink.ConfigurationLimit(model, gain=0.9)]
        self.home = np.array(model.qpos0)
        self.home[:n_joints] = home
        self.home[n_joints:] = 0.04  # fingers open
        self.posture.set_target(self.home)
        self.tasks = [self.frame, self.posture]
        # What mink's build_ik computes anew each step though it never changes: the posture
        # task's weighted Jacobian (cost x identity) and the joint limits' G = [P; -P].
        proj = self.limits[0].projection_matrix
        self._posture_wj = self.posture.cost[:, None] * self.posture.compute_jacobian(
            self.configuration)
        self._cached = proj is not None and not np.any(
            model.jnt_type == mujoco.mjtJoint.mjJNT_BALL)
        self._limit_g = np.vstack([proj, -proj]) if proj is not None else np.zeros((0, 0))
        self._dq_max, self._dq_min = np.empty(model.nv), np.empty(model.nv)
        # The stacked weighted Jacobians and errors (frame task's 6 rows, then the posture's).
        self._w, self._e = np.empty((6 + model.nv, model.nv)), np.empty(6 + model.nv)
        self._w[6:] = self._posture_wj

    @property
    def q(self) -> np.ndarray:
        """(n_joints,) the current reference configuration."""
        return self.configuration.q[: self.n].copy()

    def reset(self, q: np.ndarray, base_target: np.ndarray | None = None) -> None:
        """Restart from configuration ``q`` (n_joints,); optionally re-centre the base."""
        full = self.home.copy()
        full[: self.n] = q
        self.configuration.update(full)
        target = self.home.copy()
        if self.n_base:
            target[: self.n_base] = q[: self.n_base] if base_target is None else base_target
        self.posture.set_target(target)

    def error(self) -> float:
        """Position error [m] plus 0.1 m/rad times the orientation error, of the reference."""
        e = self.frame.compute_error(self.configuration)
        return float(np.linalg.norm(e[:3]) + 0.1 * np.linalg.norm(e[3:]))

    def step(self, target: Pose, dt: float) -> np.ndarray:
        """One differential-IK step of ``dt`` [s] towards ``target``; the new reference.

        Raises:
            IKFailure: The QP has no solution.
        """
        self.frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3(target.quat),
                                                                     target.pos))
        return self._advance(dt)

    def _advance(self, dt: float) -> np.ndarray:
        """:meth:`step` towards the frame task's target as set."""
        # mink.solve_ik(configuration, tasks, dt, "daqp", damping=1e-4, limits=...) without
        # its limit check (a debug log) and qpsolvers' dispatch: the same QP (qp()), which
        # daqp solves with the arguments qpsolvers passes (the same solution).
        p, q, g, h = self.qp(dt)
        x, _, exitflag, _ = daqp.solve(p, q, g, h, np.full(h.size, -1e30),
                                       np.zeros(h.size, _C_INT))
        if exitflag <= 0:
            raise IKFailure(f"mink found no IK solution: {mink.NoSolutionFound('daqp')}")
        self.configuration.integrate_inplace(x / dt, dt)
        return self.configuration.q[: self.n]

    def qp(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The step's QP ``min ½ xᵀ P x + qᵀ x, G x <= h`` as ``mink.build_ik`` builds it
        (the same numbers, tests/test_physics_ik.py), reusing what does not change.
        """
        cfg = self.configuration
        if not self._cached:
            problem = mink.build_ik(cfg, self.tasks, dt, 1e-4, self.limits)
            n = self.model.nv
            return (np.asarray(problem.P), problem.q,
                    np.zeros((0, n)) if problem.G is None else np.asarray(problem.G),
                    np.zeros(0) if problem.h is None else problem.h)
        wj_f, we_f, mu_f = self.frame.compute_qp_residual(cfg)
        post = self.posture
        we_p = post.cost * (-post.gain * post.compute_error(cfg))
        mu_p = post.lm_damping * float(we_p @ we_p)
        w, e = self._w, self._e
        w[:6], e[:6], e[6:] = wj_f, we_f, we_p
        p = w.T @ w
        q = -(e @ w)
        mu = 0.0
        mu += mu_f
        mu += mu_p
        p.flat[:: self.model.nv + 1] += 1e-4 + mu
        limit = self.limits[0]
        mujoco.mj_differentiatePos(self.model, self._dq_max, 1.0, cfg.q, limit.upper)
        mujoco.mj_differentiatePos(self.model, self._dq_min, 1.0, limit.lower, cfg.q)
        h = np.hstack([limit.gain * self._dq_max[limit.indices],
                       limit.gain * self._dq_min[limit.indices]])
        return p, q, self._limit_g, h

    def current(self) -> Pose:
        """The grip frame's pose at the reference configuration."""
        t = self.configuration.get_transform_frame_to_world(self.frame.frame_name, "site")
        wxyz_xyz = t.wxyz_xyz
        return Pose(np.array(wxyz_xyz[4:]), np.array(wxyz_xyz[:4]))

    def solve(self, target: Pose, iterations: int = 200, tolerance: float = 1e-3,
              approach_steps: int = 20) -> float:
        """Move the reference to ``target`` along a straight line (``approach_steps``
        increments, so the solution stays on the branch of the start), then iterate
        :meth:`step` until the error is below ``tolerance``; the final error.
        """
        start = self.current()
        for i in range(1, approach_steps + 1):
            x = i / approach_steps
            self.step(Pose(start.pos + x * (target.pos - start.pos),
                           slerp(start.quat, target.quat, x)), 0.05)
        err = np.inf
        for it in range(iterations):
            if it == 0:
                self.step(target, 0.05)  # sets the target, the same for every iteration
            else:
                self._advance(0.05)
            err = self.error()
            if err < tolerance:
                break
        return err
