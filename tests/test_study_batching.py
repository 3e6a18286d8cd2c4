"""--preference all: one batch of mixed preferences gives the numbers of one batch each."""

import numpy as np

from hri_bench import study
from hri_bench.study import StudyConfig, run_study


def test_mixed_preference_batch_equals_one_batch_per_preference(monkeypatch):
    cfg = StudyConfig("hanger", agents=("learner", "oracle", "blind"), runs=4, episodes=2,
                      preference="all", human_passive=0.2)
    units = study._units(cfg)
    by_agent = {a: [u for u in units if u.agent == a] for a in cfg.agents}
    assert [u.runs for u in by_agent["learner"]] == [tuple(range(4))]
    assert [u.runs for u in by_agent["oracle"]] == [tuple(range(4))]
    assert len(by_agent["blind"]) == 4  # plans for one human: one unit per preference
    mixed = run_study(cfg)
    monkeypatch.setattr(study, "REFERENCE_AGENTS", ("learner", "oracle", "blind"))
    assert len(study._units(cfg)) == 12
    separate = run_study(cfg)
    assert mixed.humans == separate.humans == cfg.preference_of_run()
    for agent in cfg.agents:
        for key, value in mixed.metrics[agent].items():
            np.testing.assert_array_equal(value, separate.metrics[agent][key], err_msg=key)
