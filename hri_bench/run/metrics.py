"""The task's own metrics of one agent on one track, per run, with bootstrap CIs.

Every function here takes per-(run, episode) arrays (runs are independent, an agent learns
across a run's episodes) and is pure numpy (the CIs through :mod:`hri_bench.core.stats`), so the
validator (:mod:`hri_bench.suite.submission`) recomputes every number of a results file from its
per-run data with the same code. See docs/results.md, "Metrics".

* **Learning speed** (:func:`learning_episodes`): per run, the first episode from which the
  run's regret stays within :data:`LEARNED` to the end (the episodes + 1 when its last
  episode is above: it never settled).
* **Asymptote** (:func:`asymptote`): per run, the mean over the last :func:`last_k`
  episodes (a quarter of them, at least one) of the regret (and of the reward).
* **Re-adaptation** (a drifting human, after ``drift`` episodes): :func:`learning_episodes`
  of the episodes after the switch (1: within the threshold from the first one on).
* **Identification and calibration** (agents exposing a belief,
  :func:`agents.protocol.read_belief`): ``map_steps``, ``log_loss`` and ``brier`` of
  :data:`hri_bench.run.runner.TASK_METRICS`, per episode, averaged over a run's episodes.
* **Human effort**: ``counteract``, ``human_idle``, ``human_alone`` (counts per episode,
  averaged over a run's episodes).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from hri_bench.core import stats
from hri_bench.run.runner import BELIEF_METRICS, TASK_METRICS

__all__ = ["BELIEF_METRICS", "LEARNED", "agent_metrics", "asymptote",
           "last_k", "learning_episodes", "summary"]

#: A run has learned from the first episode after which its regret stays at or below this
#: (reward units per episode: two waits of the wheel's r0 = −0.25, one and a half of the
#: hanger's −0.33; an aborted or counteracted step costs 1).
LEARNED = 0.5


def last_k(episodes: int) -> int:
    """The episodes the asymptote averages: the last quarter, at least one."""
    return max(1, episodes // 4)


def learning_episodes(regret: np.ndarray, threshold: float = LEARNED) -> np.ndarray:
    """(runs,) the first episode (1-based) from which each run's regret stays ≤ threshold.

    A run whose last episode is above the threshold gets ``episodes + 1`` (never settled);
    a run within it from the first episode gets 1.
    """
    regret = np.asarray(regret, dtype=float)
    above = regret > threshold + 1e-12
    n_e = regret.shape[1]
    # index of the last episode above (−1 if none), per run
    last = np.where(above.any(1), n_e - 1 - np.argmax(above[:, ::-1], axis=1), -1)
    return (last + 2).astype(float)


def asymptote(x: np.ndarray) -> np.ndarray:
    """(runs,) each run's mean over its last :func:`last_k` episodes."""
    x = np.asarray(x, dtype=float)
    return x[:, -last_k(x.shape[1]):].mean(1)


def summary(per_run: np.ndarray, seed: int, *, median: bool = True) -> dict[str, Any]:
    """Mean and IQM over runs with 95 % percentile bootstrap CIs (seeded), and the median
    (with ``median``; the suite's ``suite.json`` entries have none).
    """
    per_run = np.asarray(per_run, dtype=float)
    out: dict[str, Any] = {"mean": float(per_run.mean()),
                           "ci95": list(stats.bootstrap_ci(per_run, "mean", seed)),
                           "iqm": float(stats.iqm(per_run)),
                           "iqm_ci95": list(stats.bootstrap_ci(per_run, "iqm", seed))}
    if median:
        out["median"] = float(np.median(per_run))
    return out


def agent_metrics(runs: Mapping[str, np.ndarray], blind: np.ndarray | None, seed: int,
                  threshold: float = LEARNED, drift: int | None = None) -> dict[str, Any]:
    """The statistics of one agent on one track, from its per-(run, episode) arrays.

    Args:
        runs: ``reward`` and ``truncated`` and, where recorded, the
            :data:`~hri_bench.run.runner.TASK_METRICS` (the belief ones left out, or all NaN,
            for an agent without a belief); each (runs, episodes), or (runs,) per-run means
            for the task metrics.
        blind: Blind's exact expected reward per (run, episode), or None where regret is
            not reported.
        seed: Seeds every bootstrap.
        threshold: :data:`LEARNED`.
        drift: The episodes after which the human switches (None: no drift).

    Returns:
        ``score`` (each run's mean episode reward: the cross-track score), ``asymptote_reward``,
        and where regret is reported ``regret``, ``asymptote_regret``, ``learning_episodes``
        (with ``learned_rate``, the share of runs that settled) and, with a drift,
        ``readapt_episodes`` (episodes after the switch until the regret stays within the
        threshold; the episodes left + 1: never); the belief metrics where the
        agent has a belief, the effort metrics: each a :func:`summary`; ``truncation_rate``.
        Absent entries are None.
    """
    reward = np.asarray(runs["reward"], dtype=float)
    out: dict[str, Any] = {"score": summary(reward.mean(1), seed),
                           "asymptote_reward": summary(asymptote(reward), seed),
                           "truncation_rate": float(np.asarray(runs["truncated"]).mean())}
    if blind is not None:
        regret = np.asarray(blind, dtype=float) - reward
        learned = learning_episodes(regret, threshold)
        out.update(regret=summary(regret.mean(1), seed),
                   asymptote_regret=summary(asymptote(regret), seed),
                   learning_episodes=summary(learned, seed),
                   learned_rate=float(np.mean(learned <= regret.shape[1])))
        after = regret[:, drift:] if drift is not None and 0 < drift < regret.shape[1] else None
        out["readapt_episodes"] = (None if after is None else
                                   summary(learning_episodes(after, threshold), seed))
    else:
        out.update(regret=None, asymptote_regret=None, learning_episodes=None,
                   learned_rate=None, readapt_episodes=None)
    for k in TASK_METRICS:
        x = runs.get(k)
        if x is None or np.all(np.isnan(np.asarray(x, dtype=float))):
            out[k] = None
        else:
            x = np.asarray(x, dtype=float)
            out[k] = summary(x.mean(1) if x.ndim == 2 else x, seed)
    return out
