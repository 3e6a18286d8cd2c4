"""What the benchmark's simulation loop (:mod:`hri_bench.run.runner`) is given and gives: a
batch's schedule of episodes (:class:`Schedule`, :func:`make_schedule`), each run's human
generators (:func:`human_streams`), and an episode's metrics (:data:`TASK_METRICS`,
:class:`EpisodeMetrics`, :class:`EpisodeResult`). :mod:`hri_bench.run.runner` re-exports
them; docs/results.md, "Metrics", defines the metrics.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from agents.protocol import Trace
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of


@dataclass(frozen=True)
class Schedule:
    """Start support, intended goal and turning back, per run and episode.

    Attributes:
        start: (B, E) int.
        goal: (B, E) int, the intention at the start of the episode.
        turn_back: (B, E) bool, the human returns to the start halfway.
    """

    start: np.ndarray
    goal: np.ndarray
    turn_back: np.ndarray


def make_schedule(
    graph: TaskGraph,
    kind: str,
    runs: Sequence[int] | np.ndarray,
    episodes: int,
    seed: int,
    human: ScriptedHuman | BatchHuman | None = None,
) -> Schedule:
    """Episode schedule: ``"random"`` (start and goal ≠ start drawn per episode) or one of
    the scenario's fixed schedules (the hanger's ``"table2"``, paper Table 2), cycled if
    more episodes are asked for.

    Random schedules draw from ``(seed, run, 2)`` only; turning back is drawn with each
    run's human's ``turn_back`` probability.
    """
    n_b, n_k = len(runs), graph.n_intentions
    fixed = spec_of(graph).schedules
    if kind in fixed:
        names = graph.support_names
        table = fixed[kind]
        rows = [table[e % len(table)] for e in range(episodes)]
        start = np.array([[names.index(r[0]) for r in rows]] * n_b, dtype=np.int64)
        goal = np.array([[names.index(r[1]) for r in rows]] * n_b, dtype=np.int64)
        turn = np.array([[r[2] for r in rows]] * n_b, dtype=bool)
        return Schedule(start.reshape(n_b, episodes), goal.reshape(n_b, episodes),
                        turn.reshape(n_b, episodes))
    if kind != "random":
        raise ConfigError(f"unknown schedule {kind!r} for the {graph.name}; allowed: "
                          f"{', '.join(['random', *fixed])}", field="schedule")
    start = np.zeros((n_b, episodes), dtype=np.int64)
    goal = np.zeros((n_b, episodes), dtype=np.int64)
    turn = np.zeros((n_b, episodes), dtype=bool)
    p_turn = np.zeros(n_b)
    if human is not None:
        p_turn[:] = human.turn_back
    for i, r in enumerate(runs):
        rng = np.random.default_rng([int(seed), int(r), 2])
        start[i] = rng.integers(0, n_k, episodes)
        goal[i] = (start[i] + rng.integers(1, n_k, episodes)) % n_k
        turn[i] = rng.random(episodes) < p_turn[i]
    return Schedule(start, goal, turn)


#: Per-episode metrics of the task itself (docs/results.md, "Metrics"): ``map_steps`` the
#: robot's decisions before its most likely intention is right for good (its belief's
#: unique maximum on the current ι at every later decision; the episode's length when it
#: is wrong at the last one), ``log_loss`` and ``brier`` the mean over its decisions of
#: -ln b(ι) and Σ_k (b(k) - [k = ι])² (these three NaN for agents exposing no belief,
#: :func:`agents.protocol.read_belief`); human effort: ``counteract`` the human's motions
#: against a different robot motion, ``human_idle`` the human's waits in which nothing
#: moved, ``human_alone`` the human's actions while the robot waited (counts per episode).
TASK_METRICS: tuple[str, ...] = ("map_steps", "log_loss", "brier", "counteract", "human_idle",
                                 "human_alone")


#: The belief metrics of :data:`TASK_METRICS` (NaN for agents without a belief).
BELIEF_METRICS: tuple[str, ...] = TASK_METRICS[:3]


#: Probabilities are clipped here in the log-loss, which stays finite (≤ 34.5).
LOG_LOSS_FLOOR = 1e-15


@dataclass
class EpisodeMetrics:
    """Per-run, per-episode results, each (B, E) (or (B,) for one episode of a batch).

    Attributes:
        reward: Summed robot cooperation reward.
        correct: Fraction of steps where the robot acted and got the effect it acted towards.
        passive: Fraction of steps where the robot waited.
        wrong: Fraction of steps where the robot acted otherwise.
        steps: Episode length.
        truncated: The episode did not end (step limit or a backend fault).
        extras: The backend's per-episode figures (the physics: impulses, duration, ...).
        task: The :data:`TASK_METRICS`.
    """

    reward: np.ndarray
    correct: np.ndarray
    passive: np.ndarray
    wrong: np.ndarray
    steps: np.ndarray
    truncated: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    task: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class EpisodeResult:
    """One episode of every run of a batch.

    Attributes:
        episode: The episode's index in the schedule.
        metrics: Its :class:`EpisodeMetrics`, each array (B,).
        traces: What the robot saw, per run.
        intentions: Where each episode ended, -1 where truncated (nothing revealed).
    """

    episode: int
    metrics: EpisodeMetrics
    traces: list[Trace]
    intentions: np.ndarray


def human_streams(seed: int, runs: Sequence[int] | np.ndarray) -> list[np.random.Generator]:
    """The human's generator of each run: seeded by ``(seed, run, 1)`` only."""
    return [np.random.default_rng([int(seed), int(r), 1]) for r in runs]
