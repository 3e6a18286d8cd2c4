"""Poses, quaternions ``(w, x, y, z)`` and straight-line trajectories between them.

An abstract action is tracked as one straight line (paper Sect. 4.2): the position moves
linearly and the orientation is interpolated on the shortest arc (slerp), both with the
same minimum-jerk time scaling, so the motion starts and ends at rest.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
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


def cross3(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """The cross product a × b of two 3-vectors of plain floats (the control loop's small
    arithmetic: np.cross costs far more for one pair; element by element the same IEEE
    arithmetic as numpy's).
    """
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


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
    conj = np.empty(4)
    mujoco.mju_negQuat(conj, np.ascontiguousarray(q, float))
    e = np.empty(4)
    mujoco.mju_mulQuat(e, np.ascontiguousarray(q_target, float), conj)
    w, x, y, z = e.tolist()
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return np.array([2.0 * x, 2.0 * y, 2.0 * z])
    # numpy's arctan2, not math.atan2: the two differ in the last bit for some arguments.
    k = 2.0 * float(np.arctan2(s, w)) / s
    return np.array([k * x, k * y, k * z])


def slerp(q0: np.ndarray, q1: np.ndarray, s: float) -> np.ndarray:
    """Shortest-arc interpolation from ``q0`` (s = 0) to ``q1`` (s = 1)."""
    dot = float(q0.dot(q1))
    w0, x0, y0, z0 = q0.tolist()
    w1, x1, y1, z1 = q1.tolist()
    if dot < 0.0:
        w1, x1, y1, z1, dot = -w1, -x1, -y1, -z1, -dot
    if dot > 0.9995:
        q = np.array([w0 + s * (w1 - w0), x0 + s * (x1 - x0), y0 + s * (y1 - y0),
                      z0 + s * (z1 - z0)])
        return q / math.sqrt(q.dot(q))  # = np.linalg.norm(q), bit for bit
    theta = float(np.arccos(dot))  # numpy's, like arctan2 above
    a, b, c = np.sin(np.array([(1 - s) * theta, s * theta, theta])).tolist()
    return np.array([(a * w0 + b * w1) / c, (a * x0 + b * x1) / c, (a * y0 + b * y1) / c,
                     (a * z0 + b * z1) / c])


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
        # Plain floats for sample(), which runs every control period.
        self._start = (*start.pos.tolist(), *self.delta.tolist(), *self.rotvec.tolist())
        self._end: TrajectorySample | None = None  # the sample at t >= duration, once made

    def sample(self, t: float) -> TrajectorySample:
        """The reference at time ``t`` [s] after the start (clamped to the ends).

        From ``duration`` on the sample is the goal at rest, the same arrays each call
        (read-only: do not modify them).
        """
        if t >= self.duration and self._end is not None:
            return self._end
        tau = min(max(t / self.duration, 0.0), 1.0)
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
        ds = 30.0 * tau * tau * (1.0 - tau) ** 2 / self.duration
        p0, p1, p2, d0, d1, d2, r0, r1, r2 = self._start
        sample = TrajectorySample(np.array([p0 + s * d0, p1 + s * d1, p2 + s * d2]),
                                  slerp(self.start.quat, self.goal.quat, s),
                                  np.array([ds * d0, ds * d1, ds * d2]),
                                  np.array([ds * r0, ds * r1, ds * r2]))
        if t >= self.duration:  # tau = 1 from here on: keep it (t / duration >= 1 exactly)
            self._end = sample
        return sample
