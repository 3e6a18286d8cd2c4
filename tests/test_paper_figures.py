"""The paper figures read as plain as they can (issue 43 item 5): fig8's log axis in plain
numbers, what its line and band are said in the figure; figs. 11 and 12 in six colours."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from hri_bench.core.plots import new_figure, policy_lines  # noqa: E402
from hri_bench.report.figures import (  # noqa: E402
    ACTION_COLORS,
    GOAL_STYLES,
    action_kind,
    wheel_probes,
)
from hri_envs.task.scenarios import scenario_graph  # noqa: E402


@pytest.mark.parametrize("low,high", [(0.07, 4.0), (0.7, 3.3), (0.8, 7.0)])
def test_a_log_axis_of_ratios_reads_in_plain_numbers(low, high):
    fig, ax = new_figure()
    values = np.geomspace(low, high, 10)[None, :, None].repeat(3, axis=0)
    policy_lines(ax, values, ["s"], relative=True)
    FigureCanvasAgg(fig).draw()
    labels = [t.get_text() for t in ax.get_yticklabels() + ax.get_yticklabels(minor=True)
              if t.get_text() and low <= t.get_position()[1] <= high]
    assert len(labels) >= 2 and "1" in labels
    assert all(float(t) == float(f"{float(t):g}") for t in labels)  # "4", "0.3": no 4×10⁰


@pytest.mark.parametrize("preference", ["straight", "detour"])
def test_figs_11_and_12_tell_each_line_apart_with_six_colours(preference):
    probes = [p for p in wheel_probes(scenario_graph("wheel"), preference) if p.kind == "robot"]
    looks = [(ACTION_COLORS[action_kind(p.label)], GOAL_STYLES[p.intention][0])
             for p in probes]
    assert len(set(looks)) == len(probes)  # every line of a panel has a look of its own
    assert len({colour for colour, _ in looks}) <= 6
    assert {action_kind(p.label) for p in probes} <= set(ACTION_COLORS)
    assert action_kind("3 A′ horiz.: rotate") == "rotate"
    assert action_kind("2 A low horiz.: up") == "move up"
    assert action_kind("1 B′ horiz.: down to carry") == "move down"
