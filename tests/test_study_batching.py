"""--preference all: one batch of mixed preferences gives the numbers of one batch each."""

import numpy as np
import pytest

from hri_bench.run import study
from hri_bench.run.study import Probe, StudyConfig, run_study


def test_mixed_preference_batch_equals_one_batch_per_preference(monkeypatch):
    cfg = StudyConfig("hanger", agents=("learner", "oracle", "blind"), runs=4, episodes=2,
                      preference="all", human_passive=0.2)
    units = study.study_units(cfg)
    by_agent = {a: [u for u in units if u.agent == a] for a in cfg.agents}
    assert [u.runs for u in by_agent["learner"]] == [tuple(range(4))]
    assert [u.runs for u in by_agent["oracle"]] == [tuple(range(4))]
    assert len(by_agent["blind"]) == 4  # plans for one human: one unit per preference
    mixed = run_study(cfg)
    monkeypatch.setattr(study, "REFERENCE_AGENTS", ("learner", "oracle", "blind"))
    assert len(study.study_units(cfg)) == 12
    separate = run_study(cfg)
    assert mixed.humans == separate.humans == cfg.preference_of_run()
    for agent in cfg.agents:
        for key, value in mixed.metrics[agent].items():
            np.testing.assert_array_equal(value, separate.metrics[agent][key], err_msg=key)


@pytest.mark.parametrize("settings", [
    {"scenario": "hanger", "preference": "all", "human_passive": 0.2,
     "agents": ("learner", "maxent", "imitator", "oracle", "blind", "informed")},
    {"scenario": "wheel", "population": "heldout", "turn_back": 0.3,
     "agents": ("learner", "passive", "tests.helpers_agents:AlwaysWait")},
    {"scenario": "wheel", "human_drift": 2, "human_rationality": 4.0, "agents": ("learner",),
     "probes": (Probe("p", "human", 0, 0, 1),)},
])
def test_the_numbers_do_not_depend_on_how_the_runs_are_cut(settings, monkeypatch):
    # Units are chunks of runs, so that an interrupted study loses at most a chunk; every
    # draw of run r comes from (seed, r), so one run per unit or all in one are the same.
    cfg = StudyConfig(**settings, runs=5, episodes=3, seed=7)
    monkeypatch.setattr(study, "UNIT_EPISODES", 10**9)
    whole = run_study(cfg)
    monkeypatch.setattr(study, "UNIT_EPISODES", 1)
    assert all(len(u.runs) == 1 for u in study.study_units(cfg))
    split = run_study(cfg)
    assert whole.humans == split.humans
    for key, value in whole.schedule.items():
        np.testing.assert_array_equal(value, split.schedule[key], err_msg=key)
    for agent in cfg.agents:
        np.testing.assert_array_equal(whole.probes[agent], split.probes[agent])
        for key, value in whole.metrics[agent].items():
            np.testing.assert_array_equal(value, split.metrics[agent][key], err_msg=key)


def test_units_hold_at_most_unit_episodes():
    cfg = StudyConfig("wheel", agents=("learner", "passive"), runs=230, episodes=20)
    units = study.study_units(cfg)
    assert all(len(u.runs) * 20 <= study.UNIT_EPISODES for u in units)
    assert len(units) == 2 * 5  # 230 runs: 5 chunks of 46 per agent
    assert [r for u in units if u.agent == "learner" for r in u.runs] == list(range(230))
    # At least --jobs chunks; a run is never split.
    assert len(study.study_units(StudyConfig("wheel", agents=("passive",), runs=8, jobs=4))) == 4
    long = StudyConfig("wheel", agents=("passive",), runs=3, episodes=5000)
    assert [u.runs for u in study.study_units(long)] == [(0,), (1,), (2,)]
    # The MuJoCo backend simulates one run at a time: one run per unit.
    physics = StudyConfig("wheel", agents=("passive",), runs=3, episodes=2, backend="mujoco")
    assert [u.runs for u in study.study_units(physics)] == [(0,), (1,), (2,)]
