"""Poses, quaternions ``(w, x, y, z)`` and straight-line trajectories between them.

An abstract action is tracked as one straight line (paper Sect. 4.2): the position moves
linearly and the orientation is interpolated on the shortest arc (slerp), both with the
same minimum-jerk time scaling, so the motion starts and ends at rest.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

__all__ = [
    "Pose",
    "StraightLine",
    "TrajectorySample",
    "compose",
    "cross3",
    "quat_conj",
    "quat_mul",
    "quat_to_mat",
    "rotation_error",
    "slerp",
]


class Pose(NamedTuple):
    """A rigid pose: position [m] (3,) and unit quaternion (4,) of a frame in the world."""

    pos: np.ndarray
    quat: np.ndarray


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a ⊗ b``."""
    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.ascontiguousarray(a, float), np.ascontiguousarray(b, float))
    return out


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The cross product a × b of two 3-vectors (np.cross costs more for one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Inverse of a unit quaternion."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion."""
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.ascontiguousarray(q, float))
    return out.reshape(3, 3)


def rotation_error(q_target: np.ndarray, q: np.ndarray) -> np.ndarray:
    """World-frame rotation vector [rad] (3,) that turns ``q`` into ``q_target``."""
    e = quat_mul(q_target, quat_conj(q))
    if e[0] < 0.0:
        e = -e
    s = float(np.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]))
    if s < 1e-12:
        return 2.0 * e[1:]
    return (2.0 * np.arctan2(s, e[0]) / s) * e[1:]


def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Shortest-arc interpolation from ``q0`` (s = 0) to ``q1`` (s = 1)."""
    dot = float(np.dot(q0, q1))
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:
        q = q0 + s * (q1 - q0)
        return q / np.linalg.norm(q)
    theta = np.arccos(dot)
    return (np.sin((1 - s) * theta) * q0 + np.sin(s * theta) * q1) / np.sin(theta)


def compose(pose: Pose, pos_local: np.ndarray, quat_local: np.ndarray) -> Pose:
    """The pose of a frame given in ``pose``'s local coordinates, in the world."""
    return Pose(pose.pos + quat_to_mat(pose.quat) @ pos_local, quat_mul(pose.quat, quat_local))


class TrajectorySample(NamedTuple):
    """A point of a trajectory: pose, linear velocity [m/s] and angular velocity [rad/s]."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    angvel: np.ndarray


class StraightLine:
    """Straight-line motion between two poses with minimum-jerk timing.

    Args:
        start: Initial pose.
        goal: Final pose.
        linear_speed: Peak linear speed [m/s].
        angular_speed: Peak angular speed [rad/s].
        min_duration: Shortest duration [s].
    """

    def __init__(self, start: Pose, goal: Pose, linear_speed: float, angular_speed: float,
                 min_duration: float = 0.6) -> None:
        self.start, self.goal = start, goal
        self.delta = goal.pos - start.pos
        self.rotvec = rotation_error(goal.quat, start.quat)
        distance, angle = float(np.linalg.norm(self.delta)), float(np.linalg.norm(self.rotvec))
        # A minimum-jerk profile peaks at 1.875 times its mean speed.
        self.duration = max(1.875 * distance / linear_speed, 1.875 * angle / angular_speed,
                            min_duration)
        self.direction = self.delta / distance if distance > 1e-9 else np.zeros(3)
        self.axis = self.rotvec / angle if angle > 1e-9 else np.zeros(3)

    def sample(self, t: float) -> TrajectorySample:
        """The reference at time ``t`` [s] after the start (clamped to the ends)."""
        tau = min(max(t / self.duration, 0.0), 1.0)
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
        ds = 30.0 * tau * tau * (1.0 - tau) ** 2 / self.duration
        return TrajectorySample(self.start.pos + s * self.delta,
                                slerp(self.start.quat, self.goal.quat, s),
                                ds * self.delta, ds * self.rotvec)
