"""The references on the product of task and human states (baselines/product.py): qmdp's
rows are stacked (one look-up for every row's own human), so a row's episodes must not
depend on the rows beside it; and its bracket order holds on a hand-made mixture.
"""

import numpy as np
import pytest

from hri_bench.run.study import StudyConfig, Unit, _run_unit


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_qmdp_rows_do_not_depend_on_the_rows_beside_them(scenario):
    # The test split's first block meets humans with 1 to 6 internal states side by side
    # (scripted, impatient, follower, trust, wary, fickle, moody).
    cfg = StudyConfig(scenario, agents=("qmdp", "informed"), runs=12, episodes=3,
                      population="test", seed=4)
    runs = tuple(range(12))
    unit = _run_unit(Unit(cfg, "qmdp", "default", runs))
    together, labels = unit[0]["reward"], unit[3]
    assert len(set(labels)) > 6
    for r in (0, 5, 11):
        alone = _run_unit(Unit(cfg, "qmdp", "default", (r,)))[0]["reward"]
        np.testing.assert_array_equal(alone[0], together[r])
    informed = _run_unit(Unit(cfg, "informed", "default", runs))[0]["reward"]
    # The upper end sees ι and z: per run, on the same humans and schedules, no lower.
    assert informed.sum() >= together.sum()
