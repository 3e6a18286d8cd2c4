"""The async measurement of benchmarks/physics_speed.py, for real (no timing thresholds)."""

import numpy as np
import pytest

from hri_envs.task.scenarios import scenario_graph

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def test_async_measurement_steps_every_env():
    from hri_envs.physics.panda.speed import async_steps_per_second

    res = async_steps_per_second(scenario_graph("hanger"), num_envs=2, seconds=0.5, seed=0)
    # Both envs step together: the count is a multiple of the number of envs, at least one
    # round; every step simulates time (a refused or aborted action settles for 0.15 s).
    assert res.abstract_steps >= 2 and res.abstract_steps % 2 == 0
    assert np.isfinite(res.wall_seconds) and res.wall_seconds >= 0.5
    assert res.sim_seconds >= 0.15 * res.abstract_steps
