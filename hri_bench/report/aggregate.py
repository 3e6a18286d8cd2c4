"""Aggregates across tracks, as rliable recommends (written on numpy/scipy; rliable itself
is archived).

The score of a run on a track is its mean episode reward (every step costs at most 1, so
the tracks share units and no normalisation is applied). Per agent, over the tracks it ran
on, and over every suite seed given:

Only agents with runs on every track of ``scores`` are aggregated (an agent that raised on
a track, or a reference that runs only where it fits, is listed under ``partial`` with its
tracks): an aggregate over other tracks would not be comparable.

* **IQM** of the pooled run scores with a 95 % **stratified** percentile bootstrap CI: the
  runs of each track are resampled on their own (:func:`hri_bench.core.stats.bootstrap_ci` with
  one stratum per track), and the mean likewise;
* **seed-to-seed spread**: the IQM of each suite seed alone, their standard deviation
  (``ddof=1``; 0 for one seed), minimum and maximum;
* **performance profile**: for each threshold τ of a common grid, the fraction of runs
  scoring above τ, averaged over tracks (each track weighs the same);
* **probability of improvement** for every ordered pair of agents: P(a run of ``a`` scores
  higher than a run of ``b`` on the same track, ties one half), averaged over the tracks both
  ran on and over seeds.

Inputs are ``scores[seed][track][agent]`` = (runs,) arrays. See docs/results.md,
"Aggregates".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from hri_bench.core import stats

__all__ = ["PROFILE_POINTS", "aggregate", "probability_of_improvement", "profile_grid",
           "profiles"]

Scores = Mapping[str, Mapping[str, Mapping[str, np.ndarray]]]  # seed -> track -> agent
#: Thresholds of the performance profiles.
PROFILE_POINTS = 51


def _tracks_of(scores: Scores, agent: str) -> list[str]:
    tracks: list[str] = []
    for by_track in scores.values():
        tracks += [t for t, by_agent in by_track.items() if agent in by_agent and t not in tracks]
    return tracks


def _strata(scores: Scores, agent: str) -> list[np.ndarray]:
    """One stratum per track: the runs of every seed on it."""
    return [np.concatenate([np.asarray(scores[s][t][agent], dtype=float) for s in scores
                            if agent in scores[s].get(t, {})])
            for t in _tracks_of(scores, agent)]


def probability_of_improvement(scores: Scores, a: str, b: str) -> float | None:
    """P(a > b) averaged over (seed, track) where both ran; None where they share none."""
    return _improvement_pair(scores, a, b)[0]


def _improvement_pair(scores: Scores, a: str, b: str
                      ) -> tuple[float | None, float | None]:
    """(P(a > b), P(b > a)) as :func:`probability_of_improvement` computes each, from one
    Mann-Whitney U per (seed, track) (:func:`hri_bench.core.stats.improvement_pair`).
    """
    values = []
    for by_track in scores.values():
        for by_agent in by_track.values():
            if a in by_agent and b in by_agent:
                x, y = np.asarray(by_agent[a], float), np.asarray(by_agent[b], float)
                values.append(stats.improvement_pair(x[:, None], y[:, None]))
    if not values:
        return None, None
    # Each direction averaged as a 1-D array, as before (a mean over axis 0 of the pairs
    # could add in another order).
    ab, ba = (round(float(np.mean([v[i] for v in values])), 6) for i in (0, 1))
    return ab, ba


def profile_grid(scores: Scores, points: int = PROFILE_POINTS) -> list[float]:
    """A common grid of thresholds from the lowest to the highest run score (rounded)."""
    every = np.concatenate([np.asarray(x, dtype=float).ravel() for by_track in scores.values()
                            for by_agent in by_track.values() for x in by_agent.values()])
    lo, hi = float(every.min()), float(every.max())
    if hi == lo:
        hi = lo + 1.0
    return [round(float(v), 6) for v in np.linspace(lo, hi, points)]


def profiles(scores: Scores, agents: Sequence[str], grid: Sequence[float]
             ) -> dict[str, list[float]]:
    """Per agent, the fraction of runs scoring above each τ of ``grid``, averaged over
    tracks (runs of all seeds pooled per track).
    """
    tau = np.asarray(grid, dtype=float)
    out = {}
    for agent in agents:
        per_track = [(s[:, None] > tau[None, :]).mean(0) for s in _strata(scores, agent)]
        out[agent] = [round(float(v), 6) for v in np.mean(per_track, axis=0)]
    return out


def aggregate(scores: Scores, agents: Sequence[str], seed: int) -> dict[str, Any]:
    """The aggregate block of a results file (module docstring).

    Args:
        scores: ``scores[seed][track][agent]`` (runs,) run scores.
        agents: The agents, in order (those with no track are left out).
        seed: Seeds the bootstraps.

    Returns:
        ``{"score": ..., "partial": {a: [tracks]}, "agents": {a: {"tracks", "runs", "iqm",
        "iqm_ci95", "mean", "ci95", "seeds": {seed: iqm}, "seed_std", "seed_min", "seed_max"}},
        "probability_of_improvement": {a: {b: p}}, "profiles": {"tau": [...], a: [...]}}``.
    """
    every = {t for by_track in scores.values() for t in by_track}
    present = [a for a in agents if set(_tracks_of(scores, a)) == every]
    partial = {a: _tracks_of(scores, a) for a in agents if a not in present}
    block: dict[str, Any] = {}
    for agent in present:
        strata = _strata(scores, agent)
        pooled = np.concatenate(strata)
        per_seed = {str(s): float(stats.iqm(np.concatenate(
            [np.asarray(by_agent[agent], float) for by_agent in by_track.values()
             if agent in by_agent])))
            for s, by_track in scores.items()
            if any(agent in by_agent for by_agent in by_track.values())}
        spread = np.array(list(per_seed.values()))
        block[agent] = {
            "tracks": _tracks_of(scores, agent), "runs": int(len(pooled)),
            "iqm": float(stats.iqm(pooled)),
            "iqm_ci95": list(stats.bootstrap_ci(strata, "iqm", seed)),
            "mean": float(pooled.mean()),
            "ci95": list(stats.bootstrap_ci(strata, "mean", seed)),
            "seeds": per_seed,
            "seed_std": float(spread.std(ddof=1)) if len(spread) > 1 else 0.0,
            "seed_min": float(spread.min()), "seed_max": float(spread.max()),
        }
    poi: dict[str, dict[str, float | None]] = {a: {} for a in present}
    for i, a in enumerate(present):  # each unordered pair once
        for b in present[i + 1:]:
            poi[a][b], poi[b][a] = _improvement_pair(scores, a, b)
    poi = {a: {b: poi[a][b] for b in present if b != a} for a in present}  # the column order
    grid = profile_grid(scores) if present else []
    return {"score": "each run's mean episode reward (higher is better)", "agents": block,
            "partial": partial,
            "probability_of_improvement": poi,
            "profiles": {"tau": grid, "fraction_above": profiles(scores, present, grid)}}
