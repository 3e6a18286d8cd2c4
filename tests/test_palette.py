"""One palette (issue 34): every agent keeps one colour and line style in every figure, the
references are grey or black with dash patterns of their own, and agents drawn alike stay
apart for a colour-blind reader; the performance profiles span the scores that occur.

Before, the Learner and the goal filter shared dark blue (the goal filter had no colour and
took matplotlib's first), the Oracle and ``blind`` the same green dash, ``passive`` and
``informed`` the same orange, and ``profiles.png`` spanned -45 to 0 with every curve at its
right edge.
"""

import itertools
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.colors import to_hex, to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from hri_bench.core import plots
from hri_bench.run.agents import AGENTS

ROOT = Path(__file__).resolve().parents[1]
#: Every name a figure draws: the registry, the JAX and SB3 policies, sample efficiency's.
NAMES = (*AGENTS, "jaxppo", "sb3", "ppo", "dqn", "random")
#: Drawn as references: grey or black, each with a dash pattern of its own.
REFERENCES = (*(a for a, s in AGENTS.items() if s.role == "reference"), "oracle", "random")

# Machado, Oliveira & Fernandes (2009), severity 1, on linear RGB.
CVD = {
    "deuteranopia": np.array([[0.367322, 0.860646, -0.227968], [0.280085, 0.672501, 0.047413],
                              [-0.011820, 0.042940, 0.968881]]),
    "protanopia": np.array([[0.152286, 1.052583, -0.204868], [0.114503, 0.786281, 0.099216],
                            [-0.003882, -0.048116, 1.051998]]),
}
SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
#: CIE76 colour difference two same-style lines keep under every view (≈ 2.3 is "just
#: noticeable"; 15 tells thin lines apart at a glance).
MIN_DELTA_E = 15.0


def _lab(color, vision=None):
    """CIELAB of a matplotlib colour as a viewer with ``vision`` (None: typical) sees it."""
    c = np.asarray(to_rgb(color))
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    if vision is not None:
        linear = np.clip(CVD[vision] @ linear, 0.0, 1.0)
    xyz = SRGB_TO_XYZ @ linear / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _distance(a, b, vision):
    return float(np.linalg.norm(_lab(a, vision) - _lab(b, vision)))


def _dashes(linestyle):
    """A linestyle as the dash pattern matplotlib draws (a line of width 1)."""
    return Line2D([], [], linestyle=linestyle, linewidth=1.0)._unscaled_dash_pattern


def test_every_agent_has_a_style_of_its_own():
    styles = {name: plots.agent_style(name) for name in NAMES}
    assert set(NAMES) <= set(plots.STYLES)  # none falls back to a name-picked colour
    seen = {(to_hex(c), _dashes(d)) for c, d in styles.values()}
    assert len(seen) == len(NAMES)  # no two agents drawn alike
    for name, (color, _) in styles.items():
        r, g, b = to_rgb(color)
        grey = r == g == b
        assert grey == (name in REFERENCES), name  # references grey or black, others not
    patterns = [_dashes(styles[name][1]) for name in REFERENCES]
    assert len(set(patterns)) == len(patterns)  # a dash pattern per reference
    assert all(p[1] for p in patterns)  # dashed, never solid
    # sb3:PATH and jaxppo:PATH as their kind; module:Class dash-dotted, always alike
    assert plots.agent_style("sb3:out/ppo.zip") == plots.agent_style("sb3")
    assert plots.agent_style("jaxppo:out/jaxppo") == plots.agent_style("jaxppo")
    mine = plots.agent_style("mylab.agent:Mine")
    assert mine == plots.agent_style("mylab.agent:Mine") and mine[1] == plots.CUSTOM


@pytest.mark.parametrize("vision", [None, "deuteranopia", "protanopia"])
def test_agents_drawn_alike_stay_apart_for_colour_blind_readers(vision):
    """Same line style: colours at least MIN_DELTA_E apart (CIE76) as a viewer with
    typical vision, deuteranopia or protanopia sees them; every line stands out from the
    white page; the colours of agents of the user's own too."""
    by_style = {}
    for name in NAMES:
        color, dashes = plots.agent_style(name)
        by_style.setdefault(_dashes(dashes), []).append((name, color))
    by_style["custom"] = [(c, c) for c in plots.CUSTOM_COLORS]
    for group in by_style.values():
        for (a, ca), (b, cb) in itertools.combinations(group, 2):
            assert _distance(ca, cb, vision) >= MIN_DELTA_E, (vision, a, b)
    for name in NAMES:
        assert _distance(plots.agent_style(name)[0], "white", vision) >= 30, (vision, name)


def _captured(monkeypatch):
    figures = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: figures.append(fig) or path)
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: figures.append(fig))
    return figures


def _check_lines(fig, names, labels=None):
    """Each agent's line in ``fig`` (found by its legend label) has the agent's style."""
    labels = labels or {n: plots.LABELS.get(n, n) for n in names}
    lines = {line.get_label(): line for ax in fig.axes for line in ax.get_lines()}
    for name in names:
        line = lines[labels[name]]
        color, dashes = plots.agent_style(name)
        assert to_hex(line.get_color()) == to_hex(color), name
        assert line._unscaled_dash_pattern == _dashes(dashes), name


def test_the_study_and_suite_figures_draw_each_agent_in_its_style(monkeypatch, tmp_path):
    from hri_bench.suite import results_v3
    from hri_bench.suite.running import track_figure
    from hri_bench.suite.submission import profile_figure

    figures = _captured(monkeypatch)
    names = ["learner", "goalfilter", "countqmdp", "imitator", "maxent", "passive", "oracle",
             "informed", "blind", "qmdp", "jaxppo", "tests.helpers_agents:AlwaysWait"]
    rng = np.random.default_rng(0)
    runs = {n: -rng.random((4, 5)) for n in names}
    result = SimpleNamespace(config=SimpleNamespace(n_episodes=5, seed=0),
                             metrics={n: {"reward": r, "truncated": np.zeros((4, 5)),
                                          "linear_impulse": -r} for n, r in runs.items()})
    with plots.style():
        fig, ax = plots.new_figure()
        plots.reward_bands(ax, result, names)
        _check_lines(fig, names)
        fig, ax = plots.new_figure()
        plots.impulse_bands(ax, result)
        _check_lines(fig, names)
    per_episode = {"mean": [0.1] * 5, "ci95": [[0.0, 0.2]] * 5}
    track_figure("t", {"regret_reported": True, "description": "d",
                       "agents": {n: {"regret": {"per_episode": per_episode}} for n in names}},
                 tmp_path / "t.png")
    # errorbar's data line is the container's first line; its label is the container's
    fig = figures[-1]
    containers = fig.axes[0].containers
    assert sorted(c.get_label() for c in containers) == sorted(
        plots.LABELS.get(n, n) for n in names)  # one errorbar per agent, none drawn otherwise
    for container in containers:
        line = container.lines[0]
        name = next(n for n in names if plots.LABELS.get(n, n) == container.get_label())
        color, dashes = plots.agent_style(name)
        assert to_hex(line.get_color()) == to_hex(color)
        assert line._unscaled_dash_pattern == _dashes(dashes)
    tau = list(np.linspace(-45, 0, 201))
    profile_figure({"aggregate": {"profiles": {"tau": tau, "fraction_above": {
        n: list(1 / (1 + np.exp(4 * (np.array(tau) + 1)))) for n in names}}}},
        tmp_path / "p.png")
    _check_lines(figures[-1], names)
    head = {"order": names, "tracks": ["a"], "agents": {
        n: {"mean": 0.5, "ci95": [0.4, 0.6], "per_track": {"a": {"mean": 0.5}}} for n in names}}
    results_v3.ranking_figure({"aggregate": {"headline": head}}, tmp_path / "r.png")
    colours = [to_hex(c.lines[0].get_color()) for c in figures[-1].axes[0].containers]
    assert colours == [to_hex(plots.agent_style(n)[0]) for n in names[::-1]]


def test_sample_efficiency_draws_each_agent_in_its_style(monkeypatch, tmp_path):
    from hri_bench.report.sample_efficiency import (
        SampleEfficiencyConfig,
        SampleEfficiencyResult,
        plot,
    )

    figures = _captured(monkeypatch)
    doc = json.loads((ROOT / "docs/figures/sample_efficiency.json").read_text())
    cfg = SampleEfficiencyConfig(**{k: tuple(v) if isinstance(v, list) else v
                                    for k, v in doc["config"].items()})
    learner = {k: np.asarray(v) for k, v in doc["learner"].items()}
    result = SampleEfficiencyResult(
        cfg, learner["episodes"], learner["reward"], learner["q25"], learner["q75"],
        {a: np.asarray(r["episodes"]) for a, r in doc["rl"].items()},
        {a: np.asarray(r["reward"]) for a, r in doc["rl"].items()},
        {a: np.asarray(r["steps"]) for a, r in doc["rl"].items()}, doc["references"])
    plot(result, tmp_path / "s.png")
    lines = figures[-1].axes[0].get_lines()
    for name in ("learner", "ppo", "dqn", "oracle", "passive", "random"):
        color, dashes = plots.agent_style(name)
        assert any(to_hex(line.get_color()) == to_hex(color)
                   and line._unscaled_dash_pattern == _dashes(dashes) for line in lines), name


def test_the_profiles_span_the_scores_that_occur(monkeypatch, tmp_path):
    """A few runs at -45 stretched the axis over -45 .. 0 with every curve at its right
    edge: it spans where the fractions lie in 5-95 %, and says how far the scores reach."""
    from hri_bench.suite.submission import profile_figure, profile_span

    figures = _captured(monkeypatch)
    tau = np.linspace(-45, 0, 201)
    fractions = {"learner": 1 / (1 + np.exp(8 * (tau + 0.6))),
                 "passive": 1 / (1 + np.exp(8 * (tau + 1.5)))}
    fractions["learner"][0] = 0.998  # one run in 500 at the floor
    prof = {"tau": tau.tolist(), "fraction_above": {k: v.tolist() for k, v in fractions.items()}}
    profile_figure({"aggregate": {"profiles": prof}}, tmp_path / "p.png")
    low, high = figures[-1].axes[0].get_xlim()
    assert (low, high) == profile_span(prof)
    # logistic curves of slope 8 at -1.5 and -0.6: 95 % at -1.87, 5 % at -0.23 (± a grid step)
    assert -2.2 < low < -1.8 and -0.4 < high < -0.1
    label = figures[-1].axes[0].get_xlabel()
    assert "-45" in label and "5%–95%" in label
    assert profile_span({"tau": [], "fraction_above": {}}) is None

