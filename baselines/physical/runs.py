"""Runs of physical robots on seeded episodes of the continuous v1 envs, as rows.

A *run* is one agent with one human for a few episodes (an agent that learns, learns
across them); episode ``i`` of every run is reset with seed ``i``, so every agent meets
the same start, goal, layout and human in it (paired comparisons). Each episode becomes
one row of figures (:data:`ROW_FIELDS`, from the env's ``info["episode"]``, and for a
robot with a belief over goals, when it first put :data:`INFERRED` on the goal revealed
at the end), which
``benchmarks/physical_baselines.py`` writes to a CSV and summarises, and
``benchmarks/tune_physical_baselines.py`` scores.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterable
from typing import Any

import gymnasium as gym
import numpy as np

import hri_envs  # noqa: F401  (registers the ids)
from agents.physical import PhysicalAgent, PhysicalEpisode, outcome_of
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.intention import HUMAN_PRESETS
from hri_envs.registration import continuous_id
from hri_envs.task.scenarios import ScenarioSpec

__all__ = ["HUMANS", "INFERRED", "ROW_FIELDS", "episode_row", "inferred_s", "make_env",
           "run_episode", "run_seeds"]

#: The named humans of the continuous envs (``human={"preset": name}``).
HUMANS: tuple[str, ...] = tuple(HUMAN_PRESETS)

#: The columns of an episode's row.
ROW_FIELDS: tuple[str, ...] = (
    "agent", "scenario", "human", "population", "run", "seed", "outcome", "placed",
    "reached_intention", "fault", "return", "effort", "effort_per_progress", "peak_force",
    "rms_force", "rms_jerk", "time_s", "time_to_place_s", "linear_impulse",
    "angular_impulse", "disagreement", "stall_s", "progress", "inferred_s", "steps",
    "wall_s")

#: A robot has inferred the goal once its belief in it reaches this (``inferred_s``).
INFERRED = 0.9


def make_env(spec: ScenarioSpec, human: str = "default", population: str | None = None,
             max_time_s: float | None = None) -> gym.Env:
    """The scenario ``spec``'s v1 continuous env with the named human (or a population's).

    Raises:
        ConfigError: An unknown human (the message lists the names).
    """
    if human not in HUMANS:
        raise ConfigError(f"unknown human {human!r}; allowed: {', '.join(HUMANS)}",
                          field="human")
    kwargs: dict[str, Any] = {}
    if human != "default":
        kwargs["human"] = {"preset": human}
    if population is not None:
        kwargs["population"] = population
    if max_time_s is not None:
        kwargs["max_time_s"] = max_time_s
    env_id = continuous_id(str(spec.continuous_id), 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return gym.make(env_id, **kwargs)


def episode_row(metrics: dict[str, Any], **keys: Any) -> dict[str, Any]:
    """One episode's row: ``keys`` (agent, scenario, ...) and the figures of its
    ``info["episode"]`` (``metrics``) named in :data:`ROW_FIELDS`.
    """
    row = {k: None for k in ROW_FIELDS}
    row.update(keys)
    row.update({k: metrics[k] for k in ROW_FIELDS if k in metrics and k not in keys})
    return row


def run_episode(env: gym.Env, robot: PhysicalAgent, seed: int
                ) -> tuple[PhysicalEpisode, np.ndarray | None]:
    """One episode, as :func:`agents.physical.run_physical_episode` runs it, and the
    robot's belief after each step ((steps, K), None if it has none).
    """
    base = env.unwrapped
    obs, _ = env.reset(seed=seed)
    if robot.privileged:
        robot.attach(base)
    task = base.robot_task()  # type: ignore[attr-defined]
    robot.begin_episode(task)
    total, steps, beliefs = 0.0, 0, []
    while True:
        obs, reward, term, trunc, info = env.step(robot.act(obs))
        total += float(reward)
        steps += 1
        belief = robot.belief()
        if belief is not None:
            beliefs.append(np.array(belief, dtype=float))
        if term or trunc:
            break
    outcome = outcome_of(task, info, trunc and not term)
    robot.end_episode(outcome)
    return (PhysicalEpisode(outcome, total, steps, info),
            np.array(beliefs) if beliefs else None)


def inferred_s(beliefs: np.ndarray | None, goal: int, dt: float,
               threshold: float = INFERRED) -> float | None:
    """When [s] the belief in the revealed ``goal`` first reached ``threshold`` (None: it
    never did, or the robot has no belief).
    """
    if beliefs is None or goal < 0:
        return None
    hits = np.flatnonzero(beliefs[:, goal] >= threshold)
    return float((hits[0] + 1) * dt) if len(hits) else None


def run_seeds(robot: PhysicalAgent, env: gym.Env, seeds: Iterable[int], **keys: Any
              ) -> list[dict[str, Any]]:
    """The rows of one run: ``robot`` on ``env`` for the episodes ``seeds`` in order
    (``keys``: the row's agent, scenario, human, population and run).
    """
    rows = []
    dt = float(env.unwrapped.sim.dt_step)  # type: ignore[attr-defined]
    for seed in seeds:
        t0 = time.perf_counter()
        episode, beliefs = run_episode(env, robot, int(seed))
        metrics = dict(episode.outcome.metrics)
        rows.append(episode_row(
            metrics, seed=int(seed), steps=episode.steps, wall_s=time.perf_counter() - t0,
            inferred_s=inferred_s(beliefs, int(metrics.get("intention", -1)), dt), **keys))
    return rows
