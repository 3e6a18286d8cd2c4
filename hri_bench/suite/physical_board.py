"""The physical suite's leaderboard (``leaderboard.md``) and figures, from a results document.

The headline table ranks the robots by their normalised score (1: the upper reference, 0:
the passive floor) with two-stage 95 % CIs; robots whose paired difference to the next one
includes 0 share a rank. Beside the score: the goal rate, the human's effort (per episode
and per unit of route progress), peak interaction force, the object's RMS jerk, the time to
place, and each robot's share of humans on which it does worse than the floor. Effort is
never ranked on its own: it stands beside the goal rate. References (agents that read the
simulation) are listed apart, never ranked.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.physical_tracks import FLOOR, REFERENCE

__all__ = ["headline_table", "leaderboard", "write_figures"]

_COLUMNS = (("placed_goal", "goal rate", 2), ("effort", "effort [N s]", 1),
            ("effort_per_progress", "effort per route [N s]", 1),
            ("peak_force", "peak force [N]", 1), ("rms_jerk", "RMS jerk [m/s³]", 2),
            ("time_to_place_s", "time to place [s]", 1))


def _pooled(doc: Mapping[str, Any], agent: str, figure: str) -> float | None:
    """A figure's mean over the tracks (first seed's statistics), each track the same."""
    values = []
    for by_track in doc["statistics"].values():
        for stats in by_track.values():
            v = stats["agents"].get(agent, {}).get(figure, {}).get("mean")
            if v is not None:
                values.append(float(v))
        break
    return sum(values) / len(values) if values else None


def headline_table(doc: Mapping[str, Any]) -> str:
    """The headline table of a physical results document (markdown; also what the console
    prints at the end of a suite).
    """
    agg = doc["aggregate"]
    head = agg.get("headline")
    if head is None:
        return "No robot ran on every track: no headline."
    block, pairs = head["agents"], head["pairs"]
    # by rank (1 + the robots whose paired difference to it is above 0), then by mean
    order = sorted(head["order"], key=lambda a: (agg["ranks"][a], head["order"].index(a)))
    counts = list(agg["ranks"].values())
    ranks = [f"{agg['ranks'][a]}=" if counts.count(agg["ranks"][a]) > 1
             else str(agg["ranks"][a]) for a in order]
    lines = ["| rank | robot | score [95 % CI] | IQM | "
             + " | ".join(c[1] for c in _COLUMNS) + " | worse than floor | W/T/L vs next |",
             "|---|---|---|---|" + "---|" * len(_COLUMNS) + "---|---|"]
    for i, a in enumerate(order):
        e = block[a]
        score = "0 (the floor, by definition)" if a == FLOOR else with_ci(e)
        cells = [number(_pooled(doc, a, fig), d) for fig, _, d in _COLUMNS]
        below = agg["below_floor"].get(a)
        worse = "·" if a == FLOOR or below is None else f"{100 * below:.0f} %"
        if i + 1 < len(order):
            p = pairs[a][order[i + 1]]
            wtl = f"{p['wins']}/{p['ties']}/{p['losses']}"
        else:
            wtl = "·"
        lines.append(f"| {ranks[i]} | {code(a)} | {score} | {number(e['iqm'])} | "
                     + " | ".join(cells) + f" | {worse} | {wtl} |")
    iqm_order = sorted(order, key=lambda a: -block[a]["iqm"])
    swapped = [(a, b) for i, a in enumerate(order) for b in order[i + 1:]
               if iqm_order.index(b) < iqm_order.index(a)]
    if swapped:
        lines += ["", "The IQM orders differently: " + "; ".join(
            f"{code(b)} above {code(a)}" for a, b in swapped) + "."]
    return "\n".join(lines)


def leaderboard(doc: Mapping[str, Any]) -> str:
    """``leaderboard.md`` of a physical results document."""
    agg = doc["aggregate"]
    head = agg.get("headline")
    lines = [f"# Physical suite v{escape(str(doc['suite_version']))}: robots that feel the "
             "human", "",
             f"Suite hash `{doc['suite_hash'][:16]}`, seeds "
             f"{', '.join(str(s) for s in doc['seeds'])}, runs scale {doc['runs_scale']}. "
             "Each run: a few episodes of one robot with one held-out physical human on the "
             "continuous envs' v1 (`*PandaContinuous-v1`). A run's score is the mean of its "
             "episodes' returns (placing at the human's goal +10, any other end -5, the "
             "human's effort -0.02 per N s, -0.1 per J against the motion, -0.5 per s of "
             "stall), normalised per track: 1 at the upper reference (`upper`, which knows "
             "the goal), 0 at the passive floor (`passive`, 0 by definition). 95 % CIs from a "
             "two-stage bootstrap (humans, then runs; the reference and the floor re-estimated in "
             "every replicate). A robot's rank is 1 + the robots whose paired difference to "
             "it has its interval above 0, so robots no interval separates share a rank "
             "(\"2=\"); rows by rank, then mean.", ""]
    if head is None:
        return "\n".join([*lines, "No robot ran on every track: no headline.", ""])
    order, block = head["order"], head["agents"]
    lines += ["## Headline", "", headline_table(doc)]
    lines += ["", "References (never ranked): " + ", ".join(
        f"{code(a)} ({escape(str(doc['agents'][a].get('description', '')))})"
        for a in doc["agents"] if a == REFERENCE or doc["agents"][a].get("privileged")) + ".",
        "", "## Per track: normalised score [95 % CI]", "",
        "| track | humans | " + " | ".join(code(a) for a in order) + " |",
        "|---|---|" + "---|" * len(order)]
    for t, tr in doc["tracks"].items():
        if t not in block[order[0]]["per_track"]:
            continue
        lines.append(f"| {escape(t)} | {tr['humans']} | " + " | ".join(
            with_ci(block[a]["per_track"][t]) for a in order) + " |")
    lines += ["", "## Per track: goal rate and the human's effort [N s]", "",
              "| track | " + " | ".join(code(a) for a in [*order, REFERENCE]) + " |",
              "|---|" + "---|" * (len(order) + 1)]
    first = next(iter(doc["statistics"].values()))
    for t, stats in first.items():
        cells = []
        for a in [*order, REFERENCE]:
            s = stats["agents"].get(a, {})
            cells.append(f"{number(s.get('placed_goal', {}).get('mean'), 2)}, "
                         f"{number(s.get('effort', {}).get('mean'), 1)}")
        lines.append(f"| {escape(t)} | " + " | ".join(cells) + " |")
    return "\n".join([*lines, ""])


#: Colour-blind-safe colours (Okabe & Ito) and markers for the robots, in headline order; the
#: references keep theirs.
_COLORS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")
_REFERENCES = {REFERENCE: ("#000000", "*"), FLOOR: ("#999999", "o")}


def _styles(agents: list[str]) -> dict[str, tuple[str, str]]:
    """Each agent's (colour, marker): no two robots of a figure share both."""
    out, i = {}, 0
    for a in agents:
        if a in _REFERENCES:
            out[a] = _REFERENCES[a]
        else:
            out[a] = (_COLORS[i % len(_COLORS)], _MARKERS[i % len(_MARKERS)])
            i += 1
    return out


def write_figures(doc: Mapping[str, Any], folder: Path) -> list[Path]:
    """``ranking.png`` (the headline with its CIs, each track as dots) and
    ``goal_effort.png`` (per scenario, each robot's goal rate against the human's effort).
    """
    from hri_bench.core import plots  # matplotlib: the bench extra

    head = doc["aggregate"].get("headline")
    if head is None:
        return []
    order = head["order"][::-1]
    style = _styles([*head["order"], REFERENCE])
    fig, ax = plots.new_figure(figsize=(6.4, 0.45 * max(len(order), 4) + 1.2))
    for y, a in enumerate(order):
        e = head["agents"][a]
        color, marker = style[a]
        lo, hi = e["ci95"]
        ax.errorbar([e["mean"]], [y], xerr=[[max(e["mean"] - lo, 0.0)],
                                            [max(hi - e["mean"], 0.0)]],
                    fmt=marker, color=color, capsize=3)
        per = [e["per_track"][t]["mean"] for t in head["tracks"]]
        ax.scatter(per, [y + 0.22] * len(per), s=9, color=color, alpha=0.6, linewidths=0)
    ax.set_yticks(range(len(order)), list(order))
    ax.axvline(0.0, color="#999999", linewidth=0.8, linestyle=":")
    ax.axvline(1.0, color="#333333", linewidth=0.8, linestyle="--")
    ax.set_xlabel("normalised score (0: passive floor, 1: upper reference)")
    ax.set_title("Physical suite headline, 95 % two-stage CI; dots: tracks", fontsize=9)
    paths = [plots.save_figure(fig, folder / "ranking.png")]
    first = next(iter(doc["statistics"].values()))
    scenarios = sorted({doc["tracks"][t]["scenario"] for t in first})
    fig, axes = plots.new_figure(ncols=len(scenarios), figsize=(5.0 * len(scenarios), 4.0))
    axes = list(axes) if len(scenarios) > 1 else [axes]
    for ax, sc in zip(axes, scenarios, strict=True):
        for a in [*head["order"], REFERENCE]:
            xs, ys = [], []
            for t, stats in first.items():
                if doc["tracks"][t]["scenario"] != sc or a not in stats["agents"]:
                    continue
                s = stats["agents"][a]
                if s["effort"]["mean"] is not None:
                    xs.append(s["effort"]["mean"])
                    ys.append(s["placed_goal"]["mean"])
            ax.scatter(xs, ys, label=a, color=style[a][0], marker=style[a][1], s=28,
                       alpha=0.85)
        ax.set_ylim(-0.03, 1.05)
        ax.set_xlabel("human's effort per episode [N s] (lower is better)")
        ax.set_ylabel("goal rate (placed at the human's goal)")
        ax.set_title(f"{sc}: one dot per track", fontsize=9)
    axes[-1].legend(fontsize=7, loc="lower left")
    paths.append(plots.save_figure(fig, folder / "goal_effort.png"))
    return paths
