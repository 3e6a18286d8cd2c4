"""The physical suite's results file: its runs, the statistics computed from them alone.

A physical results document (``format`` :data:`FORMAT`, written by ``hri-bench suite
--physical`` as ``results.json``) holds the suite's version and hash, the agents (with their
code identity and whether they are references), per track its settings and the humans its
population holds (family, label, fingerprint), and per seed and track each run's human and
each agent's per-episode figures (:data:`~hri_bench.run.physical.FIGURES`, rounded to
:data:`DECIMALS`). :func:`compute` derives every statistic from the runs alone, with the
same two-stage bootstrap (humans, then runs) and paired comparisons as the graph suites
(:mod:`hri_bench.report.ranking`), so a reader recomputes them exactly (``hri-bench
validate``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from hri_bench.report import ranking
from hri_bench.suite.physical_tracks import FLOOR, REFERENCE

__all__ = ["DECIMALS", "FORMAT", "SCHEMA_VERSION", "SUMMARY_FIGURES", "compute",
           "round_runs", "run_scores"]

FORMAT = "hri-bench-physical-results"
SCHEMA_VERSION = "p1"
#: Per-episode values are written rounded to this many decimals; the statistics are
#: computed from the rounded values.
DECIMALS = 6
#: The figures summarised per track and agent beside the score: each run's mean over its
#: episodes (``time_to_place_s`` over the episodes that placed the object at the goal;
#: ``effort_per_progress`` over those with progress).
SUMMARY_FIGURES: tuple[str, ...] = ("placed_goal", "effort", "effort_per_progress",
                                    "peak_force", "rms_force", "rms_jerk", "time_to_place_s",
                                    "stall_s")


def round_runs(figures: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """One agent's per-episode figures as a results file holds them (rounded; non-finite
    values as None).
    """
    out: dict[str, Any] = {}
    for k, v in figures.items():
        x = np.round(np.asarray(v, dtype=float), DECIMALS)
        out[k] = [[float(e) if np.isfinite(e) else None for e in row] for row in x]
    return out


def _array(rows: Sequence[Sequence[Any]]) -> np.ndarray:
    return np.array([[np.nan if e is None else float(e) for e in row] for row in rows],
                    dtype=float)


def run_scores(entry: Mapping[str, Any]) -> np.ndarray:
    """(runs,) each run's score: the mean over its episodes of the v1 return."""
    return _array(entry["return"]).mean(axis=1)


def _run_means(entry: Mapping[str, Any], figure: str) -> np.ndarray:
    """(runs,) each run's mean of ``figure`` over the episodes where it is defined."""
    x = _array(entry[figure])
    if figure == "time_to_place_s":
        x = np.where(_array(entry["placed_goal"]) > 0.5, x, np.nan)
    x = np.where(np.isfinite(x), x, np.nan)
    with np.errstate(invalid="ignore"):
        count = np.sum(~np.isnan(x), axis=1)
        total = np.nansum(x, axis=1)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _figure_summary(track: ranking.Track, values: np.ndarray) -> dict[str, Any]:
    """The mean of a per-run figure over the track's humans with its two-stage CI (runs
    without a value left out, each replicate renormalised).
    """
    w, big = track.weights()
    ok = ~np.isnan(values)
    if not ok.any():
        return {"mean": None, "ci95": [None, None]}
    v = np.where(ok, values, 0.0)
    point = float((w * v).sum() / (w * ok).sum())
    mass = big @ ok
    with np.errstate(invalid="ignore", divide="ignore"):
        reps = (big @ v) / mass
    reps = reps[np.isfinite(reps)]
    lo, hi = np.quantile(reps, [0.025, 0.975]) if len(reps) else (np.nan, np.nan)
    return {"mean": point, "ci95": [float(lo), float(hi)]}


def _normalisation(block: Mapping[str, Any]) -> tuple[dict[str, Any], np.ndarray,
                                                      np.ndarray]:
    """The track's normalisation (the reference's and the floor's mean scores) and their
    per-run scores, which every bootstrap replicate re-estimates
    (:class:`hri_bench.report.ranking.Track`'s ``reference`` and ``floor``).
    """
    agents = block["agents"]
    if REFERENCE not in agents or FLOOR not in agents:
        raise ValueError(f"a physical track needs the reference ({REFERENCE}) and the floor "
                         f"({FLOOR})")
    ref, floor = run_scores(agents[REFERENCE]), run_scores(agents[FLOOR])
    return {"reference": REFERENCE, "reference_score": float(ref.mean()), "floor": FLOOR,
            "floor_score": float(floor.mean())}, ref, floor


def compute(doc: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(statistics, aggregate)`` of a physical results document, from its runs alone.

    ``statistics[seed][track]``: the normalisation and per agent its normalised score
    (mean, IQM, two-stage CIs in which every replicate re-estimates the reference and the
    floor) and the :data:`SUMMARY_FIGURES` (means over humans with two-stage CIs).
    ``aggregate``: every seed pooled per track; the headline (the mean over the headline
    tracks of each track's mean over its humans), the pairs with wins / ties / losses
    (:func:`hri_bench.report.ranking.headline`), the shared ranks and each robot's share of
    humans on whom it scores below the floor.
    """
    tracks = doc.get("tracks", {})
    statistics: dict[str, Any] = {}
    pooled: dict[str, dict[str, list[np.ndarray]]] = {}
    humans: dict[str, list[np.ndarray]] = {}
    seed0 = int(next(iter(doc["runs"]), 0))
    for seed, by_track in doc["runs"].items():
        statistics[seed] = {}
        for name, block in by_track.items():
            norm, ref, floor = _normalisation(block)
            x = {a: run_scores(e) for a, e in block["agents"].items()}
            one = ranking.Track(name, x, block["humans"], int(seed), reference=ref,
                                floor=floor)
            per_agent = {}
            for agent, entry in block["agents"].items():
                stat = {"normalised": ranking.public(ranking.summarise(one, agent))}
                for fig in SUMMARY_FIGURES:
                    stat[fig] = _figure_summary(one, _run_means(entry, fig))
                per_agent[agent] = stat
                pooled.setdefault(name, {}).setdefault(agent, []).append(x[agent])
            humans.setdefault(name, []).append(np.asarray(block["humans"]))
            statistics[seed][name] = {"normalisation": norm, "agents": per_agent}
    every = list(pooled)
    agents = [a for a in doc["agents"] if all(a in pooled[t] and len(pooled[t][a]) ==
                                              len(humans[t]) for t in every)]
    ranked = [a for a in agents if a != REFERENCE and not doc["agents"][a].get("privileged")]
    order = [t for t in tracks if t in pooled] + sorted(set(every) - set(tracks))
    rank_tracks = []
    for t in order:
        scores = {a: np.concatenate(pooled[t][a]) for a in agents}
        rank_tracks.append(ranking.Track(
            t, scores, np.concatenate(humans[t]).tolist(), seed0,
            headline=bool(tracks.get(t, {}).get("headline", True)),
            reference=scores.get(REFERENCE), floor=scores.get(FLOOR)))
    aggregate: dict[str, Any] = {
        "score": "normalised: 1 at the upper reference (knows the goal), 0 at the passive "
                 "floor, both re-estimated in every bootstrap replicate; a run's score is the "
                 "mean of its episodes' v1 returns",
        "partial": sorted(set(doc["agents"]) - set(agents))}
    if not ranked or not any(t.headline for t in rank_tracks):
        aggregate.update(headline=None, ranks=None, below_floor=None)
        return _finite(statistics), _finite(aggregate)
    head = ranking.headline(rank_tracks, ranked)
    aggregate["headline"] = head
    aggregate["ranks"] = ranking.shared_ranks(head["order"], head["pairs"])
    aggregate["below_floor"] = {a: ranking.worse_than_floor(rank_tracks, a, FLOOR)
                                for a in ranked}
    return _finite(statistics), _finite(aggregate)


def _finite(value: Any) -> Any:
    """``value`` with every non-finite float as None (JSON has neither NaN nor inf)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if np.isfinite(value) else None
    return value

