"""The paper's figures, each from one study (``hri-bench figures --out DIR`` draws them all).

========  =====================================================================  ==========
figure    what                                                                   command
========  =====================================================================  ==========
fig10a    wheel, r0 = -0.25, straight and detour: reward of all agents           ``--only fig10a``
fig10b    wheel, r0 = -0.50, straight and detour                                 ``--only fig10b``
fig10c    wheel, r0 = -0.25, human passive 20% of the steps                      ``--only fig10c``
fig11     Learner's π̂_H and π_R of the listed state-action pairs (straight)       ``--only fig11``
fig12     the same for the detour preference                                     ``--only fig12``
fig8      hanger critical states: p(preferred) / p(wait), 100 random simulations ``--only fig8``
fig4      hanger Table 2 schedule: correct / passive / wrong per episode          ``--only fig4``
========  =====================================================================  ==========

Figures 11 and 12 come from the Learner runs of the Fig. 10 studies (probes recorded after
each episode), so asking for them costs nothing extra.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.typing import LineStyleType

from hri_bench.core.plots import (
    band_legend,
    decision_panels,
    new_figure,
    policy_lines,
    reward_bands,
    save_figure,
    styled,
)
from hri_bench.run.study import Probe, StudyConfig, StudyResult, graph_for, run_study
from hri_envs.errors import ConfigError
from hri_envs.task.graph import PUT_ON, ROTATE, TOGGLE, TaskGraph

__all__ = ["FIGURES", "action_kind", "fig8_probes", "make_figures", "wheel_probes"]

FIGURES = ("fig10a", "fig10b", "fig10c", "fig11", "fig12", "fig8", "fig4")
WHEEL_SETTINGS = {"fig10a": (-0.25, 0.0), "fig10b": (-0.5, 0.0), "fig10c": (-0.25, 0.2)}
#: Figs. 11 and 12: a colour per kind of action probed (colour-blind safe, Okabe-Ito) and a
#: line style per goal, rather than ten colours in a panel.
ACTION_COLORS = {"move over": "#0072B2", "move up": "#E69F00", "move down": "#56B4E9",
                 "rotate": "#009E73", "put on": "#CC79A7", "let go": "#D55E00"}
GOAL_STYLES: dict[int, tuple[LineStyleType, str]] = {0: ("-", "towards the rack (A)"),
                                                      1: ("--", "towards a stand (B)")}


def action_kind(label: str) -> str:
    """The kind of action (a key of :data:`ACTION_COLORS`) of a Fig. 11/12 probe's label."""
    what = label.split(": ", 1)[1]
    return next(kind for kind in ACTION_COLORS if what.startswith(kind.removeprefix("move ")))


def _median_band_handles() -> list[Any]:
    """Legend entries that say what a line and a band are."""
    return [Line2D([], [], color="0.3", linewidth=1.5, label="line: median of the runs"),
            Patch(color="0.3", alpha=0.15, linewidth=0, label="band: interquartile range")]


def wheel_probes(graph: TaskGraph, preference: str) -> tuple[Probe, ...]:
    """The state-action pairs listed under Figs. 11 (straight) and 12 (detour).

    Stand B stands for "a stand (B or C)"; h indexes 0.95 (carrying), 1.1 (B′), 1.3 (C′),
    1.7 m (A′); o is 0 horizontal, 1 vertical.
    """
    w, a_rack, b = graph.waypoint_state, 0, 1
    carry, hb, top = 0, 1, 3
    hor, ver = 0, 1
    on = graph.support_state
    if preference == "straight":
        pairs = [
            ("1 B′ horiz.: over to A", w(1, hb, hor), a_rack, graph.move_over(0)),
            ("2 A low horiz.: up", w(0, hb, hor), a_rack, graph.move_to_height(top)),
            ("3 A′ horiz.: rotate", w(0, top, hor), a_rack, ROTATE),
            ("4 A′ vert.: put on", w(0, top, ver), a_rack, PUT_ON),
            ("5 on A: let go", on(0, 3), a_rack, TOGGLE),
            ("6 A′ vert.: over to B", w(0, top, ver), b, graph.move_over(1)),
            ("7 B high vert.: down", w(1, top, ver), b, graph.move_to_height(hb)),
            ("8 B′ vert.: rotate", w(1, hb, ver), b, ROTATE),
            ("9 B′ horiz.: put on", w(1, hb, hor), b, PUT_ON),
            ("10 on B: let go", on(1, 3), b, TOGGLE),
        ]
    else:
        pairs = [
            ("1 B′ horiz.: down to carry", w(1, hb, hor), a_rack, graph.move_to_height(carry)),
            ("2 B low horiz.: over to A", w(1, carry, hor), a_rack, graph.move_over(0)),
            ("3 A low horiz.: up", w(0, carry, hor), a_rack, graph.move_to_height(top)),
            ("4 A′ horiz.: rotate", w(0, top, hor), a_rack, ROTATE),
            ("5 A′ vert.: put on", w(0, top, ver), a_rack, PUT_ON),
            ("6 on A: let go", on(0, 3), a_rack, TOGGLE),
            ("7 A′ vert.: rotate", w(0, top, ver), b, ROTATE),
            ("8 A high horiz.: down", w(0, top, hor), b, graph.move_to_height(carry)),
            ("9 A low horiz.: over to B", w(0, carry, hor), b, graph.move_over(1)),
            ("10 B low horiz.: up", w(1, carry, hor), b, graph.move_to_height(hb)),
            ("11 B′ horiz.: put on", w(1, hb, hor), b, PUT_ON),
            ("12 on B: let go", on(1, 3), b, TOGGLE),
        ]
    return tuple(Probe(label, kind, s, i, a) for kind in ("human", "robot")
                 for label, s, i, a in pairs)


def fig8_probes(graph: TaskGraph) -> tuple[Probe, ...]:
    """The four critical states of Fig. 8 (most frequent hanger preference), relative to
    waiting: s10 (B′, to A: move down), s4 (B low, to A: over to A), s1 (A′, to B: over to B),
    s3 (B low peg-facing, to B: rotate).
    """
    w = graph.waypoint_state
    return (
        Probe("s10: B′ → move down (to A)", "robot", w(1, 1, 1), 0, graph.move_to_height(0), True),
        Probe("s4: B low → move over to A", "robot", w(1, 0, 1), 0, graph.move_over(0), True),
        Probe("s1: A′ → move over to B", "robot", w(0, 0, 0), 1, graph.move_over(1), True),
        Probe("s3: B low → rotate (to B)", "robot", w(1, 0, 0), 1, ROTATE, True),
    )


def _wheel_study(base: StudyConfig, fig: str, preference: str) -> StudyConfig:
    r0, passive = WHEEL_SETTINGS[fig]
    graph = graph_for("wheel")
    return replace(base, scenario="wheel", r0=r0, human_passive=passive, preference=preference,
                   schedule="random", episodes=base.episodes or 20,
                   probes=wheel_probes(graph, preference))


@styled
def make_figures(
    out: str | Path,
    *,
    runs: int = 100,
    jobs: int = 1,
    executor: str = "serial",
    seed: int = 0,
    only: tuple[str, ...] = FIGURES,
    wheel_episodes: int = 20,
    progress: bool = False,
    log: Callable[[str], None] = print,
) -> list[Path]:
    """Run the studies behind the requested figures and draw them as PNGs into ``out``."""
    unknown = set(only) - set(FIGURES)
    if unknown:
        raise ConfigError(f"unknown figure(s) {sorted(unknown)}; allowed: {', '.join(FIGURES)}",
                          field="only")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    base = StudyConfig("wheel", runs=runs, jobs=jobs, executor=executor, seed=seed,
                       episodes=wheel_episodes)
    paths: list[Path] = []
    wheel_results: dict[tuple[str, str], StudyResult] = {}
    needed = {f for f in only if f.startswith("fig10")}
    if {"fig11", "fig12"} & set(only):
        needed |= set(WHEEL_SETTINGS)
    for fig in sorted(needed):
        for pref in ("straight", "detour"):
            cfg = _wheel_study(base, fig, pref)
            wheel_results[fig, pref] = run_study(cfg, progress=progress)
            log(f"{fig} {pref}: {wheel_results[fig, pref].wall_time_s:.1f} s")
    for fig in sorted(set(only) & set(WHEEL_SETTINGS)):
        r0, passive = WHEEL_SETTINGS[fig]
        f, axes = new_figure(1, 2, figsize=(11, 4), sharey=True)
        for ax, pref in zip(axes, ("straight", "detour"), strict=True):
            reward_bands(ax, wheel_results[fig, pref], title=f"preference: {pref}")
        band_legend(axes[0])
        axes[0].legend(frameon=False, fontsize=8, title="line: mean", title_fontsize=7)
        f.suptitle(f"Wheel, r0 = {r0:g}, human passive {passive:.0%} ({runs} runs each)")
        paths.append(save_figure(f, out / f"{fig}.png"))
    for fig, pref in (("fig11", "straight"), ("fig12", "detour")):
        if fig not in only:
            continue
        f, axes = new_figure(3, 3, figsize=(15, 10.5), sharex=True, sharey=True,
                             layout="constrained")
        rows = (("learner", "human", "Learner's π̂_H"), ("learner", "robot", "Learner's π_R"),
                ("maxent", "robot", "plain ME-IRL's π"))
        for col, setting in enumerate(WHEEL_SETTINGS):
            res = wheel_results[setting, pref]
            probes = res.config.probes
            r0, passive = WHEEL_SETTINGS[setting]
            for row, (agent, kind, name) in enumerate(rows):
                idx = [j for j, p in enumerate(probes) if p.kind == kind]
                policy_lines(axes[row, col], res.probes[agent][:, :, idx],
                             [probes[j].label for j in idx],
                             colors=[ACTION_COLORS[action_kind(probes[j].label)] for j in idx],
                             styles=[GOAL_STYLES[probes[j].intention][0] for j in idx],
                             title=f"{name}: r0 = {r0:g}, passive {passive:.0%}",
                             ylabel=col == 0)
        handles = [Line2D([], [], color=c, linewidth=2, label=k) for k, c in
                   ACTION_COLORS.items()]
        handles += [Line2D([], [], color="0.2", linestyle=ls, label=goal)
                    for ls, goal in GOAL_STYLES.values()]
        f.legend(handles=[*handles, *_median_band_handles()], loc="outside right center",
                 frameon=False, fontsize=9, title="action probed", title_fontsize=9)
        f.suptitle(f"{pref.capitalize()} preference: the Learner's human-policy estimate (top), "
                   f"its robot policy (middle), plain ME-IRL's policy (bottom); {runs} runs")
        paths.append(save_figure(f, out / f"{fig}.png"))
    if "fig8" in only:
        graph = graph_for("hanger")
        cfg = replace(base, scenario="hanger", agents=("learner",), episodes=9, r0=None,
                      schedule="random", preference=None, probes=fig8_probes(graph))
        res = run_study(cfg, progress=progress)
        log(f"fig8: {res.wall_time_s:.1f} s")
        f, axes = new_figure(2, 2, figsize=(10, 7), sharex=True, layout="constrained")
        for ax, j in zip(axes.ravel(), range(4), strict=True):
            policy_lines(ax, res.probes["learner"][:, :, [j]], [cfg.probes[j].label],
                         relative=True, title=cfg.probes[j].label, colors=["C0"],
                         ylabel=False)
        for ax in axes[0]:
            ax.set_xlabel("")
        f.supylabel("p(preferred action) / p(wait), log scale")
        f.legend(handles=[*_median_band_handles(),
                          Line2D([], [], color="k", linestyle="-.", linewidth=0.8,
                                 label="1: as likely as waiting")],
                 loc="outside lower center", ncol=3, frameon=False, fontsize=9)
        f.suptitle("Hanger, most frequent preference: preferred action vs waiting "
                   f"({runs} random simulations)")
        paths.append(save_figure(f, out / "fig8.png"))
    if "fig4" in only:
        cfg = replace(base, scenario="hanger", agents=("imitator", "learner", "maxent"),
                      schedule="table2", episodes=9, r0=None, preference="all")
        res = run_study(cfg, progress=progress)
        log(f"fig4: {res.wall_time_s:.1f} s")
        f = decision_panels(res, title="Hanger, Table 2 schedule, runs cycling over the 36 "
                            "preferences")
        paths.append(save_figure(f, out / "fig4.png"))
    return paths
