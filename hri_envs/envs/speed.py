"""Throughput of the environments, for ``hri-bench speed`` and ``benchmarks/env_speed.py``.

Both measurements drive the envs with random *valid* actions drawn before the clock starts
(sampling inside the loop would dominate the cost of a graph step), and report the best of
a few repeats, the usual way to time code on a shared machine. The clock is wall time by
default; ``clock=time.thread_time`` counts the CPU time of the measuring thread only, which
other jobs on a loaded machine disturb much less (on an idle machine the two agree).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.task.graph import TaskGraph

__all__ = ["SpeedResult", "parallel_env_steps_per_s", "valid_choices", "vector_env_steps_per_s"]


class SpeedResult(NamedTuple):
    """A throughput measurement."""

    steps_per_s: float
    steps: int
    seconds: float


def valid_choices(graph: TaskGraph, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, S) random valid action per state of ``graph``: column j holds one draw for every
    state (the speed workloads' robot and human; :mod:`hri_envs.jax.speed` draws the same
    table).
    """
    valid = graph.valid  # (S, A)
    u = rng.random((n,) + valid.shape) * valid  # (n, S, A); invalid actions score 0
    return np.argmax(u, axis=-1)  # (n, S)


def parallel_env_steps_per_s(
    scenario: str = "hanger",
    steps: int = 50_000,
    repeats: int = 3,
    seed: int = 0,
    clock: Callable[[], float] = time.perf_counter,
) -> SpeedResult:
    """Joint steps per second of the PettingZoo parallel env (random valid actions).

    Args:
        scenario: "hanger" or "wheel".
        steps: Joint steps per repeat (resets when an episode ends are included).
        repeats: Timed repeats; the fastest counts.
        seed: Seed of the env and of the action table.
        clock: Seconds, as ``time.perf_counter`` (wall) or ``time.thread_time`` (CPU).
    """
    env = CooperationParallelEnv(scenario)
    rng = np.random.default_rng(seed)
    # A fixed table of random valid actions per (draw, state), cycled through.
    human = valid_choices(env.graph, rng, 256).tolist()
    robot = valid_choices(env.graph, rng, 256).tolist()
    best = np.inf
    for _ in range(repeats):
        obs, _ = env.reset(seed=seed)
        s = obs["robot"]["state"]
        t0 = clock()
        for i in range(steps):
            j = i & 255
            obs, _, term, trunc, _ = env.step({"human": human[j][s], "robot": robot[j][s]})
            if term["robot"] or trunc["robot"]:
                obs, _ = env.reset()
            s = obs["robot"]["state"]
        best = min(best, clock() - t0)
    return SpeedResult(steps / best, steps, float(best))


def vector_env_steps_per_s(
    num_envs: int = 1024,
    scenario: str = "hanger",
    steps: int = 1_000,
    repeats: int = 3,
    seed: int = 0,
    clock: Callable[[], float] = time.perf_counter,
) -> SpeedResult:
    """Env steps per second (num_envs x vector steps) of the numpy-batched robot env.

    The robot takes a random valid action in each env (looked up from a precomputed table
    by the current state); the scripted human follows its default preference.

    Args:
        num_envs: Episodes stepped together.
        scenario: "hanger" or "wheel".
        steps: Vector steps per repeat.
        repeats: Timed repeats; the fastest counts.
        seed: Seed of the env and of the action table.
        clock: Seconds, as ``time.perf_counter`` (wall) or ``time.thread_time`` (CPU).
    """
    env = RobotVectorEnv(num_envs, scenario)
    rng = np.random.default_rng(seed)
    n_s = env.graph.n_states
    table = valid_choices(env.graph, rng, 64).reshape(-1)  # (64 S,)
    offsets = rng.integers(64, size=(64, num_envs)) * n_s  # (64, N)
    best = np.inf
    for _ in range(repeats):
        obs, _ = env.reset(seed=seed)
        t0 = clock()
        for i in range(steps):
            actions = np.take(table, offsets[i & 63] + obs["state"])
            obs, *_ = env.step(actions)
        best = min(best, clock() - t0)
    return SpeedResult(steps * num_envs / best, steps * num_envs, float(best))
