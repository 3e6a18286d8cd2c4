"""The study statistics: IQM, bootstrap CIs, probability of improvement."""

from __future__ import annotations

import numpy as np
import pytest

from hri_bench.core import stats
from hri_bench.run.study import StudyConfig, run_study, summarize
from hri_envs.errors import ConfigError


def test_iqm_hand_computed() -> None:
    # 8 values sorted -50, 1, 2, 3, 4, 5, 6, 100: the middle 50 % are 2, 3, 4, 5.
    assert stats.iqm(np.array([100.0, 1, 2, 3, 4, 5, 6, -50])) == pytest.approx(3.5)


def test_ci_contains_the_mean_and_shrinks_with_more_runs() -> None:
    rng = np.random.default_rng(0)
    widths = []
    for n in (10, 40, 160):
        x = rng.normal(-1.0, 0.5, (n, 3))
        agg = stats.aggregate(x, seed=1)
        low, high = agg["ci95"]
        assert low <= agg["mean"] <= high
        lo_i, hi_i = agg["iqm_ci95"]
        assert lo_i <= agg["iqm"] <= hi_i
        for e, (lo, hi) in enumerate(stats.per_episode(x, seed=1)["ci95"]):
            assert lo <= x[:, e].mean() <= hi
        widths.append(high - low)
    assert widths[0] > widths[1] > widths[2]


def test_ci_is_reproducible_and_degenerate_when_constant() -> None:
    x = np.random.default_rng(3).normal(size=(20, 2))
    assert stats.per_episode(x, 7) == stats.per_episode(x, 7)
    assert stats.bootstrap_ci(np.zeros(5), "mean", 0) == (0.0, 0.0)
    with pytest.raises(ConfigError, match="'mean' or 'iqm'"):
        stats.bootstrap_ci(np.ones(3), "median", 0)


def test_probability_of_improvement_hand_computed() -> None:
    x = np.array([[1.0], [2.0], [3.0]])
    y = np.array([[2.0], [0.0]])
    # pairs x>y: (1,0), (2,0), (3,2), (3,0) = 4; ties (2,2) = 0.5; out of 6.
    assert stats.probability_of_improvement(x, y) == pytest.approx(4.5 / 6)
    assert stats.probability_of_improvement(y, x) == pytest.approx(1.5 / 6)
    table = stats.improvement_table({"a": x, "b": y})
    assert table["a"]["b"] + table["b"]["a"] == pytest.approx(1.0)


def test_improvement_pair_equals_both_directions_to_the_bit() -> None:
    # Seed 6: ties, and 1 - P(X > Y) differs from P(Y > X) in the last bit.
    rng = np.random.default_rng(6)
    x, y = rng.integers(0, 4, (7, 5)).astype(float), rng.integers(0, 4, (5, 5)).astype(float)
    assert stats.improvement_pair(x, y) == (stats.probability_of_improvement(x, y),
                                            stats.probability_of_improvement(y, x))


def test_summary_reports_iqm_and_cis() -> None:
    res = run_study(StudyConfig("hanger", agents=("learner", "passive"), runs=8, episodes=3))
    s = summarize(res)
    reward = s["agents"]["learner"]["reward"]
    assert len(reward["iqm"]) == len(reward["ci95"]) == 3
    for mean, (lo, hi) in zip(reward["mean"], reward["ci95"], strict=True):
        assert lo <= mean <= hi
    assert s["probability_of_improvement"]["table"]["learner"]["passive"] > 0.5
    assert summarize(res) == s  # the bootstrap is seeded by the study seed
