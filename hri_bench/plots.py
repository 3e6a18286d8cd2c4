"""Paper-style plots of study results (matplotlib, no display needed).

Figures are :class:`matplotlib.figure.Figure` objects made without pyplot, so drawing and
writing a PNG needs neither a display nor a backend choice, and importing this module
changes no global matplotlib state. The house style :data:`STYLE` is in effect inside
:func:`style` (and in functions decorated with :func:`styled`): build and save a figure
there, e.g. with :func:`new_figure` and :func:`save_figure`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any, TypeVar, cast

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from hri_bench.results import StudyResult, StudySettings

__all__ = ["STYLE", "decision_bars", "impulse_bands", "new_figure", "policy_lines",
           "reward_bands", "save_figure", "study_plots", "style", "styled"]

_F = TypeVar("_F", bound=Callable[..., Any])
#: A study result as the plots read it (any configuration with the :class:`StudySettings`).
Result = StudyResult[StudySettings]

COLORS = {"learner": "#1f5fa8", "imitator": "#7fb2e5", "maxent": "#7a7a7a",
          "passive": "#e0a030", "oracle": "#2a9d55"}
LABELS = {"learner": "Learner", "imitator": "Imitator", "maxent": "plain ME-IRL",
          "passive": "Passive", "oracle": "Oracle"}
DECISION_COLORS = {"correct": "#1f5fa8", "passive": "#bcd3ea", "wrong": "#c8102e"}

#: rcParams of the house style (see :func:`style`).
STYLE: dict[str, Any] = {"font.size": 10, "axes.spines.top": False,
                         "axes.spines.right": False, "figure.dpi": 110, "savefig.bbox": "tight"}


def style() -> AbstractContextManager[Any]:
    """A context in which matplotlib uses :data:`STYLE`; build and save figures inside it."""
    return matplotlib.rc_context(cast(Any, STYLE))  # the stubs want literal rc keys


def styled(func: _F) -> _F:
    """Decorate a function that draws figures so that it runs inside :func:`style`."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with style():
            return func(*args, **kwargs)

    return cast(_F, wrapper)


def new_figure(nrows: int = 1, ncols: int = 1, **kwargs: Any) -> tuple[Figure, Any]:
    """A figure in the house style and its axes, like ``pyplot.subplots`` but without pyplot.

    ``figsize`` goes to the figure, the other keywords (``sharex``, ...) to
    :meth:`~matplotlib.figure.Figure.subplots`.
    """
    figsize = kwargs.pop("figsize", None)
    with style():
        fig = Figure(figsize=figsize)
        return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig: Figure, path: Path) -> Path:
    """Write ``fig`` to ``path`` in the house style (the format follows the suffix)."""
    with style():
        fig.savefig(path)
    return path


def _label(agent: str) -> str:
    return LABELS.get(agent, agent)


def reward_bands(ax: Axes, result: Result, agents: Sequence[str] | None = None,
                 title: str | None = None, *, ci: bool = False, stalls: bool = False) -> None:
    """Mean (line) and interquartile band of the cooperation reward per episode (Fig. 10).

    With ``ci``, error bars show the mean's 95 % bootstrap confidence interval per episode
    (:func:`hri_bench.stats.per_episode`, seeded by the study seed). With ``stalls``,
    also the median (dotted) and, in each label, the share of the agent's episodes cut off
    at the step limit, so that a few stalled episodes dragging the mean down are visible.
    """
    from hri_bench import stats

    episodes = np.arange(1, result.config.n_episodes + 1)
    for agent in agents or list(result.metrics):
        r = result.metrics[agent]["reward"]
        color = COLORS.get(agent)
        style = "--" if agent == "oracle" else "-"
        ax.fill_between(episodes, np.percentile(r, 25, 0), np.percentile(r, 75, 0),
                        color=color, alpha=0.18, linewidth=0)
        label = _label(agent)
        if stalls:
            label += f" ({result.metrics[agent]['truncated'].mean():.1%} truncated)"
            ax.plot(episodes, np.median(r, 0), ":", color=color, linewidth=1.4)
        ax.plot(episodes, r.mean(0), style, color=color, label=label, linewidth=1.8)
        if ci:
            cis = stats.per_episode(r, getattr(result.config, "seed", 0), iqm_ci=False)["ci95"]
            low, high = np.array(cis, dtype=float).T  # None (a single run) -> NaN: no bar
            mean = r.mean(0)
            # A percentile interval can miss the sample mean by rounding when the runs agree.
            yerr = np.nan_to_num(np.clip(np.stack([mean - low, high - mean]), 0.0, None))
            ax.errorbar(episodes, mean, yerr=yerr, fmt="none",
                        ecolor=color, elinewidth=1.0, capsize=2)
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("robot cooperation reward per episode")
    ax.set_xlim(1, max(2, episodes[-1]))
    if title:
        ax.set_title(title)


def decision_bars(ax: Axes, result: Result, agents: Sequence[str] | None = None,
                  title: str | None = None) -> None:
    """Correct / passive / wrong fractions of the robot's decisions per episode (Fig. 4)."""
    agents = list(agents or result.metrics)
    n_e = result.config.n_episodes
    width = 0.8 / len(agents)
    # Later agents' bars are paler: 0.25 less opaque each, spread wider for many agents.
    fade = min(0.25, 0.75 / max(1, len(agents) - 1))
    for j, agent in enumerate(agents):
        m = result.metrics[agent]
        x = np.arange(1, n_e + 1) - 0.4 + width * (j + 0.5)
        bottom = np.zeros(n_e)
        for kind in ("correct", "passive", "wrong"):
            h = 100 * m[kind].mean(0)
            ax.bar(x, h, width * 0.92, bottom=bottom, color=DECISION_COLORS[kind],
                   edgecolor="white", linewidth=0.4, alpha=1.0 - fade * j,
                   label=f"{_label(agent)}: {kind}")
            bottom += h
    ax.set_xticks(np.arange(1, n_e + 1))
    ax.set_xlabel("episode")
    ax.set_ylabel("robot decisions [%]")
    ax.set_ylim(0, 100)
    if title:
        ax.set_title(title)


def policy_lines(ax: Axes, values: np.ndarray, labels: Sequence[str], *, relative: bool = False,
                 title: str | None = None) -> None:
    """Median and interquartile band of probed policy entries over episodes (Figs. 8, 11, 12).

    Args:
        ax: Target axes.
        values: (runs, episodes + 1, P) probed probabilities (episode 0 = before learning).
        labels: One label per probe.
        relative: Values are ratios to waiting, drawn on a log axis with the 1.0 line.
        title: Axes title.
    """
    x = np.arange(values.shape[1])
    cmap = matplotlib.colormaps["tab10" if values.shape[2] <= 10 else "tab20"]
    for j, label in enumerate(labels):
        v = values[:, :, j]
        color = cmap(j % cmap.N)
        ax.fill_between(x, np.nanpercentile(v, 25, 0), np.nanpercentile(v, 75, 0), color=color,
                        alpha=0.15, linewidth=0)
        ax.plot(x, np.nanmedian(v, 0), color=color, label=label, linewidth=1.5)
    ax.set_xlabel("episodes learned")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if relative:
        ax.set_yscale("log")
        ax.axhline(1.0, color="k", linestyle="-.", linewidth=0.8)
        ax.set_ylabel("p(preferred action) / p(wait)")
    else:
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("action probability")
    if title:
        ax.set_title(title)


@styled
def study_plots(result: Result, out: Path) -> list[Path]:
    """``reward.png`` (Fig. 10 style) and ``decisions.png`` (Fig. 4 style) for a study."""
    cfg = result.config
    title = (f"{cfg.scenario}, {cfg.schedule} schedule, r0 = {cfg.waiting_reward:g}, "
             f"human passive {cfg.human_passive:.0%}, {cfg.runs} runs")
    fig, ax = new_figure(figsize=(6.4, 4.0))
    reward_bands(ax, result, title=title, ci=True, stalls=True)
    ax.plot([], [], ":", color="0.4", label="median")
    ax.legend(frameon=False, fontsize=8, title="line: mean, bars: 95% CI, band: IQR",
              title_fontsize=7)
    paths = [save_figure(fig, out / "reward.png")]
    fig, ax = new_figure(figsize=(max(6.4, 0.55 * cfg.n_episodes * len(result.metrics)), 4.0))
    decision_bars(ax, result, title=title)
    ax.legend(frameon=False, fontsize=7, ncol=len(result.metrics), loc="upper center",
              bbox_to_anchor=(0.5, -0.15))
    paths.append(save_figure(fig, out / "decisions.png"))
    if "linear_impulse" in next(iter(result.metrics.values())):
        fig, ax = new_figure(figsize=(6.4, 4.0))
        impulse_bands(ax, result, title=title)
        ax.legend(frameon=False, fontsize=8)
        paths.append(save_figure(fig, out / "impulse.png"))
    return paths


def impulse_bands(ax: Axes, result: Result, title: str | None = None) -> None:
    """Mean and interquartile band of the linear interaction impulse per episode (Fig. 6)."""
    episodes = np.arange(1, result.config.n_episodes + 1)
    for agent, m in result.metrics.items():
        v = m["linear_impulse"]
        color = COLORS.get(agent)
        ax.fill_between(episodes, np.percentile(v, 25, 0), np.percentile(v, 75, 0),
                        color=color, alpha=0.18, linewidth=0)
        ax.plot(episodes, v.mean(0), color=color, label=_label(agent), linewidth=1.8)
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("linear impulse of the human [N s]")
    if title:
        ax.set_title(title)
