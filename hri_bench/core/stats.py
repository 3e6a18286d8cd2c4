"""Statistics of a study: mean, IQM, stratified bootstrap CIs, probability of improvement.

Every function takes a metric as a (runs, episodes) array: run ``r`` of an agent learns
across its episodes, runs are independent. Per episode the runs are resampled with
:func:`scipy.stats.bootstrap`; for a figure over all episodes the bootstrap is *stratified*
by episode (the runs of each episode are resampled independently, as rliable does across
tasks), which is what scipy does when each episode is passed as its own sample. The
bootstrap's generator is seeded by the caller (the study seed), so the intervals are
reproducible.
"""

from __future__ import annotations

import functools
import math
import statistics
from collections.abc import Mapping
from types import ModuleType

import numpy as np

from hri_envs.errors import ConfigError

__all__ = [
    "aggregate",
    "bootstrap_ci",
    "detectable_difference",
    "improvement_pair",
    "improvement_table",
    "iqm",
    "per_episode",
    "probability_of_improvement",
    "runs_for_difference",
]

@functools.cache
def _scipy_stats() -> ModuleType:
    """scipy.stats, imported on first use: it takes about a second, and every ``hri-bench``
    command imports this module to build its argument parser.
    """
    from scipy import stats

    return stats


#: Bootstrap resamples (scipy's default is 9999; 2000 keeps a study's summary fast).
N_RESAMPLES = 2000


def iqm(x: np.ndarray, axis: int | None = None) -> np.ndarray:
    """Interquartile mean: the mean of the middle 50 % (scipy's 25 %-trimmed mean)."""
    return np.asarray(_scipy_stats().trim_mean(x, 0.25, axis=axis))


def _pooled_stat(fn: str):
    def stat(*samples: np.ndarray, axis: int = -1) -> np.ndarray:
        pooled = np.concatenate(samples, axis=axis)
        return np.asarray(iqm(pooled, axis=axis) if fn == "iqm" else pooled.mean(axis=axis))

    return stat


def bootstrap_ci(samples: list[np.ndarray] | np.ndarray, statistic: str,
                 seed: int | np.random.SeedSequence, *, level: float = 0.95
                 ) -> tuple[float | None, float | None]:
    """Percentile bootstrap CI of the mean or IQM of the pooled samples.

    Args:
        samples: One (N,) array, or a list of them: the strata, each resampled on its own.
        statistic: "mean" or "iqm".
        seed: Seeds the bootstrap's generator.
        level: Confidence level.

    Returns:
        (low, high); both equal the statistic when every value is the same; (None, None)
        when a stratum has fewer than two runs (no interval can be estimated; JSON null).
    """
    if statistic not in ("mean", "iqm"):
        raise ConfigError(f"statistic must be 'mean' or 'iqm', got {statistic!r}",
                          field="statistic")
    strata = [np.asarray(samples, dtype=float)] if isinstance(samples, np.ndarray) else [
        np.asarray(s, dtype=float) for s in samples]
    if min(len(s) for s in strata) < 2:
        return None, None
    pooled = np.concatenate(strata)
    if np.ptp(pooled) == 0:
        v = float(pooled[0])
        return v, v
    res = _scipy_stats().bootstrap(tuple(strata), _pooled_stat(statistic), n_resamples=N_RESAMPLES,
                        confidence_level=level, method="percentile", vectorized=True,
                        rng=np.random.default_rng(seed))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


Interval = list[float | None]


def per_episode(x: np.ndarray, seed: int, *, iqm_ci: bool = True
                ) -> dict[str, list[float] | list[Interval]]:
    """Per episode of a (runs, episodes) metric: mean, IQM and their 95 % CIs over runs.

    Returns:
        ``{"mean": [E], "iqm": [E], "ci95": [E][2] (of the mean), "iqm_ci95": [E][2]}``
        (``iqm_ci95`` only with ``iqm_ci``); episode ``e`` bootstraps with seed
        ``(seed, e)``.
    """
    x = np.asarray(x, dtype=float)
    cis = [bootstrap_ci(x[:, e], "mean", _seed(seed, e)) for e in range(x.shape[1])]
    out: dict[str, list[float] | list[Interval]] = {
        "mean": x.mean(0).tolist(), "iqm": iqm(x, axis=0).tolist(),
        "ci95": [list(c) for c in cis]}
    if iqm_ci:
        out["iqm_ci95"] = [list(bootstrap_ci(x[:, e], "iqm", _seed(seed, e)))
                           for e in range(x.shape[1])]
    return out


def aggregate(x: np.ndarray, seed: int, *, iqm_ci: bool = True
              ) -> dict[str, float | Interval]:
    """Over all episodes of a (runs, episodes) metric, bootstrap stratified by episode.

    Returns:
        ``{"mean", "iqm", "ci95" (of the mean), "iqm_ci95"}`` (``iqm_ci95`` only with
        ``iqm_ci``: the stratified IQM bootstrap is the costly one).
    """
    x = np.asarray(x, dtype=float)
    strata = [x[:, e] for e in range(x.shape[1])]
    out: dict[str, float | Interval] = {
        "mean": float(x.mean()), "iqm": float(iqm(x.ravel())),
        "ci95": list(bootstrap_ci(strata, "mean", seed))}
    if iqm_ci:
        out["iqm_ci95"] = list(bootstrap_ci(strata, "iqm", seed))
    return out


def probability_of_improvement(x: np.ndarray, y: np.ndarray) -> float:
    """P(X > Y) averaged over episodes, ties counting one half.

    Per episode it is the Mann-Whitney U statistic of the runs of ``x`` against those of
    ``y`` divided by the number of pairs; both arrays are (runs, episodes).
    """
    return improvement_pair(x, y)[0]


def improvement_pair(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(P(X > Y), P(Y > X)) as :func:`probability_of_improvement` computes each, from one
    Mann-Whitney U per episode: U of ``y`` against ``x`` is the number of pairs minus U of
    ``x`` against ``y``, exactly (both are multiples of one half), so the second equals
    ``probability_of_improvement(y, x)`` to the bit.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.shape[1] != y.shape[1]:
        raise ConfigError(f"x and y need the same episodes, got {x.shape} and {y.shape}",
                          field="episodes")
    pairs = len(x) * len(y)
    u = _scipy_stats().mannwhitneyu(x, y, axis=0).statistic  # (E,)
    return float(np.mean(u / pairs)), float(np.mean((pairs - u) / pairs))


def improvement_table(metric: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """``table[a][b]`` = P(agent a's metric > agent b's) for every ordered pair a ≠ b.

    Each unordered pair is computed once: with ties counting one half,
    P(b > a) = 1 - P(a > b).
    """
    names = list(metric)
    table: dict[str, dict[str, float]] = {a: {} for a in names}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            p = probability_of_improvement(metric[a], metric[b])
            table[a][b], table[b][a] = round(p, 6), round(1.0 - p, 6)
    return {a: {b: table[a][b] for b in names if b != a} for a in names}


def runs_for_difference(sd: float, delta: float, *, power: float = 0.8, alpha: float = 0.05
                        ) -> int:
    """Runs needed to detect a difference ``delta`` between two agents' mean rewards.

    The normal approximation for a two-sided paired comparison at level ``alpha``:
    ``n = ((z_(1-α/2) + z_power) · sd / delta)²``, rounded up, where ``sd`` is the standard
    deviation over runs of the difference of two agents' run means (runs are paired: the
    same run meets the same human and schedule). With ``sd = 0.3``, ``delta = 0.05`` at 80 %
    power: 283 runs.
    """
    for name, value in (("sd", sd), ("delta", delta)):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise ConfigError(f"{name} must be a number > 0, got {value!r}", field=name)
    for name, value in (("power", power), ("alpha", alpha)):
        if not (isinstance(value, int | float) and 0 < value < 1):
            raise ConfigError(f"{name} must be in (0, 1), got {value!r}", field=name)
    return int(math.ceil((_z(power, alpha) * sd / delta) ** 2))


def detectable_difference(sd: float, runs: int, *, power: float = 0.8, alpha: float = 0.05
                          ) -> float:
    """The smallest difference :func:`runs_for_difference` detects with ``runs`` runs."""
    return float(_z(power, alpha) * sd / math.sqrt(runs))


def _z(power: float, alpha: float) -> float:
    """``z_(1-α/2) + z_power`` (the standard library's normal quantiles: importing
    scipy.stats would slow every command that builds the suite's tracks).
    """
    norm = statistics.NormalDist()
    return norm.inv_cdf(1 - alpha / 2) + norm.inv_cdf(power)


def _seed(seed: int, e: int) -> np.random.SeedSequence:
    return np.random.SeedSequence([int(seed) & 0xFFFFFFFF, int(e), 9])
