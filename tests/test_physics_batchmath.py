"""The batched pose arithmetic of the mjwarp backend against the single-world formulas."""

import mujoco
import numpy as np

from hri_envs.physics.scene.kinematics import Pose, StraightLine, rotation_error, slerp
from hri_envs.physics.scene.warp import batchmath as bm


def _unit_quats(n, seed=0):
    q = np.random.default_rng(seed).standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_mat_to_quat_is_mujocos():
    q = _unit_quats(400)
    # Near-identity and half-turn rotations reach every branch of mju_mat2Quat.
    q[:4] = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    mats = bm.quat_to_mat(q)
    for m, got in zip(mats, bm.mat_to_quat(mats), strict=True):
        want = np.empty(4)
        mujoco.mju_mat2Quat(want, m.ravel())
        np.testing.assert_allclose(got, want, atol=1e-12)
        ref = np.empty(9)
        mujoco.mju_quat2Mat(ref, want)
        np.testing.assert_allclose(m.ravel(), ref, atol=1e-12)


def test_rotation_error_and_slerp_match_the_single_world_code():
    a, b = _unit_quats(300, 1), _unit_quats(300, 2)
    b[:10] = a[:10]  # no rotation: the small-angle branch
    b[10:20] = -a[10:20] * np.cos(1e-3) + 0.0  # nearly the same rotation, other sign
    b[10:20] /= np.linalg.norm(b[10:20], axis=1, keepdims=True)
    s = np.random.default_rng(3).uniform(0, 1, 300)
    err, lerp = bm.rotation_error(a, b), bm.slerp(a, b, s)
    for i in range(300):
        np.testing.assert_allclose(err[i], rotation_error(a[i], b[i]), atol=1e-12)
        np.testing.assert_allclose(lerp[i], slerp(a[i], b[i], s[i]), atol=1e-12)


def test_line_samples_match_straight_line():
    rng = np.random.default_rng(4)
    q0, q1 = _unit_quats(50, 5), _unit_quats(50, 6)
    p0, p1 = rng.uniform(-1, 1, (50, 3)), rng.uniform(-1, 1, (50, 3))
    lines = [StraightLine(Pose(p0[i], q0[i]), Pose(p1[i], q1[i]), 0.2, 1.0, 0.6)
             for i in range(50)]
    t = rng.uniform(-0.5, 1.2, 50) * np.array([ln.duration for ln in lines])
    pos, quat, vel, angvel = bm.line_sample(
        t, np.array([ln.duration for ln in lines]), p0, p1 - p0, q0, q1,
        np.array([ln.rotvec for ln in lines]))
    for i, ln in enumerate(lines):
        want = ln.sample(t[i])
        np.testing.assert_allclose(pos[i], want.pos, atol=1e-12)
        np.testing.assert_allclose(quat[i], want.quat, atol=1e-12)
        np.testing.assert_allclose(vel[i], want.vel, atol=1e-12)
        np.testing.assert_allclose(angvel[i], want.angvel, atol=1e-12)
