"""Pose arithmetic over a leading axis of worlds: what :mod:`hri_envs.physics.scene.kinematics`
does for one pose, on ``(N, ...)`` arrays.

Quaternions are ``(w, x, y, z)``; every function takes and returns float64 arrays with the
worlds along the first axis. The formulas are those of the single-world code (MuJoCo's
``mju_mat2Quat``, ``mju_mulQuat``; the shortest-arc slerp and rotation error of
:mod:`~hri_envs.physics.scene.kinematics`), so a world here follows the C backend's arithmetic up
to rounding.
"""

from __future__ import annotations

import numpy as np

__all__ = ["dot", "line_sample", "mat_to_quat", "quat_conj", "quat_mul",
           "quat_to_mat", "rotate", "rotation_error", "slerp"]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (N, k) arrays: (N,)."""
    return np.einsum("ij,ij->i", a, b)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """(N, 4) inverses of unit quaternions."""
    out = -q
    out[:, 0] = q[:, 0]
    return out


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, 4) Hamilton products ``a ⊗ b``."""
    w1, x1, y1, z1 = a.T
    w2, x2, y2, z2 = b.T
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=1)


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of (N, 4) unit quaternions."""
    w, x, y, z = q.T
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = w * w + x * x - y * y - z * z
    out[:, 0, 1] = 2 * (x * y - w * z)
    out[:, 0, 2] = 2 * (x * z + w * y)
    out[:, 1, 0] = 2 * (x * y + w * z)
    out[:, 1, 1] = w * w - x * x + y * y - z * z
    out[:, 1, 2] = 2 * (y * z - w * x)
    out[:, 2, 0] = 2 * (x * z - w * y)
    out[:, 2, 1] = 2 * (y * z + w * x)
    out[:, 2, 2] = w * w - x * x - y * y + z * z
    return out


def mat_to_quat(mat: np.ndarray) -> np.ndarray:
    """(N, 4) unit quaternions of (N, 3, 3) rotation matrices (MuJoCo's ``mju_mat2Quat``)."""
    m = mat.reshape(-1, 9)
    q = np.empty((len(m), 4))
    tr = m[:, 0] + m[:, 4] + m[:, 8]
    c0 = tr > 0
    c1 = ~c0 & (m[:, 0] > m[:, 4]) & (m[:, 0] > m[:, 8])
    c2 = ~c0 & ~c1 & (m[:, 4] > m[:, 8])
    c3 = ~(c0 | c1 | c2)
    with np.errstate(divide="ignore", invalid="ignore"):
        for case, (i, sign), pairs in (
                (c0, (0, (1, 1, 1)), ((1, 7, 5, -1), (2, 2, 6, -1), (3, 3, 1, -1))),
                (c1, (1, (1, -1, -1)), ((0, 7, 5, -1), (2, 1, 3, 1), (3, 2, 6, 1))),
                (c2, (2, (-1, 1, -1)), ((0, 2, 6, -1), (1, 1, 3, 1), (3, 5, 7, 1))),
                (c3, (3, (-1, -1, 1)), ((0, 3, 1, -1), (1, 2, 6, 1), (2, 5, 7, 1)))):
            if not case.any():
                continue
            r = m[case]
            big = 0.5 * np.sqrt(1 + sign[0] * r[:, 0] + sign[1] * r[:, 4] + sign[2] * r[:, 8])
            q[case, i] = big
            for j, a, b, s in pairs:
                q[case, j] = 0.25 * (r[:, a] + s * r[:, b]) / big
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, 3) vectors ``v`` rotated by the (N, 4) quaternions ``q``."""
    return np.einsum("nij,nj->ni", quat_to_mat(q), v)


def rotation_error(q_target: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(N, 3) world-frame rotation vectors [rad] that turn ``q`` into ``q_target``."""
    e = quat_mul(q_target, quat_conj(q))
    e[e[:, 0] < 0.0] *= -1.0
    s = np.linalg.norm(e[:, 1:], axis=1)
    small = s < 1e-12
    k = np.where(small, 2.0, 2.0 * np.arctan2(s, e[:, 0]) / np.where(small, 1.0, s))
    return k[:, None] * e[:, 1:]


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(N, 4) shortest-arc interpolation from ``q0`` (s = 0) to ``q1`` (s = 1), s (N,)."""
    d = dot(q0, q1)
    q1 = np.where((d < 0.0)[:, None], -q1, q1)
    d = np.abs(d)
    near = d > 0.9995
    s_ = s[:, None]
    lin = q0 + s_ * (q1 - q0)
    lin /= np.linalg.norm(lin, axis=1, keepdims=True)
    theta = np.arccos(np.minimum(d, 1.0))
    c = np.sin(theta)
    c = np.where(near, 1.0, c)[:, None]
    arc = (np.sin((1 - s_) * theta[:, None]) * q0 + np.sin(s_ * theta[:, None]) * q1) / c
    return np.where(near[:, None], lin, arc)


def line_sample(t: np.ndarray, duration: np.ndarray, start: np.ndarray, delta: np.ndarray,
                q0: np.ndarray, q1: np.ndarray, rotvec: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Samples of straight lines with minimum-jerk timing at times ``t`` [s] (N,).

    As :meth:`hri_envs.physics.scene.kinematics.StraightLine.sample`: position (N, 3), quaternion
    (N, 4), linear (N, 3) and angular velocity (N, 3); clamped to the ends.
    """
    tau = np.clip(t / duration, 0.0, 1.0)
    s = tau ** 3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
    ds = 30.0 * tau * tau * (1.0 - tau) ** 2 / duration
    return (start + s[:, None] * delta, slerp(q0, q1, s), ds[:, None] * delta,
            ds[:, None] * rotvec)
