"""The reference IK builds mink's QP and gets mink's solution, with less of mink's work.

:class:`~hri_envs.physics.scene.ik.ReferenceIK` reuses what ``mink.build_ik`` would compute anew
every step (the posture task's weighted Jacobian, the joint limits' constraint matrix) and
calls daqp as qpsolvers does; these tests hold it to mink's numbers, bit for bit.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

pytest.importorskip("mujoco")

import mink  # noqa: E402

from hri_envs.physics.carry.sim import CarrySim  # noqa: E402
from hri_envs.physics.scene.ik import ReferenceIK  # noqa: E402
from hri_envs.physics.scene.kinematics import Pose, slerp  # noqa: E402
from hri_envs.task.scenarios import scenario_graph  # noqa: E402


@pytest.fixture(scope="module", params=["hanger", "wheel"])
def sim(request: pytest.FixtureRequest) -> CarrySim:
    sim = CarrySim(scenario_graph(request.param))
    sim.reset(1, 0, np.random.default_rng(0))
    return sim


def _targets(sim: CarrySim, n: int) -> list[Pose]:
    rng = np.random.default_rng(3)
    g = sim.grip_pose()
    return [Pose(g.pos + 0.03 * rng.standard_normal(3), g.quat) for _ in range(n)]


def _mink_step(ik: ReferenceIK, target: Pose, dt: float) -> np.ndarray:
    """What ReferenceIK.step did with mink.solve_ik."""
    cfg = ik.configuration
    ik.frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3(target.quat),
                                                               target.pos))
    v = mink.solve_ik(cfg, [ik.frame, ik.posture], dt, "daqp", damping=1e-4,
                      limits=ik.limits)
    cfg.integrate_inplace(v, dt)
    return np.asarray(cfg.q[:ik.n]).copy()


def test_the_qp_is_minks(sim: CarrySim) -> None:
    ik = sim.ik
    for target in _targets(sim, 30):
        ik.frame.set_target(mink.SE3.from_rotation_and_translation(mink.SO3(target.quat),
                                                                   target.pos))
        ours = ik.qp(0.04)
        theirs = mink.build_ik(ik.configuration, [ik.frame, ik.posture], 0.04, 1e-4,
                               ik.limits)
        for a, b in zip(ours, (theirs.P, theirs.q, theirs.G, theirs.h), strict=True):
            np.testing.assert_array_equal(a, b)
        ik.step(target, 0.04)


def _mink_solve(ik: ReferenceIK, target: Pose, iterations: int) -> float:
    """What ReferenceIK.solve did with mink.solve_ik."""
    start = ik.current()
    for i in range(1, 21):
        x = i / 20
        _mink_step(ik, Pose(start.pos + x * (target.pos - start.pos),
                            slerp(start.quat, target.quat, x)), 0.05)
    err = np.inf
    for _ in range(iterations):
        _mink_step(ik, target, 0.05)
        err = ik.error()
        if err < 1e-3:
            break
    return err


def test_steps_and_solves_follow_mink_bit_for_bit(sim: CarrySim) -> None:
    ours, theirs = sim.ik, copy.deepcopy(sim.ik)
    for target in _targets(sim, 40):
        np.testing.assert_array_equal(ours.step(target, 0.04).copy(),
                                      _mink_step(theirs, target, 0.04))
    for iterations in (0, 1, 30):
        goal = _targets(sim, 1)[0]
        assert ours.solve(goal, iterations=iterations) == _mink_solve(theirs, goal, iterations)
        np.testing.assert_array_equal(ours.configuration.q, theirs.configuration.q)
