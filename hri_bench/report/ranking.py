"""Suite v3's ranking: normalised scores per track, humans as a sample, paired comparisons.

The statistics behind suite v3's headline (docs/results.md, "Ranking (suite v3)"). Every
function is pure numpy on per-run arrays, so :mod:`hri_bench.suite.submission` recomputes each
number of a results file from its runs with the same code.

**Normalised score.** On a track, run ``r`` of agent ``a`` scores

    z[a, r] = (x[a, r] - floor) / (reference - floor)

where ``x`` is the run's mean episode reward, ``reference`` the mean episode reward of the
*reachable reference* (blind's exact expected reward where the exact plan fits, else the
``qmdp`` agent's mean: an intention-blind policy that knows each human's model) and
``floor`` the ``passive`` agent's mean, both over the same runs of the same suite seed. So 1
is what an intention-blind robot can reach, 0 is doing nothing, and every track has the
same scale whatever its rewards' range.

**Humans are a sample.** A track's statistic is the mean over its humans of each human's
mean over its runs (every seed pooled). Its 95 % CI is a *two-stage* percentile bootstrap
(:func:`replicate_weights`): draw the humans with replacement, then each drawn human's runs
with replacement; so the interval covers the humans one might have met as well as the luck
of the runs. Each replicate is a weight vector over the runs, the same for every agent of
the track, so a difference of two agents is resampled *paired* (the same humans, seeds and
runs) and linear statistics cost a matrix product.

**The headline** is the mean over the headline tracks of each track's statistic (every
track weighs the same); its replicates are the means of the tracks' replicates (each track
resampled on its own: the headline tracks partition the test humans). The IQM (a robustness
column) is the mean over tracks of each track's weighted interquartile mean.

**The references' own noise (suite v4).** A :class:`Track` given each run's ``reference``
and ``floor`` values holds raw run values, not normalised ones: every replicate then
re-estimates the reference and the floor from its own draw of humans and runs, and
normalises with them, ``(W x - W floor) / (W reference - W floor)``; the point estimate does
the same with the point weights. So an interval covers the references' noise too, the floor
agent scores exactly 0 (and the reference agent exactly 1) in every replicate, and a paired
difference ``W (x_a - x_b) / (W reference - W floor)`` shares the scale of its replicate.
:func:`shared_ranks` gives agents whose paired difference's interval includes 0 one rank.

**Pairs.** For agents ``a`` and ``b`` on a track: the paired difference ``z[a] - z[b]``
with its two-stage CI, a **win** for ``a`` when the CI lies above 0, a **loss** below, a
**tie** otherwise; over the headline tracks, the mean difference with its CI and the
wins / ties / losses; the paired probability of improvement, P(z[a, r] > z[b, r]) on the
same run (ties one half), averaged like the scores.
"""

from __future__ import annotations

import zlib
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError

__all__ = ["LEVEL", "REPLICATES", "Track", "compare", "headline", "human_groups",
           "normalise", "public", "replicate_weights", "shared_ranks", "summarise",
           "track_seed", "weighted_iqm", "worse_than_floor"]

#: Bootstrap replicates (as :data:`hri_bench.core.stats.N_RESAMPLES`).
REPLICATES = 2000
#: Confidence level of every interval.
LEVEL = 0.95
#: The smallest reference − floor a track may have (reward per episode): below it the
#: normalised score would divide by noise.
MIN_RANGE = 0.05


def normalise(x: np.ndarray, reference: float, floor: float) -> np.ndarray:
    """``(x - floor) / (reference - floor)`` (module docstring).

    Raises:
        ConfigError: The reference is not at least :data:`MIN_RANGE` above the floor.
    """
    if not reference - floor >= MIN_RANGE:
        raise ConfigError(f"the reference ({reference:.4f}) must lie at least {MIN_RANGE} above "
                          f"the floor ({floor:.4f}) to normalise a score", field="reference")
    return (np.asarray(x, dtype=float) - floor) / (reference - floor)


def human_groups(humans: Sequence[Hashable]) -> list[np.ndarray]:
    """The runs of each human (indices into ``humans``), in order of first appearance."""
    index: dict[Hashable, list[int]] = {}
    for i, h in enumerate(humans):
        index.setdefault(h, []).append(i)
    return [np.asarray(v, dtype=np.int64) for v in index.values()]


def track_seed(seed: int, track: str) -> np.random.SeedSequence:
    """The bootstrap's seed for a track: the suite seed and a checksum of the track's name
    (so a track's replicates do not depend on which other tracks a file holds).
    """
    return np.random.SeedSequence([int(seed) & 0xFFFFFFFF, zlib.crc32(track.encode()), 13])


def replicate_weights(groups: Sequence[np.ndarray], n: int, seed: Any,
                      replicates: int = REPLICATES) -> tuple[np.ndarray, np.ndarray]:
    """The point weights and the two-stage bootstrap's weights over ``n`` runs.

    Args:
        groups: The runs of each human (:func:`human_groups`).
        n: The runs in all.
        seed: Seeds the generator (:func:`track_seed`).
        replicates: How many replicates.

    Returns:
        ``(w, W)``: ``w`` (n,) the weights of the point estimate (each human ``1/H``, spread
        evenly over its runs); ``W`` (replicates, n): per replicate, H humans drawn with
        replacement, then each drawn human's runs drawn with replacement, as weights (each
        row sums to 1), so a replicate's mean of values ``v`` is ``W @ v``.
    """
    n_h = len(groups)
    sizes = np.array([len(g) for g in groups], dtype=np.int64)
    if n_h == 0 or sizes.min() < 1 or sizes.sum() != n:
        raise ConfigError(f"every one of the {n} runs must belong to one human",
                          field="humans")
    w = np.zeros(n)
    for g in groups:
        w[g] = 1.0 / (n_h * len(g))
    rng = np.random.default_rng(seed)
    width = int(sizes.max())
    table = np.zeros((n_h, width), dtype=np.int64)  # each human's runs, padded
    for i, g in enumerate(groups):
        table[i, :len(g)] = g
    picks = rng.integers(n_h, size=(replicates, n_h))  # stage 1: humans
    counts = sizes[picks]  # (B, H)
    k = np.minimum((rng.random((replicates, n_h, width)) * counts[..., None]).astype(np.int64),
                   counts[..., None] - 1)  # stage 2: runs within each drawn human
    runs = table[picks[..., None], k]  # (B, H, width)
    inside = np.arange(width) < counts[..., None]
    weight = inside / (counts[..., None] * n_h)
    rows = np.broadcast_to(np.arange(replicates)[:, None, None], runs.shape)
    big = np.bincount((rows * n + runs).ravel(), weights=weight.ravel(),
                      minlength=replicates * n)
    return w, big.reshape(replicates, n)


def weighted_iqm(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The interquartile mean of ``values`` under each row of ``weights`` (rows summing to
    1): the weighted mean of the middle half of the weight mass.

    Args:
        values: (n,).
        weights: (n,) or (B, n).

    Returns:
        () or (B,).
    """
    order = np.argsort(values, kind="stable")
    v = np.asarray(values, dtype=float)[order]
    w = np.asarray(weights, dtype=float)[..., order]
    top = np.cumsum(w, axis=-1)
    inner = np.clip(top, 0.25, 0.75) - np.clip(top - w, 0.25, 0.75)
    return (inner * v).sum(-1) / 0.5


def _interval(replicates: np.ndarray) -> list[float]:
    lo, hi = np.quantile(replicates, [(1 - LEVEL) / 2, (1 + LEVEL) / 2])
    return [float(lo), float(hi)]


@dataclass(frozen=True)
class Track:
    """One track's runs, ready to rank.

    Attributes:
        name: The track.
        scores: Per agent, (n,) normalised run scores (every seed, in one order).
        humans: (n,) each run's human (an id; runs of one human across seeds share it).
        seed: Seeds the bootstrap (the first suite seed).
        headline: Whether the track is part of the headline.
        reference: (n,) each run's value of the reference, or None: ``scores`` are
            normalised already. Given (with ``floor``), ``scores`` are raw run values and
            every replicate normalises with its own reference and floor (module docstring).
        floor: (n,) each run's value of the floor (with ``reference``).
    """

    name: str
    scores: Mapping[str, np.ndarray]
    humans: Sequence[Hashable]
    seed: int
    headline: bool = True
    reference: np.ndarray | None = None
    floor: np.ndarray | None = None

    def scale(self) -> tuple[float, float, np.ndarray, np.ndarray]:
        """``(floor, span, floors, spans)``: the floor and reference − floor of the point
        estimate and of every replicate ((0, 1, 0, 1) for normalised scores).

        Raises:
            ConfigError: The point's reference is not :data:`MIN_RANGE` above its floor.
        """
        if self.reference is None or self.floor is None:
            return 0.0, 1.0, np.zeros(1), np.ones(1)
        w, big = self.weights()
        ref, flo = np.asarray(self.reference, dtype=float), np.asarray(self.floor, dtype=float)
        floor, span = float(w @ flo), float(w @ ref - w @ flo)
        normalise(np.zeros(1), floor + span, floor)  # refuses a range below MIN_RANGE
        return floor, span, big @ flo, big @ ref - big @ flo

    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`replicate_weights` of the track's humans (cached per object)."""
        cached = self.__dict__.get("_weights")
        if cached is None:
            cached = replicate_weights(human_groups(self.humans), len(self.humans),
                                       track_seed(self.seed, self.name))
            object.__setattr__(self, "_weights", cached)
        return cached


def summarise(track: Track, agent: str) -> dict[str, Any]:
    """An agent's normalised score on a track: ``mean`` and ``iqm`` with their two-stage
    95 % CIs, and the replicates of both (``_mean``, ``_iqm``: for :func:`headline`).
    """
    w, big = track.weights()
    z = np.asarray(track.scores[agent], dtype=float)
    floor, span, floors, spans = track.scale()
    reps, iqms = (big @ z - floors) / spans, (weighted_iqm(z, big) - floors) / spans
    return {"mean": (float(w @ z) - floor) / span, "ci95": _interval(reps),
            "iqm": (float(weighted_iqm(z, w)) - floor) / span, "iqm_ci95": _interval(iqms),
            "_mean": reps, "_iqm": iqms}


def compare(track: Track, a: str, b: str) -> dict[str, Any]:
    """Agent ``a`` against ``b`` on a track, paired: ``difference`` (mean of ``z[a] - z[b]``
    with its CI), ``outcome`` ("win", "tie", "loss" for ``a``), ``improvement`` (the paired
    P(z[a] > z[b]), ties one half, with its CI), and the replicates (``_difference``,
    ``_improvement``).
    """
    w, big = track.weights()
    za, zb = (np.asarray(track.scores[x], dtype=float) for x in (a, b))
    d = za - zb
    better = (za > zb) + 0.5 * (za == zb)
    _, span, _, spans = track.scale()
    reps, p_reps = big @ d / spans, big @ better
    ci = _interval(reps)
    outcome = "win" if ci[0] > 0 else "loss" if ci[1] < 0 else "tie"
    return {"difference": {"mean": float(w @ d) / span, "ci95": ci}, "outcome": outcome,
            "improvement": {"mean": float(w @ better), "ci95": _interval(p_reps)},
            "_difference": reps, "_improvement": p_reps}


def public(entry: Mapping[str, Any]) -> dict[str, Any]:
    """A summary's entries without the private ones (``_...``: bootstrap replicates)."""
    return {k: v for k, v in entry.items() if not k.startswith("_")}


def headline(tracks: Sequence[Track], agents: Sequence[str]) -> dict[str, Any]:
    """The headline and the pairs over the headline tracks of ``tracks``.

    Args:
        tracks: Every track ranked; those with ``headline`` make the headline.
        agents: The agents, each with scores on every track.

    Returns:
        ``{"tracks": [headline tracks], "agents": {a: {"mean", "ci95", "iqm", "iqm_ci95",
        "per_track": {t: {"mean", "ci95", "iqm", "iqm_ci95"}}}}, "order": [agents by mean,
        best first], "pairs": {a: {b: {"difference": {"mean", "ci95"}, "wins", "ties",
        "losses", "improvement": {"mean", "ci95"}, "per_track": {t: {"difference",
        "outcome", "improvement"}}}}}}`` (per-track entries for every track, the headline's
        numbers over the headline tracks only).
    """
    lead = [t for t in tracks if t.headline]
    if not lead:
        raise ConfigError("no headline track to rank on", field="tracks")
    out: dict[str, Any] = {"tracks": [t.name for t in lead], "agents": {}, "pairs": {}}
    for a in agents:
        per = {t.name: summarise(t, a) for t in tracks}
        reps = np.mean([per[t.name]["_mean"] for t in lead], axis=0)
        iqms = np.mean([per[t.name]["_iqm"] for t in lead], axis=0)
        out["agents"][a] = {
            "mean": float(np.mean([per[t.name]["mean"] for t in lead])), "ci95": _interval(reps),
            "iqm": float(np.mean([per[t.name]["iqm"] for t in lead])), "iqm_ci95": _interval(iqms),
            "per_track": {name: public(e) for name, e in per.items()}}
    out["order"] = sorted(agents, key=lambda a: (-out["agents"][a]["mean"], a))
    for a in agents:
        out["pairs"][a] = {}
        for b in agents:
            if a == b:
                continue
            per = {t.name: compare(t, a, b) for t in tracks}
            count = {k: sum(per[t.name]["outcome"] == k for t in lead)
                     for k in ("win", "tie", "loss")}
            diff = np.mean([per[t.name]["_difference"] for t in lead], axis=0)
            imp = np.mean([per[t.name]["_improvement"] for t in lead], axis=0)
            out["pairs"][a][b] = {
                "difference": {"mean": float(np.mean([per[t.name]["difference"]["mean"]
                                                      for t in lead])),
                               "ci95": _interval(diff)},
                "wins": count["win"], "ties": count["tie"], "losses": count["loss"],
                "improvement": {"mean": float(np.mean([per[t.name]["improvement"]["mean"]
                                                       for t in lead])),
                                "ci95": _interval(imp)},
                "per_track": {name: public(e) for name, e in per.items()}}
    return out


def shared_ranks(order: Sequence[str], pairs: Mapping[str, Mapping[str, Any]]) -> dict[str, int]:
    """Each agent's rank: 1 + the agents whose paired headline difference to it has its
    interval above 0 (:func:`headline`'s ``pairs``). Agents that no interval separates share
    a rank (a leaderboard shows "2=").
    """
    return {a: 1 + sum(pairs[b][a]["difference"]["ci95"][0] > 0 for b in order if b != a)
            for a in order}


def worse_than_floor(tracks: Sequence[Track], agent: str, floor: str) -> float | None:
    """The share of the headline tracks' humans on whom ``agent``'s mean over their runs is
    below ``floor``'s (None without headline humans).
    """
    below, humans = 0, 0
    for t in tracks:
        if not t.headline:
            continue
        x, f = np.asarray(t.scores[agent], dtype=float), np.asarray(t.scores[floor], dtype=float)
        for g in human_groups(t.humans):
            humans += 1
            below += bool(x[g].mean() < f[g].mean())
    return below / humans if humans else None
