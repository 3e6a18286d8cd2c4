"""Suite v4's leaderboard: learners ranked apart from references, ranks that admit ties.

A results file of suite v4 (``schema_version`` "3") is v3's
(:mod:`hri_bench.suite.results_v3`, which computes both) with each agent's role
(``roles``: whether it sees ι or the human's model; a reference is never ranked) and
intervals that re-estimate the reference and the floor in every bootstrap replicate
(:mod:`hri_bench.report.ranking`). :func:`lead_section` writes the headline: the ranked
agents (the intention-blind ones, an agent of one's own included) with shared ranks ("2=")
where no paired interval separates them, the share of humans on which each does worse than
the floor, a line where the IQM orders two agents otherwise than the mean; then the
references, apart; then the pairs and the tracks (docs/results.md, "Ranking (suite v4)").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.tracks import FLOOR

__all__ = ["lead_section", "role_mark"]

#: The reachable references: 1 on the scale (``blind`` exact where it fits, else ``qmdp``).
REACHABLE = ("blind", "qmdp")


def role_mark(agent: str, roles: Mapping[str, Any]) -> str:
    """What the leaderboard says an agent is, from its recorded role: the floor, a reference
    that sees ι, one that knows the human's model (the reachable reference).
    """
    role = roles.get(agent, {})
    if agent == FLOOR:
        return " (floor)"
    if role.get("sees_intention"):
        return " (ref., sees ι)"
    if role.get("knows_human"):
        return " (ref., reachable)" if agent in REACHABLE else " (ref., knows the human)"
    return ""


def _ranked(doc: Mapping[str, Any]) -> tuple[list[str], list[str]]:
    head = doc["aggregate"]["headline"]
    roles = doc.get("roles", {})
    refs = [a for a in head["order"] if roles.get(a, {}).get("reference", False)]
    return [a for a in head["order"] if a not in refs], refs


def _rank_text(agent: str, ranks: Mapping[str, int]) -> str:
    shared = sum(r == ranks[agent] for r in ranks.values()) > 1
    return f"{ranks[agent]}{'=' if shared else ''}"


def _iqm_line(order: Sequence[str], block: Mapping[str, Any], name: Any) -> list[str]:
    flips = [(a, b) for i, a in enumerate(order) for b in order[i + 1:]
             if block[b]["iqm"] > block[a]["iqm"]]
    if not flips:
        return ["The IQM orders the ranked agents as the mean does.", ""]
    return ["**Where the IQM orders two agents otherwise:** " + "; ".join(
        f"{name(a)} is above {name(b)} by the mean but below it by the IQM "
        f"({number(block[a]['iqm'])} against {number(block[b]['iqm'])})" for a, b in flips)
        + ".", ""]


def lead_section(doc: Mapping[str, Any]) -> str:
    """The leaderboard's lead for suite v4 (module docstring)."""
    agg = doc["aggregate"]
    head = agg.get("headline")
    if head is None:
        return "## Across tracks\n\nNo agent ran on every track: no headline.\n"
    roles = doc.get("roles", {})

    def name(a: str) -> str:
        return f"{code(a)}{role_mark(a, roles)}"

    order, refs = _ranked(doc)
    block, pairs, ranks = head["agents"], head["pairs"], agg.get("ranks", {})
    worse = agg.get("worse_than_floor", {})
    seeds = ", ".join(str(s) for s in doc["seeds"])
    lines = ["## Headline: normalised score on the test split", "",
             "Each run's mean episode reward normalised per track: 1 at the track's reachable "
             "reference (`blind` exact on the paper's anchor, else `qmdp`, an intention-blind "
             "robot that knows each human's model), 0 at the floor (`passive`). Headline: the "
             f"mean over the {len(head['tracks'])} headline tracks of each track's mean over "
             "its humans; 95 % CIs from a two-stage bootstrap (humans, then runs within each "
             "human) in which every replicate re-estimates the reference and the floor, so "
             "the intervals hold their noise too (the floor scores 0 by definition). Ranked: "
             "the agents that see the robot's view only; an agent shares a rank with those "
             "whose paired headline difference to it has a 95 % CI across 0 (\"2=\"); rank = "
             "1 + the agents better than it by such a CI. Below floor: the share of the "
             "headline tracks' humans on whom the agent's mean reward is below `passive`'s. "
             f"W/T/L: headline tracks won / tied / lost against the next agent. Suite seeds "
             f"{seeds}.", "",
             "| rank | agent | headline [95 % CI] | IQM [95 % CI] | below floor | "
             "W/T/L vs next | Δ vs next [95 % CI] |", "|---|---|---|---|---|---|---|"]
    for i, a in enumerate(order):
        if i + 1 < len(order):
            p = pairs[a][order[i + 1]]
            wtl, delta = f"{p['wins']}/{p['ties']}/{p['losses']}", with_ci(p["difference"])
        else:
            wtl = delta = "·"
        share = worse.get(a)
        lines.append(f"| {_rank_text(a, ranks)} | {name(a)} | {with_ci(block[a])} | "
                     f"{with_ci(block[a], 'iqm')} | "
                     f"{'–' if share is None else f'{share:.0%}'} | {wtl} | {delta} |")
    lines += ["", *_iqm_line(order, block, name)]
    if refs:
        lines += ["### References (not ranked: they see more than the robot's view)", "",
                  "| reference | headline [95 % CI] | IQM [95 % CI] |", "|---|---|---|"]
        lines += [f"| {name(a)} | {with_ci(block[a])} | {with_ci(block[a], 'iqm')} |"
                  for a in refs]
        lines.append("")
    partial = {a: t for a, t in (agg.get("partial") or {}).items() if a not in REACHABLE}
    if partial:
        lines += ["Not ranked (no runs on every track of every seed): "
                  + "; ".join(f"{name(a)} ({len(t)} track(s))" for a, t in partial.items())
                  + ".", ""]
    lines += _pairs(order, pairs, name)
    lines += ["### Per track: normalised score [95 % CI]", "",
              "| track | " + " | ".join(name(a) for a in order + refs) + " |",
              "|---|" + "---|" * len(order + refs)]
    for t in next(iter(block.values()))["per_track"]:
        label = f"**{escape(t)}**" if t in head["tracks"] else f"{escape(t)} (anchor)"
        lines.append(f"| {label} | " + " | ".join(with_ci(block[a]["per_track"][t])
                                                  for a in order + refs) + " |")
    return "\n".join([*lines, ""])


def _pairs(order: Sequence[str], pairs: Mapping[str, Any], name: Any) -> list[str]:
    lines = ["### Every pair of ranked agents: wins/ties/losses over the headline tracks, "
             "and the paired headline difference", "", "Row agent against column agent.", "",
             "| row vs column | " + " | ".join(name(b) for b in order) + " |",
             "|---|" + "---|" * len(order)]
    for a in order:
        cells = ["·" if a == b else f"{pairs[a][b]['wins']}/{pairs[a][b]['ties']}/"
                 f"{pairs[a][b]['losses']}, {number(pairs[a][b]['difference']['mean'])}"
                 for b in order]
        lines.append(f"| {name(a)} | " + " | ".join(cells) + " |")
    odd = [(a, b) for i, a in enumerate(order) for b in order[i + 1:]
           if pairs[a][b]["losses"] > pairs[a][b]["wins"]]
    lines.append("")
    if odd:
        lines += ["**Where the order and the tracks disagree:** " + "; ".join(
            f"{name(a)} is ranked above {name(b)} but loses {pairs[a][b]['losses']} headline "
            f"track(s) to it and wins {pairs[a][b]['wins']} (paired headline difference "
            f"{with_ci(pairs[a][b]['difference'])})" for a, b in odd) + ".", ""]
    else:
        lines += ["The order agrees with the tracks: no agent loses more headline tracks to "
                  "an agent ranked below it than it wins.", ""]
    return lines
