"""``hri-bench speed``: throughput of the envs and the Learner on this machine."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from agents.learner import Learner
from hri_envs.bench.study import StudyConfig, graph_for, run_study
from hri_envs.task.humans import HANGER_PREFERENCES
from hri_envs.task.protocol import Trace

__all__ = ["HANGER_STUDY_PREFERENCES", "hanger_study_s", "learner_update_ms", "measure"]

#: Nine hanger preferences for the paper's simulation study (it does not list its nine):
#: the most frequent one and every fourth of the others.
HANGER_STUDY_PREFERENCES: tuple[str, ...] = (
    "down-over-rotate/over-rotate-up",
    *[p for p in HANGER_PREFERENCES if p != "down-over-rotate/over-rotate-up"][::4][:8],
)


def learner_update_ms(scenario: str = "wheel", repeats: int = 200) -> float:
    """Milliseconds for one Learner update (loop removal, IRL step, π̂_H and robot Q)."""
    graph = graph_for(scenario)
    learner = Learner(graph, 1)
    w = graph.waypoint_state
    # A typical straight episode from the rack to stand B.
    states = np.array([0, 1, 3, w(0, 3, 1), w(1, 3, 1), w(1, 1, 1), w(1, 1, 0), 7, 4])
    trace = Trace(states, np.zeros(8, np.int64), np.zeros(8, np.int64))
    learner.end_episode([trace], np.array([1]))  # warm-up
    t0 = time.perf_counter()
    for _ in range(repeats):
        learner.end_episode([trace], np.array([1]))
    return (time.perf_counter() - t0) / repeats * 1e3


def hanger_study_s(runs: int = 100, episodes: int = 8, jobs: int = 1) -> float:
    """Seconds for the paper's hanger simulation study: 9 preferences × ``runs`` × ``episodes``,
    Learner only (graph backend).
    """
    t0 = time.perf_counter()
    for i, pref in enumerate(HANGER_STUDY_PREFERENCES):
        cfg = StudyConfig("hanger", agents=("learner",), runs=runs, episodes=episodes,
                          preference=pref, seed=i, jobs=jobs,
                          executor="process" if jobs > 1 else "serial")
        run_study(cfg)
    return time.perf_counter() - t0


def measure(jobs: int = 1) -> dict[str, Any]:
    """All speed figures as a dict (keys: docs/benchmark.md, 'Other subcommands')."""
    from hri_envs.envs.speed import parallel_env_steps_per_s, vector_env_steps_per_s

    return {
        "parallel_env_steps_per_s": round(parallel_env_steps_per_s().steps_per_s, 1),
        "vector_env_steps_per_s": round(vector_env_steps_per_s(num_envs=1024).steps_per_s, 1),
        "learner_update_ms": round(learner_update_ms("wheel"), 3),
        "hanger_study_s": round(hanger_study_s(jobs=jobs), 3),
    }
