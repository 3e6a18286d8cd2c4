"""Compiled (numba) pose arithmetic on plain floats for :mod:`hri_envs.physics.scene.laws`.

Quaternions are ``(w, x, y, z)`` tuples of floats, vectors ``(x, y, z)`` tuples; rotation
matrices are read from row-major (9,) array views, as MuJoCo stores them (``xmat``,
``site_xmat``). The formulas are MuJoCo's (``mju_mulQuat``, ``mju_rotVecQuat``,
``mju_quat2Mat``, ``mju_mat2Quat``) and :mod:`~hri_envs.physics.scene.kinematics`'s (rotation
error, slerp, minimum-jerk samples), element by element in the same order, so the compiled
laws follow the numpy ones up to the last bits (a dot product's summation order, libm's
``atan2`` and ``sin`` against numpy's). ``cache=True`` compiles once per machine.
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.scene.jit import kernel

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]

_MINVAL = 1e-15  # MuJoCo's mjMINVAL: mju_normalize4 leaves a quaternion this close alone


@kernel
def vec3(a: np.ndarray) -> Vec:
    """The first three entries of ``a`` as a tuple."""
    return (a[0], a[1], a[2])


@kernel
def quat4(a: np.ndarray) -> Quat:
    """The first four entries of ``a`` as a tuple."""
    return (a[0], a[1], a[2], a[3])


@kernel
def dot3(a: Vec, b: Vec) -> float:
    """The dot product a · b, summed left to right."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@kernel
def cross3(a: Vec, b: Vec) -> Vec:
    """The cross product a × b (as :func:`hri_envs.physics.scene.kinematics.cross3`)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@kernel
def quat_mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product a ⊗ b (``mju_mulQuat``)."""
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


@kernel
def quat_conj(q: Quat) -> Quat:
    """The inverse of a unit quaternion."""
    return (q[0], -q[1], -q[2], -q[3])


@kernel
def rotate_vec(v: Vec, q: Quat) -> Vec:
    """``v`` rotated by ``q`` (``mju_rotVecQuat``)."""
    if v[0] == 0.0 and v[1] == 0.0 and v[2] == 0.0:
        return (0.0, 0.0, 0.0)
    if q[0] == 1.0 and q[1] == 0.0 and q[2] == 0.0 and q[3] == 0.0:
        return v
    t0 = q[0] * v[0] + q[2] * v[2] - q[3] * v[1]
    t1 = q[0] * v[1] + q[3] * v[0] - q[1] * v[2]
    t2 = q[0] * v[2] + q[1] * v[1] - q[2] * v[0]
    return (v[0] + 2 * (q[2] * t2 - q[3] * t1), v[1] + 2 * (q[3] * t0 - q[1] * t2),
            v[2] + 2 * (q[1] * t1 - q[2] * t0))


@kernel
def quat_to_mat(q: Quat) -> tuple[float, float, float, float, float, float, float, float,
                                  float]:
    """Row-major rotation matrix of a unit quaternion (``mju_quat2Mat``)."""
    if q[0] == 1.0 and q[1] == 0.0 and q[2] == 0.0 and q[3] == 0.0:
        return (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    q00, q01, q02, q03 = q[0] * q[0], q[0] * q[1], q[0] * q[2], q[0] * q[3]
    q11, q12, q13 = q[1] * q[1], q[1] * q[2], q[1] * q[3]
    q22, q23, q33 = q[2] * q[2], q[2] * q[3], q[3] * q[3]
    return (q00 + q11 - q22 - q33, 2 * (q12 - q03), 2 * (q13 + q02),
            2 * (q12 + q03), q00 - q11 + q22 - q33, 2 * (q23 - q01),
            2 * (q13 - q02), 2 * (q23 + q01), q00 - q11 - q22 + q33)


@kernel
def mat_to_quat(m: np.ndarray) -> Quat:
    """The unit quaternion of a row-major (9,) rotation matrix (``mju_mat2Quat``)."""
    if m[0] + m[4] + m[8] > 0:
        w = 0.5 * math.sqrt(1 + m[0] + m[4] + m[8])
        q = (w, 0.25 * (m[7] - m[5]) / w, 0.25 * (m[2] - m[6]) / w, 0.25 * (m[3] - m[1]) / w)
    elif m[0] > m[4] and m[0] > m[8]:
        x = 0.5 * math.sqrt(1 + m[0] - m[4] - m[8])
        q = (0.25 * (m[7] - m[5]) / x, x, 0.25 * (m[1] + m[3]) / x, 0.25 * (m[2] + m[6]) / x)
    elif m[4] > m[8]:
        y = 0.5 * math.sqrt(1 - m[0] + m[4] - m[8])
        q = (0.25 * (m[2] - m[6]) / y, 0.25 * (m[1] + m[3]) / y, y, 0.25 * (m[5] + m[7]) / y)
    else:
        z = 0.5 * math.sqrt(1 - m[0] - m[4] + m[8])
        q = (0.25 * (m[3] - m[1]) / z, 0.25 * (m[2] + m[6]) / z, 0.25 * (m[5] + m[7]) / z, z)
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if norm < _MINVAL:
        return (1.0, 0.0, 0.0, 0.0)
    if abs(norm - 1) > _MINVAL:
        inv = 1 / norm
        return (q[0] * inv, q[1] * inv, q[2] * inv, q[3] * inv)
    return q


@kernel
def mat_vec(m: np.ndarray, v: Vec) -> Vec:
    """A row-major (9,) matrix times ``v``."""
    return (m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2])


@kernel
def rotation_error(q_target: Quat, q: Quat) -> Vec:
    """World-frame rotation vector that turns ``q`` into ``q_target``
    (:func:`hri_envs.physics.scene.kinematics.rotation_error`).
    """
    w, x, y, z = quat_mul(q_target, quat_conj(q))
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return (2.0 * x, 2.0 * y, 2.0 * z)
    k = 2.0 * math.atan2(s, w) / s
    return (k * x, k * y, k * z)


@kernel
def rotate_by(q: Quat, rv: Vec) -> Quat:
    """``q`` turned by the world-frame rotation vector ``rv`` (``carry._rotate``)."""
    angle = math.sqrt(rv[0] * rv[0] + rv[1] * rv[1] + rv[2] * rv[2])
    if angle < 1e-12:
        return q
    s = math.sin(angle / 2)
    return quat_mul((math.cos(angle / 2), s * rv[0] / angle, s * rv[1] / angle,
                     s * rv[2] / angle), q)


@kernel
def slerp(q0: Quat, q1: Quat, s: float) -> Quat:
    """Shortest-arc interpolation (:func:`hri_envs.physics.scene.kinematics.slerp`)."""
    w0, x0, y0, z0 = q0
    w1, x1, y1, z1 = q1
    dot = w0 * w1 + x0 * x1 + y0 * y1 + z0 * z1
    if dot < 0.0:
        w1, x1, y1, z1, dot = -w1, -x1, -y1, -z1, -dot
    if dot > 0.9995:
        w, x, y, z = (w0 + s * (w1 - w0), x0 + s * (x1 - x0), y0 + s * (y1 - y0),
                      z0 + s * (z1 - z0))
        n = math.sqrt(w * w + x * x + y * y + z * z)
        return (w / n, x / n, y / n, z / n)
    theta = math.acos(dot)
    a, b, c = math.sin((1 - s) * theta), math.sin(s * theta), math.sin(theta)
    return ((a * w0 + b * w1) / c, (a * x0 + b * x1) / c, (a * y0 + b * y1) / c,
            (a * z0 + b * z1) / c)


@kernel
def min_jerk(tau: float) -> float:
    """The minimum-jerk phase s(τ) = τ³ (10 - 15 τ + 6 τ²) (``pow`` as Python's ``**``)."""
    return math.pow(tau, 3.0) * (10.0 - 15.0 * tau + 6.0 * tau * tau)


@kernel
def interp(x: float, xp: np.ndarray, fp: np.ndarray) -> float:
    """``np.interp(x, xp, fp)`` for one point and increasing ``xp`` (numpy's rule)."""
    n = len(xp)
    if x < xp[0]:
        return fp[0]
    if x > xp[n - 1]:
        return fp[n - 1]
    lo, hi = 0, n - 1
    while hi - lo > 1:  # xp[lo] <= x < xp[hi]
        mid = (lo + hi) // 2
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    if x >= xp[n - 1]:
        return fp[n - 1]
    if xp[lo] == x:
        return fp[lo]
    slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo])
    return slope * (x - xp[lo]) + fp[lo]


@kernel
def cholesky_solve(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """Solve ``a x = b`` for a symmetric positive definite (k, k) ``a`` (overwritten by its
    Cholesky factor, lower triangle) into ``out`` (k,).
    """
    k = a.shape[0]
    for j in range(k):
        d = a[j, j]
        for p in range(j):
            d -= a[j, p] * a[j, p]
        d = math.sqrt(d)
        a[j, j] = d
        for i in range(j + 1, k):
            v = a[i, j]
            for p in range(j):
                v -= a[i, p] * a[j, p]
            a[i, j] = v / d
    for i in range(k):  # L y = b
        v = b[i]
        for p in range(i):
            v -= a[i, p] * out[p]
        out[i] = v / a[i, i]
    for i in range(k - 1, -1, -1):  # Lᵀ x = y
        v = out[i]
        for p in range(i + 1, k):
            v -= a[p, i] * out[p]
        out[i] = v / a[i, i]
