"""Paper-style plots of study results (matplotlib, no display needed).

Figures are :class:`matplotlib.figure.Figure` objects made without pyplot, so drawing and
writing a PNG needs neither a display nor a backend choice, and importing this module
changes no global matplotlib state. The house style :data:`STYLE` is in effect inside
:func:`style` (and in functions decorated with :func:`styled`): build and save a figure
there, e.g. with :func:`new_figure` and :func:`save_figure`.
"""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any, TypeVar, cast

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

from hri_bench.core import stats
from hri_bench.core.results import StudyResult, StudySettings

__all__ = ["COLORS", "LABELS", "STYLE", "STYLES", "agent_style", "band_legend",
           "decision_panels", "impulse_bands", "new_figure", "policy_lines", "reward_bands",
           "save_figure", "study_plots", "style", "styled"]

_F = TypeVar("_F", bound=Callable[..., Any])
#: A study result as the plots read it (any configuration with the :class:`StudySettings`).
Result = StudyResult[StudySettings]

#: Line styles as matplotlib dash patterns (offset, (on, off, ...)) in points.
SOLID: Any = "-"
TRAINED: Any = (0, (6, 2))          # policies trained by RL: long dashes
CUSTOM: Any = (0, (3, 1.5, 1, 1.5))  # an agent of the user's own (module:Class): dash-dot
#: Every agent's colour and line style, the same in every figure (study plots, the suite's
#: figures, ``profiles.png``, ``ranking.png``, the paper's figures, sample efficiency). The
#: agents that infer the intention take Okabe & Ito's colour-blind-safe colours (solid),
#: the RL policies four colours of Paul Tol's (long dashes); the references and the Oracle
#: are black or grey, each with a dash pattern of its own. Same-style colours stay apart
#: under simulated deuteranopia and protanopia (``tests/test_palette.py``).
STYLES: dict[str, tuple[str, Any]] = {
    "learner": ("#0072B2", SOLID), "goalfilter": ("#56B4E9", SOLID),
    "countqmdp": ("#D55E00", SOLID), "imitator": ("#009E73", SOLID),
    "maxent": ("#CC79A7", SOLID), "passive": ("#E69F00", SOLID),
    "jaxppo": ("#882255", TRAINED), "ppo": ("#332288", TRAINED), "dqn": ("#999933", TRAINED),
    "sb3": ("#44AA99", TRAINED),
    "informed": ("#000000", (0, (5, 2))), "oracle": ("#000000", (0, (1, 1.5))),
    "blind": ("#666666", (0, (5, 2, 1, 2))), "qmdp": ("#666666", (0, (5, 2, 1, 2, 1, 2))),
    "random": ("#999999", (0, (1, 3))),
}
#: The colours of agents of the user's own (:data:`CUSTOM` lines), one picked by name.
CUSTOM_COLORS = ("#0072B2", "#56B4E9", "#D55E00", "#009E73", "#CC79A7", "#E69F00")
#: Colour per agent (:data:`STYLES`), for callers that want the colour alone.
COLORS = {agent: color for agent, (color, _) in STYLES.items()}
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

    ``figsize`` and ``layout`` go to the figure, the other keywords (``sharex``, ...) to
    :meth:`~matplotlib.figure.Figure.subplots`.
    """
    figsize, layout = kwargs.pop("figsize", None), kwargs.pop("layout", None)
    with style():
        fig = Figure(figsize=figsize, layout=layout)
        return fig, fig.subplots(nrows, ncols, **kwargs)


def save_figure(fig: Figure, path: Path) -> Path:
    """Write ``fig`` to ``path`` in the house style (the format follows the suffix)."""
    with style():
        fig.savefig(path)
    return path


def _label(agent: str) -> str:
    return LABELS.get(agent, agent)


def agent_style(agent: str) -> tuple[str, Any]:
    """The colour and line style (a matplotlib ``linestyle``) of ``agent`` in every figure.

    Built-in agents and the references by :data:`STYLES`; ``sb3:PATH`` as ``sb3``,
    ``jaxppo:PATH`` as ``jaxppo``; any other name (``module:Class``) dash-dotted, in one of
    :data:`CUSTOM_COLORS` picked by a checksum of the name (the same in every figure and
    run).
    """
    if agent in STYLES:
        return STYLES[agent]
    prefix = agent.partition(":")[0]
    if prefix in ("sb3", "jaxppo") and ":" in agent:
        return STYLES[prefix]
    return CUSTOM_COLORS[zlib.crc32(agent.encode()) % len(CUSTOM_COLORS)], CUSTOM


def reward_bands(ax: Axes, result: Result, agents: Sequence[str] | None = None,
                 title: str | None = None, *, stalls: bool = False) -> None:
    """Mean (line), its 95 % CI (dark band) and the interquartile range (light band) of the
    cooperation reward per episode (Fig. 10).

    The CI is the mean's 95 % bootstrap interval over runs per episode
    (:func:`hri_bench.core.stats.per_episode`, seeded by the study seed): it says how well the
    runs pin the mean down, the interquartile range how much single runs vary. With
    ``stalls``, also the median (dotted) and, in each label, the share of the agent's
    episodes cut off at the step limit, so that a few stalled episodes dragging the mean down
    are visible.
    """
    episodes = np.arange(1, result.config.n_episodes + 1)
    for agent in agents or list(result.metrics):
        r = result.metrics[agent]["reward"]
        color, dashes = agent_style(agent)
        ax.fill_between(episodes, np.percentile(r, 25, 0), np.percentile(r, 75, 0),
                        color=color, alpha=0.14, linewidth=0)
        cis = stats.per_episode(r, getattr(result.config, "seed", 0), iqm_ci=False)["ci95"]
        low, high = np.array(cis, dtype=float).T  # None (a single run) -> NaN: no band
        ax.fill_between(episodes, low, high, color=color, alpha=0.38, linewidth=0)
        label = _label(agent)
        if stalls:
            label += f" ({result.metrics[agent]['truncated'].mean():.1%} truncated)"
            ax.plot(episodes, np.median(r, 0), ":", color=color, linewidth=1.4)
        ax.plot(episodes, r.mean(0), linestyle=dashes, color=color, label=label, linewidth=1.8)
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("robot cooperation reward per episode")
    ax.set_xlim(1, max(2, episodes[-1]))
    if title:
        ax.set_title(title)


def band_legend(ax: Axes) -> None:
    """Legend entries saying what the bands of :func:`reward_bands` are."""
    ax.fill_between([], [], [], color="0.45", alpha=0.38, linewidth=0,
                    label="95 % CI of the mean")
    ax.fill_between([], [], [], color="0.45", alpha=0.14, linewidth=0,
                    label="interquartile range")


def decision_panels(result: Result, agents: Sequence[str] | None = None,
                    title: str | None = None, *, columns: int = 4) -> Figure:
    """Correct / passive / wrong fractions of the robot's decisions per episode (Fig. 4):
    one panel per agent, named above it, in rows of at most ``columns`` panels, so that the
    agents are told apart by name, not by shade, and the figure stays readable however many
    agents and episodes there are.
    """
    agents = list(agents or result.metrics)
    n_e = result.config.n_episodes
    cols = min(columns, len(agents))
    rows = -(-len(agents) // cols)
    width = max(2.6, min(4.2, 0.22 * n_e + 1.0))
    fig, axes = new_figure(rows, cols, figsize=(width * cols, 2.6 * rows + 0.8), sharey=True,
                           squeeze=False, layout="constrained")
    x = np.arange(1, n_e + 1)
    for k, ax in enumerate(axes.ravel()):
        if k >= len(agents):
            ax.set_visible(False)
            continue
        m = result.metrics[agents[k]]
        bottom = np.zeros(n_e)
        for kind in ("correct", "passive", "wrong"):
            h = 100 * m[kind].mean(0)
            ax.bar(x, h, 0.85, bottom=bottom, color=DECISION_COLORS[kind], edgecolor="white",
                   linewidth=0.4, label=kind)
            bottom += h
        ax.set_title(_label(agents[k]))
        ax.set_xticks(x if n_e <= 12 else x[::max(1, n_e // 10)])
        ax.set_ylim(0, 100)
        if k % cols == 0:
            ax.set_ylabel("robot decisions [%]")
        if k // cols == rows - 1:
            ax.set_xlabel("episode")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, frameon=False, ncol=3, loc="outside lower center")
    if title:
        fig.suptitle(title)
    return fig


def policy_lines(ax: Axes, values: np.ndarray, labels: Sequence[str], *, relative: bool = False,
                 title: str | None = None, colors: Sequence[Any] | None = None,
                 styles: Sequence[Any] | None = None, ylabel: bool = True) -> None:
    """Median and interquartile band of probed policy entries over episodes (Figs. 8, 11, 12).

    Args:
        ax: Target axes.
        values: (runs, episodes + 1, P) probed probabilities (episode 0 = before learning).
        labels: One label per probe.
        relative: Values are ratios to waiting, drawn on a log axis with the 1.0 line and
            plain numbers on its ticks (0.3, 1, 4: not 3×10⁻¹).
        title: Axes title.
        colors: One colour per probe (default: a colour each).
        styles: One line style per probe (default: solid).
        ylabel: Label the y axis (False where the figure labels its rows once).
    """
    x = np.arange(values.shape[1])
    cmap = matplotlib.colormaps["tab10" if values.shape[2] <= 10 else "tab20"]
    for j, label in enumerate(labels):
        v = values[:, :, j]
        color = colors[j] if colors is not None else cmap(j % cmap.N)
        ax.fill_between(x, np.nanpercentile(v, 25, 0), np.nanpercentile(v, 75, 0), color=color,
                        alpha=0.12, linewidth=0)
        ax.plot(x, np.nanmedian(v, 0), color=color, label=label, linewidth=1.5,
                linestyle=styles[j] if styles is not None else "-")
    ax.set_xlabel("episodes learned")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if relative:
        ax.set_yscale("log")
        plain = FuncFormatter(lambda v, _: f"{v:g}")
        ax.yaxis.set_major_formatter(plain)
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0)))
        ax.axhline(1.0, color="k", linestyle="-.", linewidth=0.8)
        if ylabel:
            ax.set_ylabel("p(preferred action) / p(wait)")
    else:
        ax.set_ylim(-0.02, 1.02)
        if ylabel:
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
    reward_bands(ax, result, title=title, stalls=True)
    ax.plot([], [], ":", color="0.4", label="median")
    band_legend(ax)
    ax.legend(frameon=False, fontsize=8, title="line: mean", title_fontsize=7)
    paths = [save_figure(fig, out / "reward.png")]
    paths.append(save_figure(decision_panels(result, title=title), out / "decisions.png"))
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
        color, dashes = agent_style(agent)
        ax.fill_between(episodes, np.percentile(v, 25, 0), np.percentile(v, 75, 0),
                        color=color, alpha=0.18, linewidth=0)
        ax.plot(episodes, v.mean(0), linestyle=dashes, color=color, label=_label(agent),
                linewidth=1.8)
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("linear impulse of the human [N s]")
    if title:
        ax.set_title(title)
