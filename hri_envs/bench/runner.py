"""The benchmark's one simulation loop: many independent runs of (robot agent, human).

One *run* is a sequence of episodes between one agent and one human; the agent learns
across the run's episodes. :func:`run_episodes` advances a batch of runs with array
operations on any backend (:class:`~hri_envs.envs.backends.BatchBackend`: the graph moves
every run in lockstep, the physics one run at a time); :func:`simulate` collects its
metrics, and ``hri-bench play`` drives the same loop with you as the human. The episode's
rules (start state, lifting, turning back, end, reward, decisions) are those of
:mod:`hri_envs.task.episode`. Every random draw of run ``r`` comes from generators seeded by
``(seed, r)`` alone, so a run's numbers do not depend on which batch, process or machine
simulated it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from hri_envs.envs.backends import BatchBackend, batch_backend
from hri_envs.errors import ActionError, ConfigError
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import EpisodeBatch, EpisodeRules, classify, step_reward
from hri_envs.task.graph import TaskGraph
from hri_envs.task.humans import ScriptedHuman
from hri_envs.task.protocol import BatchAgent, Trace

__all__ = [
    "TABLE2",
    "EpisodeMetrics",
    "EpisodeResult",
    "HumanPolicy",
    "Schedule",
    "ScriptedHumans",
    "make_schedule",
    "run_episodes",
    "simulate",
]

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
    human: ScriptedHuman | ScriptedHumans | None = None,
) -> Schedule:
    """Episode schedule: ``"random"`` (start and goal ≠ start drawn per episode) or
    ``"table2"`` (paper Table 2, cycled if more episodes are asked for).

    Random schedules draw from ``(seed, run, 2)`` only; turning back is drawn with the
    human's ``turn_back`` probability (each run's own for :class:`ScriptedHumans`).
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
        raise ConfigError(f"unknown schedule {kind!r}; allowed: 'random', 'table2'",
                          field="schedule")
    start = np.zeros((n_b, episodes), dtype=np.int64)
    goal = np.zeros((n_b, episodes), dtype=np.int64)
    turn = np.zeros((n_b, episodes), dtype=bool)
    p_turn = np.zeros(n_b)
    if isinstance(human, ScriptedHumans):
        p_turn[:] = human.turn_back_rates()
    elif human is not None:
        p_turn[:] = human.turn_back
    for i, r in enumerate(runs):
        rng = np.random.default_rng([int(seed), int(r), 2])
        start[i] = rng.integers(0, n_k, episodes)
        goal[i] = (start[i] + rng.integers(1, n_k, episodes)) % n_k
        turn[i] = rng.random(episodes) < p_turn[i]
    return Schedule(start, goal, turn)


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
    """

    reward: np.ndarray
    correct: np.ndarray
    passive: np.ndarray
    wrong: np.ndarray
    steps: np.ndarray
    truncated: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)


class HumanPolicy(Protocol):
    """The human side of :func:`run_episodes`: the human's actions for a batch of runs.

    Called once per step after the robot has chosen (a person at a terminal sees the
    robot's choice first); only the ``active`` rows matter and only they may consume
    randomness. Returns (B,) int actions.
    """

    def __call__(self, state: np.ndarray, start: np.ndarray, intention: np.ndarray,
                 robot_action: np.ndarray, active: np.ndarray) -> np.ndarray:
        """(B,) the human's actions in ``state`` given the robot's ``robot_action``."""
        ...


class ScriptedHumans:
    """Scripted humans for a batch of runs, each run with its own random stream.

    ``human`` is one :class:`~hri_envs.task.humans.ScriptedHuman` shared by every run (the
    default), or per run a sequence of humans per episode (a population's draw, a drifting
    human; a sequence shorter than the episodes repeats its last human). Run ``r`` draws
    from a generator seeded by ``(seed, r, 1)``, two uniforms per step it is active in
    (passivity, then the choice of action), whatever its human.
    """

    def __init__(self, human: ScriptedHuman | Sequence[Sequence[ScriptedHuman]],
                 runs: Sequence[int] | np.ndarray, seed: int) -> None:
        self.rngs = [np.random.default_rng([int(seed), int(r), 1]) for r in runs]
        self.per_run: list[list[ScriptedHuman]] | None = None
        if isinstance(human, ScriptedHuman):
            self.human = human
            self.current = [human] * len(self.rngs)
        else:
            self.per_run = [list(seq) for seq in human]
            if len(self.per_run) != len(self.rngs) or not all(self.per_run):
                raise ConfigError(f"give a non-empty sequence of humans for each of the "
                                  f"{len(self.rngs)} runs, got {len(self.per_run)}",
                                  field="human")
            self.human = self.per_run[0][0]
            self.begin_episode(0)

    def turn_back_rates(self) -> np.ndarray:
        """(B,) each run's turning-back probability (of its first episode's human)."""
        return np.array([h.turn_back for h in self.current])

    def begin_episode(self, episode: int) -> np.ndarray | None:
        """Select each run's human for ``episode``; (B, K, K) turn states, None if shared."""
        if self.per_run is None:
            return None
        current = [seq[min(episode, len(seq) - 1)] for seq in self.per_run]
        if episode > 0 and all(a is b for a, b in zip(current, self.current, strict=True)):
            return self._turn_states  # nobody's human changed (no drift now): keep the tables
        self.current = current
        self._greedy = np.stack([h.preferred_action(*self._grid) for h in self.current])
        self._cum = np.stack([np.cumsum(h.policy, axis=-1) for h in self.current])
        self._stochastic = np.array([not h.deterministic for h in self.current])
        self._passive = np.array([h.passive for h in self.current])
        self._turn_states: np.ndarray = np.stack([h.turn_state for h in self.current])
        return self._turn_states

    @property
    def _grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        g = self.human.graph
        k = np.arange(g.n_intentions)
        return np.arange(g.n_states)[None, None, :], k[:, None, None], k[None, :, None]

    def preferred_action(self, state: np.ndarray, start: np.ndarray, goal: np.ndarray
                         ) -> np.ndarray:
        """(B,) each run's current human's most likely action (for the Oracle)."""
        if self.per_run is None:
            return self.human.preferred_action(state, start, goal)
        state, start, goal = np.broadcast_arrays(state, start, goal)
        return self._greedy[np.arange(len(state)), start, goal, state]  # type: ignore[no-any-return]

    def __call__(self, state: np.ndarray, start: np.ndarray, intention: np.ndarray,
                 robot_action: np.ndarray, active: np.ndarray) -> np.ndarray:
        """The scripted humans' actions (the robot's action does not matter to them)."""
        u = np.zeros((2, len(state)))
        for i in np.flatnonzero(active):
            u[:, i] = self.rngs[i].random(2)
        if self.per_run is None:
            return self.human.act_from_uniforms(state, start, intention, u[0], u[1])
        # Each run's own table, the same inverse-CDF sampling as ScriptedHuman.
        rows = np.arange(len(state))
        actions = self._greedy[rows, start, intention, state]
        if self._stochastic.any():
            cum = self._cum[rows, start, intention, state]  # (B, A)
            sampled = np.minimum((u[1][:, None] >= cum).sum(axis=-1), cum.shape[-1] - 1)
            actions = np.where(self._stochastic, sampled, actions)
        return np.where(u[0] < self._passive, WAIT, actions)  # type: ignore[no-any-return]


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


def run_episodes(
    graph: TaskGraph,
    agent: BatchAgent,
    human: HumanPolicy,
    schedule: Schedule,
    backend: BatchBackend,
    *,
    r0: float,
    turn_state: np.ndarray | None = None,
    max_steps: int = 100,
    run_ids: Sequence[int] | np.ndarray | None = None,
    reward: str = "paper",
) -> Iterator[EpisodeResult]:
    """Play ``schedule`` for a batch of runs; yields each episode after the agent learned.

    Args:
        graph: The task graph.
        agent: A batched agent with ``n_runs`` = the schedule's runs.
        human: The human's actions (e.g. :class:`ScriptedHumans`).
        schedule: From :func:`make_schedule`; its ``goal`` is the intention at the start.
        backend: Moves the runs (the graph, or a simulator).
        r0: Reward for the robot waiting while the human acts.
        turn_state: (K, K) where a turning-back human turns (see
            :func:`hri_envs.task.episode.turn_back`); None: nobody turns back. A human with
            a ``begin_episode(e)`` method (:class:`ScriptedHumans`) that returns (B, K, K)
            per-run turn states replaces it at the start of each episode.
        max_steps: Step limit per episode (the episode is truncated there).
        reward: The reward variant (:data:`hri_envs.task.episode.REWARDS`).
        run_ids: The runs' indices, for error messages (default 0 .. B-1).

    Raises:
        ActionError: The agent's ``act`` returned something other than one integer action
            in [0, A) per run (masked actions are allowed: they abort the step); the message
            names the run, the episode and the step.
    """
    n_b, n_e = schedule.start.shape
    if agent.n_runs != n_b:
        raise ConfigError(f"the agent has {agent.n_runs} runs, the schedule {n_b}",
                          field="runs")
    if turn_state is None:
        turn_state = np.full((graph.n_intentions,) * 2, -1)
    eps = EpisodeBatch(EpisodeRules(graph, r0), turn_state, n_b)
    privileged = bool(getattr(agent, "privileged", False))
    rows = np.arange(n_b)
    states = np.zeros((n_b, max_steps + 1), dtype=np.int64)
    robot_acts = np.zeros((n_b, max_steps), dtype=np.int64)
    human_seen = np.zeros((n_b, max_steps), dtype=np.int64)
    begin_humans = getattr(human, "begin_episode", None)
    for e in range(n_e):
        if begin_humans is not None and (per_run := begin_humans(e)) is not None:
            eps.turn_state = per_run  # (B, K, K): each run's human turns at its own point
        eps.begin(rows, schedule.start[:, e], schedule.goal[:, e], schedule.turn_back[:, e])
        agent.begin_episode(eps.start.copy())
        totals = {k: np.zeros(n_b) for k in ("reward", "correct", "passive", "wrong",
                                              *backend.extras)}
        over = np.zeros(n_b, dtype=bool)
        faulted = np.zeros(n_b, dtype=bool)
        states[:, 0] = eps.state
        for group in backend.groups():
            faulted[group] = backend.begin(group, eps.start[group])
            active = np.zeros(n_b, dtype=bool)
            active[group] = ~faulted[group]
            for t in range(max_steps):
                if not active.any():
                    break
                s = eps.state
                obs: dict[str, np.ndarray] = {
                    "state": s, "start": eps.start, "last_human_action": eps.last_human,
                    "action_mask": graph.valid[s].astype(np.int8)}
                if privileged:
                    obs["intention"] = eps.intention
                a_r = np.where(active, _checked(agent.act(obs, active), active, graph.n_actions,
                                                run_ids, e, t), WAIT)
                a_h = np.where(active, human(s, eps.start, eps.intention, a_r, active), WAIT)
                step = backend.transition(s, a_r, a_h, active)
                w = active.astype(float)
                failed = False if step.penalty is None else step.penalty
                totals["reward"] += w * step_reward(graph, s, a_r, a_h, step.next_state, r0,
                                                    reward=reward, start=eps.start,
                                                    lifted=eps.lifted, failed=failed)
                for key, judged in zip(("correct", "passive", "wrong"),
                                       classify(graph, s, a_r, a_h, step.next_state),
                                       strict=True):
                    totals[key] += w * judged
                for key, value in step.extras.items():
                    totals[key] += w * value
                agent.observe(s, a_r, step.human_seen, step.next_state, active)
                robot_acts[active, t] = a_r[active]
                human_seen[active, t] = step.human_seen[active]
                ended = eps.commit(step.next_state, step.human_seen, active)
                states[active, t + 1] = eps.state[active]
                over |= ended
                if step.fault is not None:
                    faulted |= active & step.fault & ~ended
                active &= ~(ended | faulted)
        steps = eps.steps.copy()
        truncated = ~over
        per_step = np.maximum(steps, 1)
        for key in ("correct", "passive", "wrong", *backend.step_means):
            totals[key] /= per_step
        intentions = np.where(truncated, -1, graph.support[states[rows, steps]])
        traces = [Trace(states[i, : steps[i] + 1].copy(), robot_acts[i, : steps[i]].copy(),
                        human_seen[i, : steps[i]].copy()) for i in range(n_b)]
        agent.end_episode(traces, intentions)
        metrics = EpisodeMetrics(totals["reward"], totals["correct"], totals["passive"],
                                 totals["wrong"], steps.astype(float), truncated,
                                 {k: totals[k] for k in backend.extras})
        yield EpisodeResult(e, metrics, traces, intentions)


def _checked(actions: object, active: np.ndarray, n_actions: int,
             run_ids: Sequence[int] | np.ndarray | None, episode: int, step: int) -> np.ndarray:
    """The agent's actions as an int array, or an :class:`ActionError` naming where."""
    arr = np.asarray(actions)
    n_b = active.shape[0]
    where = f"episode {episode + 1}, step {step + 1}"
    if arr.shape != (n_b,) or arr.dtype.kind not in "iu":
        raise ActionError(f"act() returned {arr.dtype} of shape {arr.shape} in {where}; "
                          f"expected one integer action per run, shape ({n_b},)")
    bad = active & ((arr < 0) | (arr >= n_actions))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        run = i if run_ids is None else int(run_ids[i])
        raise ActionError(f"act() returned action {arr[i]} for run {run} in {where}; "
                          f"actions are integers in [0, {n_actions})")
    return arr


def simulate(
    graph: TaskGraph,
    agent: BatchAgent,
    human: ScriptedHuman | ScriptedHumans,
    schedule: Schedule,
    *,
    runs: Sequence[int] | np.ndarray,
    seed: int,
    r0: float,
    max_steps: int = 100,
    after_episode: Callable[[int, BatchAgent], None] | None = None,
    backend: str = "graph",
    reward: str = "paper",
    physics: Mapping[str, Any] | None = None,
) -> EpisodeMetrics:
    """Simulate ``schedule`` for a batch of runs with one agent and a scripted human.

    Args:
        graph: The task graph.
        agent: A batched agent with ``n_runs == len(runs)``.
        human: The scripted human (one per run, identical behaviour, own random stream), or
            :class:`ScriptedHumans` built for these ``runs`` and ``seed`` (a human per run
            and episode).
        schedule: From :func:`make_schedule`.
        runs: Run indices (seed the human's random stream with ``(seed, run, 1)``).
        seed: Base seed.
        r0: Reward for the robot waiting while the human acts (for the metrics).
        max_steps: Step limit per episode (the episode is truncated there).
        after_episode: Called as ``after_episode(e, agent)`` after each learning update.
        backend: A registered backend (:mod:`hri_envs.envs.backends`): "graph" or "mujoco".
        reward: The reward variant (:data:`hri_envs.task.episode.REWARDS`).
        physics: Validated ``physics`` options of the backend (e.g. ``{"preset":
            "weak-human"}``); None or empty for its defaults.

    Returns:
        The episode metrics; ``extras`` holds the backend's per-episode figures (the
        physics: interaction impulses, simulated duration, agreement with the graph).
    """
    n_b, n_e = schedule.start.shape
    if len(runs) != n_b:
        raise ConfigError(f"the schedule has {n_b} runs, runs= names {len(runs)}", field="runs")
    sim = batch_backend(backend)(graph, runs, seed, physics=physics)
    keys = ("reward", "correct", "passive", "wrong", "steps")
    out = {k: np.zeros((n_b, n_e)) for k in keys}
    extras = {k: np.zeros((n_b, n_e)) for k in sim.extras}
    truncated = np.zeros((n_b, n_e), dtype=bool)
    humans = human if isinstance(human, ScriptedHumans) else ScriptedHumans(human, runs, seed)
    for res in run_episodes(graph, agent, humans, schedule, sim, r0=r0,
                            turn_state=humans.human.turn_state, max_steps=max_steps,
                            run_ids=runs, reward=reward):
        e, m = res.episode, res.metrics
        for k in keys:
            out[k][:, e] = getattr(m, k)
        for k, v in m.extras.items():
            extras[k][:, e] = v
        truncated[:, e] = m.truncated
        if after_episode is not None:
            after_episode(e, agent)
    return EpisodeMetrics(out["reward"], out["correct"], out["passive"], out["wrong"],
                          out["steps"], truncated, extras)
