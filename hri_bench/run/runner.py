"""The benchmark's one simulation loop: many independent runs of (robot agent, human).

One *run* is a sequence of episodes between one agent and one human; the agent learns
across the run's episodes. :func:`run_episodes` advances a batch of runs with array
operations on any backend (:class:`~hri_envs.envs.backends.BatchBackend`: the graph moves
every run in lockstep, the physics one run at a time); :func:`simulate` collects its
metrics, and ``hri-bench play`` drives the same loop with you as the human. The episode's
rules (start state, lifting, turning back, end, reward, decisions) are those of
:mod:`hri_envs.task.episode`. Every random draw of run ``r`` comes from generators seeded by
``(seed, r)`` alone, so a run's numbers do not depend on which batch, process or machine
simulated it. What the loop is given and gives (the schedule, the human generators, the
metrics) is :mod:`hri_bench.run.episodes`'s, re-exported here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.protocol import BatchAgent, Trace, read_belief
from hri_bench.run.episodes import (
    BELIEF_METRICS,
    LOG_LOSS_FLOOR,
    TASK_METRICS,
    EpisodeMetrics,
    EpisodeResult,
    Schedule,
    human_streams,
    make_schedule,
)
from hri_envs.envs.backends import BatchBackend, BatchStep, batch_backend
from hri_envs.errors import ActionError, ConfigError
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.tables import TableHumans
from hri_envs.task.actions import TAKE_OFF, WAIT
from hri_envs.task.episode import EpisodeBatch, EpisodeRules, classify
from hri_envs.task.graph import TaskGraph

__all__ = [
    "BELIEF_METRICS",
    "TASK_METRICS",
    "EpisodeMetrics",
    "EpisodeResult",
    "Schedule",
    "human_streams",
    "make_schedule",
    "run_episodes",
    "simulate",
]


def run_episodes(
    graph: TaskGraph,
    agent: BatchAgent,
    human: BatchHuman,
    schedule: Schedule,
    backend: BatchBackend,
    *,
    r0: float,
    max_steps: int = 100,
    run_ids: Sequence[int] | np.ndarray | None = None,
    reward: str = "paper",
) -> Iterator[EpisodeResult]:
    """Play ``schedule`` for a batch of runs; yields each episode after the agent learned.

    Args:
        graph: The task graph.
        agent: A batched agent with ``n_runs`` = the schedule's runs.
        human: The human, ``n_runs`` = the schedule's runs (the human protocol,
            :mod:`hri_envs.humans.protocol`; e.g. :class:`~hri_envs.humans.tables.TableHumans`);
            it acts after the robot has chosen and sees its action. Where it turns back
            (:attr:`~hri_envs.humans.protocol.BatchHuman.turn_state`) is read after each
            :meth:`~hri_envs.humans.protocol.BatchHuman.begin_episode`; a change of mind it
            reports after a step (:meth:`~hri_envs.humans.protocol.BatchHuman.
            revised_intentions`) is ι from the next step on.
        schedule: From :func:`make_schedule`; its ``goal`` is the intention at the start.
        backend: Moves the runs (the graph, or a simulator).
        r0: Reward for the robot waiting while the human acts.
        max_steps: Step limit per episode (the episode is truncated there).
        reward: The reward variant (:data:`hri_envs.task.episode.REWARD_RULES`).
        run_ids: The runs' indices, for error messages (default 0 .. B-1).

    Raises:
        ActionError: The agent's or the human's ``act`` returned something other than one
            integer action in [0, A) per run (masked actions are allowed: they abort the
            step); the message names who, the run, the episode and the step.
    """
    n_b, n_e = schedule.start.shape
    for who, n in (("agent", agent.n_runs), ("human", human.n_runs)):
        if n != n_b:
            raise ConfigError(f"the {who} has {n} runs, the schedule {n_b}", field="runs")
    loop = _Loop(graph, agent, human, backend, n_b, r0=r0, max_steps=max_steps,
                 run_ids=run_ids, reward=reward)
    for e in range(n_e):
        yield loop.episode(e, schedule)


@dataclass
class _Progress:
    """One episode of a batch so far, each (B,): the metrics' sums, the human's last action,
    which runs ended, which faulted, which still act (in the backend's current group).
    """

    totals: dict[str, np.ndarray]
    human_last: np.ndarray
    over: np.ndarray
    faulted: np.ndarray
    active: np.ndarray
    has_belief: bool = True


class _Loop:
    """:func:`run_episodes` for one batch: the buffers its episodes share, and one method per
    part of an episode (begin, choose the actions, account for a step, record it, finish).
    """

    def __init__(self, graph: TaskGraph, agent: BatchAgent, human: BatchHuman,
                 backend: BatchBackend, n_b: int, *, r0: float, max_steps: int,
                 run_ids: Sequence[int] | np.ndarray | None, reward: str) -> None:
        self.graph, self.agent, self.human, self.backend = graph, agent, human, backend
        self.n_b, self.max_steps, self.run_ids = n_b, max_steps, run_ids
        self.never = np.full((graph.n_intentions,) * 2, -1)
        self.rules = EpisodeRules(graph, r0, reward)  # the one place a step is judged
        self.eps = EpisodeBatch(self.rules, self.never, n_b)
        # A human whose draw() does something (a population of the user's, say) draws the
        # next episode's member before each episode, from each run's own generator.
        self.draws = type(human).draw is not BatchHuman.draw
        self.privileged = bool(getattr(agent, "privileged", False))
        # An agent in a process of its own (hri_bench.run.isolation): one message per step
        # brings its belief and its actions.
        self.decide = getattr(agent, "decide", None)
        self.rows = np.arange(n_b)
        self.scratch = np.empty((n_b, graph.n_intentions))  # _score_belief's, every step
        self.states = np.zeros((n_b, max_steps + 1), dtype=np.int64)
        self.robot_acts = np.zeros((n_b, max_steps), dtype=np.int64)
        self.human_seen = np.zeros((n_b, max_steps), dtype=np.int64)

    def episode(self, e: int, schedule: Schedule) -> EpisodeResult:
        """Play episode ``e`` of ``schedule`` in every run; the agent has learned from it."""
        p = self._begin(e, schedule)
        for group in self.backend.groups():
            p.faulted[group] = self.backend.begin(group, self.eps.start[group])
            p.active = np.zeros(self.n_b, dtype=bool)
            p.active[group] = ~p.faulted[group]
            for t in range(self.max_steps):
                if not p.active.any():
                    break
                self._step(e, t, p)
        return self._finish(e, p)

    def _begin(self, e: int, schedule: Schedule) -> _Progress:
        """Start episode ``e``: the human's, the episode rules' and the agent's."""
        eps = self.eps
        if self.draws:
            _draw(self.human)
        self.human.begin_episode(schedule.start[:, e], schedule.goal[:, e])
        where = self.human.turn_state  # (K, K), or (B, K, K): each run's human turns apart
        eps.turn_state = self.never if where is None else where
        eps.begin(self.rows, schedule.start[:, e], schedule.goal[:, e],
                  schedule.turn_back[:, e])
        self.agent.begin_episode(eps.start.copy())
        n_b = self.n_b
        totals = {k: np.zeros(n_b) for k in ("reward", "correct", "passive", "wrong",
                                              *self.backend.extras, *TASK_METRICS)}
        self.states[:, 0] = eps.state
        return _Progress(totals, np.full(n_b, WAIT, dtype=np.int64), np.zeros(n_b, dtype=bool),
                         np.zeros(n_b, dtype=bool), np.zeros(n_b, dtype=bool))

    def _step(self, e: int, t: int, p: _Progress) -> None:
        """Step ``t``: both act, the backend moves, the metrics add up, both observe."""
        s = self.eps.state
        w = p.active.astype(float)  # this step's weights (active changes after it)
        a_r, a_h = self._actions(e, t, s, w, p)
        step = self.backend.transition(s, a_r, a_h, p.active)
        self._account(s, a_r, a_h, step, w, p.totals)
        self.agent.observe(s, a_r, step.human_seen, step.next_state, p.active)
        self.human.observe(s, a_r, a_h, step.next_state, p.active)
        self._record(t, a_r, a_h, step, p)

    def _actions(self, e: int, t: int, s: np.ndarray, w: np.ndarray, p: _Progress
                 ) -> tuple[np.ndarray, np.ndarray]:
        """The robot's action, then the human's (who sees it); WAIT for inactive runs. The
        agent's belief is scored before it acts.
        """
        eps, active, n_actions = self.eps, p.active, self.graph.n_actions
        obs: dict[str, np.ndarray] = {
            "state": s, "start": eps.start, "last_human_action": eps.last_human,
            "action_mask": self.graph.valid[s].astype(np.int8)}
        if self.privileged:
            obs["intention"] = eps.intention
        try:
            if self.decide is not None:  # the belief it had before acting comes with it
                chosen = self.decide(obs, active, p.has_belief)
            if p.has_belief:
                p.has_belief = _score_belief(self._belief(), eps.intention, active, t,
                                             p.totals, self.rows, w, self.scratch)
            if self.decide is None:
                chosen = self.agent.act(obs, active)
        except ActionError as exc:  # a Batched agent's: add where it happened
            raise ActionError(f"{exc} (episode {e + 1}, step {t + 1})") from None
        a_r = np.where(active, _checked("act()", chosen, active, n_actions, self.run_ids, e, t),
                       WAIT)
        seen = {"state": s, "start": eps.start, "intention": eps.intention,
                "last_human_action": p.human_last, "action_mask": obs["action_mask"],
                "robot_action": a_r}
        a_h = np.where(active, _checked("the human's act()", self.human.act(seen, active),
                                        active, n_actions, self.run_ids, e, t), WAIT)
        return a_r, a_h

    def _belief(self) -> np.ndarray | None:
        """The agent's belief (:func:`agents.protocol.read_belief`), one probability per run
        and intention of the graph: a belief over another number of intentions is a
        :class:`ConfigError` naming the agent, never scored.
        """
        belief = read_belief(self.agent, self.n_b)
        k = self.graph.n_intentions
        if belief is not None and belief.shape[1] != k:
            name = getattr(self.agent, "name", type(self.agent).__name__)
            raise ConfigError(f"belief() of agent {name!r} returned {belief.shape[1]} "
                              f"probabilities per run; the {self.graph.name} has {k} "
                              "intentions (one probability each, in the order of its supports)",
                              field="belief")
        return belief

    def _account(self, s: np.ndarray, a_r: np.ndarray, a_h: np.ndarray, step: BatchStep,
                 w: np.ndarray, totals: dict[str, np.ndarray]) -> None:
        """Add the step's reward, decisions, backend figures and human effort (weights ``w``)."""
        graph, eps = self.graph, self.eps
        failed = False if step.penalty is None else step.penalty
        totals["reward"] += w * self.rules.judge(s, a_r, a_h, step.next_state, eps.start,
                                                 eps.lifted, failed)
        for key, judged in zip(("correct", "passive", "wrong"),
                               classify(graph, s, a_r, a_h, step.next_state), strict=True):
            totals[key] += w * judged
        for key, value in step.extras.items():
            totals[key] += w * value
        motion_r, motion_h = a_r >= TAKE_OFF, a_h >= TAKE_OFF
        totals["counteract"] += w * (motion_r & motion_h & (a_r != a_h))
        totals["human_idle"] += w * ((a_h == WAIT) & (step.next_state == s))
        totals["human_alone"] += w * ((a_r == WAIT) & (a_h != WAIT))

    def _record(self, t: int, a_r: np.ndarray, a_h: np.ndarray, step: BatchStep,
                p: _Progress) -> None:
        """Commit the step to the episode and the traces; runs that ended or faulted stop."""
        active, eps = p.active, self.eps
        p.human_last = np.where(active, a_h, p.human_last)
        self.robot_acts[active, t] = a_r[active]
        self.human_seen[active, t] = step.human_seen[active]
        ended = eps.commit(step.next_state, step.human_seen, active)
        revised = self.human.revised_intentions()  # a human who changed its mind
        if revised is not None:
            eps.revise(np.asarray(revised, dtype=np.int64), active & ~ended)
        self.states[active, t + 1] = eps.state[active]
        p.over |= ended
        if step.fault is not None:
            p.faulted |= active & step.fault & ~ended
        active &= ~(ended | p.faulted)

    def _finish(self, e: int, p: _Progress) -> EpisodeResult:
        """The episode's metrics and traces; the agent learns from them, the human ends it."""
        steps = self.eps.steps.copy()
        truncated = ~p.over
        per_step = np.maximum(steps, 1)
        totals = p.totals
        for key in ("correct", "passive", "wrong", "log_loss", "brier",
                    *self.backend.step_means):
            totals[key] /= per_step
        if not p.has_belief:
            for key in BELIEF_METRICS:
                totals[key][:] = np.nan
        intentions = np.where(truncated, -1, self.graph.support[self.states[self.rows, steps]])
        traces = [Trace(self.states[i, : steps[i] + 1].copy(),
                        self.robot_acts[i, : steps[i]].copy(),
                        self.human_seen[i, : steps[i]].copy()) for i in range(self.n_b)]
        self.agent.end_episode(traces, intentions)
        self.human.end_episode()
        metrics = EpisodeMetrics(totals["reward"], totals["correct"], totals["passive"],
                                 totals["wrong"], steps.astype(float), truncated,
                                 {k: totals[k] for k in self.backend.extras},
                                 {k: totals[k] for k in TASK_METRICS})
        return EpisodeResult(e, metrics, traces, intentions)


def _draw(human: BatchHuman) -> None:
    """Ask the seat to draw the next episode's humans: each row from its own generator
    (the study's ``(seed, run, 1)``), else every row from the shared one.
    """
    rngs = getattr(human, "rngs", None)
    if rngs is None:
        human.draw(human.rng)
        return
    for i, rng in enumerate(rngs):
        human.draw(rng, np.array([i]))


def _score_belief(belief: np.ndarray | None, intention: np.ndarray, active: np.ndarray,
                  t: int, totals: dict[str, np.ndarray], rows: np.ndarray, w: np.ndarray,
                  scratch: np.ndarray) -> bool:
    """Add decision ``t``'s belief scores to ``totals``; False when there is no belief.

    ``map_steps`` becomes t + 1 wherever the belief's unique maximum is not the current
    intention, so at the end it counts the decisions up to the last wrong one. ``rows`` is
    ``arange(B)``, ``w`` is ``active`` as floats and ``scratch`` a (B, K) float work array
    (all the caller's, so that nothing of the sort is rebuilt every step).
    """
    if belief is None:
        return False
    p_true = belief[rows, intention]
    np.copyto(scratch, belief)  # the other intentions' beliefs
    scratch[rows, intention] = -np.inf
    totals["map_steps"][active & ~(p_true > scratch.max(1))] = t + 1
    totals["log_loss"] += w * -np.log(np.maximum(p_true, LOG_LOSS_FLOOR))
    np.multiply(belief, belief, out=scratch)  # (belief minus the one-hot truth)²
    miss = p_true - 1.0
    scratch[rows, intention] = miss * miss
    totals["brier"] += w * scratch.sum(1)
    return True


def _checked(who: str, actions: object, active: np.ndarray, n_actions: int,
             run_ids: Sequence[int] | np.ndarray | None, episode: int, step: int) -> np.ndarray:
    """The actions ``who`` returned as an int array, or an :class:`ActionError` naming where."""
    arr = np.asarray(actions)
    n_b = active.shape[0]
    where = f"episode {episode + 1}, step {step + 1}"
    if arr.shape != (n_b,) or arr.dtype.kind not in "iu":
        raise ActionError(f"{who} returned {arr.dtype} of shape {arr.shape} in {where}; "
                          f"expected one integer action per run, shape ({n_b},)")
    bad = active & ((arr < 0) | (arr >= n_actions))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        run = i if run_ids is None else int(run_ids[i])
        raise ActionError(f"{who} returned action {arr[i]} for run {run} in {where}; "
                          f"actions are integers in [0, {n_actions})")
    return arr


def simulate(
    graph: TaskGraph,
    agent: BatchAgent,
    human: ScriptedHuman | BatchHuman,
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
    """Simulate ``schedule`` for a batch of runs with one agent and one human per run.

    Args:
        graph: The task graph.
        agent: A batched agent with ``n_runs == len(runs)``.
        human: A scripted human shared by the runs (each with its own random stream), or a
            :class:`~hri_envs.humans.protocol.BatchHuman` with a row per run.
        schedule: From :func:`make_schedule`.
        runs: Run indices (the human draws from :func:`human_streams`).
        seed: Base seed.
        r0: Reward for the robot waiting while the human acts (for the metrics).
        max_steps: Step limit per episode (the episode is truncated there).
        after_episode: Called as ``after_episode(e, agent)`` after each learning update.
        backend: A registered backend (:mod:`hri_envs.envs.backends`): "graph" or "mujoco".
        reward: The reward variant (:data:`hri_envs.task.episode.REWARD_RULES`).
        physics: Validated ``physics`` options of the backend (e.g. ``{"preset":
            "weak-human"}``); None or empty for its defaults.

    Returns:
        The episode metrics; ``extras`` holds the backend's per-episode figures (the
        physics: interaction impulses, simulated duration, agreement with the graph),
        ``task`` the :data:`TASK_METRICS`.
    """
    n_b, n_e = schedule.start.shape
    if len(runs) != n_b:
        raise ConfigError(f"the schedule has {n_b} runs, runs= names {len(runs)}", field="runs")
    sim = batch_backend(backend)(graph, runs, seed, physics=physics)
    keys = ("reward", "correct", "passive", "wrong", "steps")
    out = {k: np.zeros((n_b, n_e)) for k in keys}
    extras = {k: np.zeros((n_b, n_e)) for k in sim.extras}
    task = {k: np.zeros((n_b, n_e)) for k in TASK_METRICS}
    truncated = np.zeros((n_b, n_e), dtype=bool)
    humans = TableHumans(human, n_b) if isinstance(human, ScriptedHuman) else human
    humans.seed(human_streams(seed, runs))
    for res in run_episodes(graph, agent, humans, schedule, sim, r0=r0, max_steps=max_steps,
                            run_ids=runs, reward=reward):
        e, m = res.episode, res.metrics
        for k in keys:
            out[k][:, e] = getattr(m, k)
        for k, v in m.extras.items():
            extras[k][:, e] = v
        for k, v in m.task.items():
            task[k][:, e] = v
        truncated[:, e] = m.truncated
        if after_episode is not None:
            after_episode(e, agent)
    return EpisodeMetrics(out["reward"], out["correct"], out["passive"], out["wrong"],
                          out["steps"], truncated, extras, task)
