"""Batched simulation of many independent runs of (robot agent, scripted human) episodes.

One *run* is a sequence of episodes between one agent and one scripted human; the agent
learns across the run's episodes. :func:`simulate` advances a batch of runs in lockstep
with array operations (the graph backend). Every random draw of run ``r`` comes from
generators seeded by ``(seed, r)`` alone, so a run's numbers do not depend on which batch,
process or machine simulated it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from hri_envs.task.graph import WAIT, TaskGraph
from hri_envs.task.humans import ScriptedHuman
from hri_envs.task.protocol import BatchAgent, Trace

__all__ = ["TABLE2", "EpisodeMetrics", "Schedule", "make_schedule", "simulate"]

#: The user study's episodes (paper Table 2): (start, goal, turns back halfway).
TABLE2: tuple[tuple[str, str, bool], ...] = (
    ("B", "A", False), ("A", "B", False), ("B", "A", False), ("A", "C", False),
    ("C", "B", False), ("B", "C", False), ("C", "A", False), ("A", "B", True),
    ("A", "B", False),
)


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
    human: ScriptedHuman | None = None,
) -> Schedule:
    """Episode schedule: ``"random"`` (start and goal ≠ start drawn per episode) or
    ``"table2"`` (paper Table 2, cycled if more episodes are asked for).

    Random schedules draw from ``(seed, run, 2)`` only; turning back is drawn with the
    human's ``turn_back`` probability.
    """
    n_b, n_k = len(runs), graph.n_intentions
    if kind == "table2":
        names = graph.support_names
        rows = [TABLE2[e % len(TABLE2)] for e in range(episodes)]
        start = np.array([[names.index(r[0]) for r in rows]] * n_b, dtype=np.int64)
        goal = np.array([[names.index(r[1]) for r in rows]] * n_b, dtype=np.int64)
        turn = np.array([[r[2] for r in rows]] * n_b, dtype=bool)
        return Schedule(start.reshape(n_b, episodes), goal.reshape(n_b, episodes),
                        turn.reshape(n_b, episodes))
    if kind != "random":
        raise ValueError(f"unknown schedule {kind!r}; allowed: 'random', 'table2'")
    start = np.zeros((n_b, episodes), dtype=np.int64)
    goal = np.zeros((n_b, episodes), dtype=np.int64)
    turn = np.zeros((n_b, episodes), dtype=bool)
    p_turn = 0.0 if human is None else human.turn_back
    for i, r in enumerate(runs):
        rng = np.random.default_rng([int(seed), int(r), 2])
        start[i] = rng.integers(0, n_k, episodes)
        goal[i] = (start[i] + rng.integers(1, n_k, episodes)) % n_k
        turn[i] = rng.random(episodes) < p_turn
    return Schedule(start, goal, turn)


@dataclass
class EpisodeMetrics:
    """Per-run, per-episode results, each (B, E).

    Attributes:
        reward: Summed robot cooperation reward.
        correct: Fraction of steps where the robot acted and got the effect it acted towards.
        passive: Fraction of steps where the robot waited.
        wrong: Fraction of steps where the robot acted otherwise.
        steps: Episode length.
        truncated: The episode hit the step limit.
    """

    reward: np.ndarray
    correct: np.ndarray
    passive: np.ndarray
    wrong: np.ndarray
    steps: np.ndarray
    truncated: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)


def simulate(
    graph: TaskGraph,
    agent: BatchAgent,
    human: ScriptedHuman,
    schedule: Schedule,
    *,
    runs: Sequence[int] | np.ndarray,
    seed: int,
    r0: float,
    max_steps: int = 100,
    after_episode: Callable[[int, BatchAgent], None] | None = None,
) -> EpisodeMetrics:
    """Simulate ``schedule`` for a batch of runs with one agent.

    Args:
        graph: The task graph.
        agent: A batched agent with ``n_runs == len(runs)``.
        human: The scripted human (one per run, identical behaviour, own random stream).
        schedule: From :func:`make_schedule`.
        runs: Run indices (seed the human's random stream with ``(seed, run, 1)``).
        seed: Base seed.
        r0: Reward for the robot waiting while the human acts (for the metrics).
        max_steps: Step limit per episode (the episode is truncated there).
        after_episode: Called as ``after_episode(e, agent)`` after each learning update.

    Returns:
        The episode metrics.
    """
    n_b, n_e = schedule.start.shape
    if agent.n_runs != n_b or len(runs) != n_b:
        raise ValueError(f"agent has {agent.n_runs} runs, schedule {n_b}, runs {len(runs)}")
    rngs = [np.random.default_rng([int(seed), int(r), 1]) for r in runs]
    reward_table = graph.reward(r0)
    privileged = bool(getattr(agent, "privileged", False))
    rows = np.arange(n_b)
    out = {k: np.zeros((n_b, n_e)) for k in ("reward", "correct", "passive", "wrong", "steps")}
    truncated = np.zeros((n_b, n_e), dtype=bool)
    states_buf = np.zeros((n_b, max_steps + 1), dtype=np.int64)
    robot_buf = np.zeros((n_b, max_steps), dtype=np.int64)
    human_buf = np.zeros((n_b, max_steps), dtype=np.int64)
    for e in range(n_e):
        start = schedule.start[:, e].copy()
        goal = schedule.goal[:, e].copy()
        turn = schedule.turn_back[:, e].copy()
        turn_state = human.turn_state[start, goal]
        s = 4 * start  # resting on the start support, nobody holds it
        lifted = np.zeros(n_b, dtype=bool)
        active = np.ones(n_b, dtype=bool)
        length = np.full(n_b, max_steps)
        last_h = np.full(n_b, WAIT)
        agent.begin_episode(start)
        states_buf[:, 0] = s
        for t in range(max_steps):
            turning = active & turn & (s == turn_state)
            goal = np.where(turning, start, goal)
            turn &= ~turning
            obs = {"state": s, "start": start, "last_human_action": last_h,
                   "action_mask": graph.valid[s].astype(np.int8)}
            if privileged:
                obs["intention"] = goal
            a_r = agent.act(obs, active)
            u = np.zeros((2, n_b))
            for i in np.flatnonzero(active):
                u[:, i] = rngs[i].random(2)
            a_h = human.act_from_uniforms(s, start, goal, u[0], u[1])
            a_r = np.where(active, a_r, WAIT)
            a_h = np.where(active, a_h, WAIT)
            s_next = graph.next_state[s, a_r, a_h]
            w = active.astype(float)
            out["reward"][:, e] += w * reward_table[s, a_r, a_h]
            effective = graph.robot_effective[s, a_r, a_h]
            out["correct"][:, e] += w * effective
            out["passive"][:, e] += w * (a_r == WAIT)
            out["wrong"][:, e] += w * ((a_r != WAIT) & ~effective)
            agent.observe(s, a_r, a_h, s_next, active)
            robot_buf[:, t], human_buf[:, t] = a_r, a_h
            s = np.where(active, s_next, s)
            states_buf[:, t + 1] = s
            last_h = a_h
            lifted |= graph.left_start(s, start)
            done = active & graph.episode_over(s, start, lifted)
            length[done] = t + 1
            active &= ~done
            if not active.any():
                break
        truncated[:, e] = active
        out["steps"][:, e] = length
        for k in ("correct", "passive", "wrong"):
            out[k][:, e] /= length
        ended = graph.support[states_buf[rows, length]]
        intentions = np.where(active, -1, ended)  # a truncated episode reveals nothing
        traces = [Trace(states_buf[i, : length[i] + 1].copy(), robot_buf[i, : length[i]].copy(),
                        human_buf[i, : length[i]].copy()) for i in range(n_b)]
        agent.end_episode(traces, intentions)
        if after_episode is not None:
            after_episode(e, agent)
    return EpisodeMetrics(out["reward"], out["correct"], out["passive"], out["wrong"],
                          out["steps"], truncated)
