"""Regret against blind for studies whose runs have their own humans (drift, populations)."""

import numpy as np
import pytest

from baselines.bounds import plan
from hri_bench.run.regret import blind_values
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios import scenario_graph


def test_drifting_deterministic_wheel_human_blind_waits_once_every_episode():
    # Wheel straight -> detour: either deterministic human reveals the goal with its first
    # action, so blind waits exactly once (r0 = -0.25) in every episode, before and after.
    cfg = StudyConfig("wheel", agents=("passive",), runs=3, episodes=5, human_drift=2)
    result = run_study(cfg)
    assert set(result.humans) == {"straight>detour"}
    np.testing.assert_allclose(blind_values(result), -0.25, atol=1e-12)


def test_drift_plans_each_episode_for_that_episodes_human():
    cfg = StudyConfig("wheel", agents=("passive",), runs=4, episodes=4, human_drift=2,
                      human_passive=0.2, seed=3)
    result = run_study(cfg)
    graph = scenario_graph("wheel")
    values = {p: plan(graph, preference_human(graph, p, passive=0.2), r0=-0.25,
                      informed=False).start_value() for p in ("straight", "detour")}
    starts = result.schedule["start"]
    expected = np.array([[values["straight" if e < 2 else "detour"][starts[r, e]]
                          for e in range(4)] for r in range(4)])
    np.testing.assert_allclose(blind_values(result), expected, atol=1e-12)
    # A passive human makes blind wait longer than one step on average.
    assert expected.mean() < -0.25


@pytest.mark.parametrize("kwargs", [
    {"population": "heldout"},  # draws β: Boltzmann
    {"population": "theta"},
    {"human_rationality": 4.0, "human_drift": 1},
])
def test_boltzmann_per_run_humans_are_refused(kwargs):
    cfg = StudyConfig("hanger", agents=("passive",), runs=2, episodes=2, **kwargs)
    with pytest.raises(ConfigError, match="Boltzmann"):
        blind_values(run_study(cfg))


def test_passive_and_turning_back_population_is_refused():
    cfg = StudyConfig("hanger", agents=("passive",), runs=2, episodes=2,
                      population="passive-turnback")
    with pytest.raises(ConfigError, match="both passive and turns back"):
        blind_values(run_study(cfg))
