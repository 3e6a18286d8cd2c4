"""The count-based learner's human model (:mod:`baselines.countqmdp`, module docstring):
Dirichlet–categorical counts of the human's actions in three nested contexts, the wait rates
of free space, the prior ``π0`` and the labels the counts are kept under, and the learning
from an episode in hindsight (the smoothed posterior of the intention under the
change-of-mind hazard).

:class:`CountModel` holds the model's methods; :class:`~baselines.countqmdp.CountQMDP`
(the agent: the filter, the plan and the action) derives from it and makes its arrays.
:mod:`baselines.countqmdp` re-exports the public names here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from agents.protocol import Trace
from baselines.goalfilter import shortest_path_policy
from baselines.simple import Tracking
from hri_envs.errors import ConfigError
from hri_envs.task.actions import N_FIXED_ACTIONS, WAIT
from hri_envs.task.graph import TaskGraph

#: How the robot's action of the step splits the human's context.
ROBOT_CONTEXTS: tuple[str, ...] = ("none", "wait", "action")
#: What a step teaches in hindsight.
HINDSIGHT: tuple[str, ...] = ("revealed", "smooth")


def prior_policy(graph: TaskGraph, beta: float, epsilon: float) -> np.ndarray:
    """(K, K, S, A) ``π0(a | st, ι, s)``: the goal filter's shortest-path human (β, no
    uniform part) mixed with ``epsilon`` of a uniform choice among the valid actions in
    every state (module docstring).
    """
    sp = shortest_path_policy(graph, beta, 0.0)
    uniform = graph.valid / graph.valid.sum(-1, keepdims=True)
    return (1.0 - epsilon) * sp + epsilon * uniform[None, None]


def relative_actions(graph: TaskGraph) -> np.ndarray:
    """(K, K, A) int ``rel(a; st, ι)``: each action's label relative to the episode.

    "Move over to support k" becomes "move over to the j-th support" in the order ι, the
    start (when it is not ι), then the others by index; every other action keeps its
    index. A permutation of the actions for each (start, ι).
    """
    n_k, n_a = graph.n_intentions, graph.n_actions
    out = np.broadcast_to(np.arange(n_a), (n_k, n_k, n_a)).copy()
    for st in range(n_k):
        for io in range(n_k):
            order = [io] + [k for k in [st] if k != io] + [k for k in range(n_k)
                                                            if k not in (io, st)]
            for j, k in enumerate(order):
                out[st, io, N_FIXED_ACTIONS + k] = N_FIXED_ACTIONS + j
    return out


def state_roles(graph: TaskGraph) -> np.ndarray:
    """(K, K, S) int ``role(s; st, ι)``: 0 where the state's column (or support) is ι's, 1
    where it is the start's (and not ι's), 2 elsewhere.
    """
    n_k = graph.n_intentions
    col = graph.column[None, None, :]
    goal = col == np.arange(n_k)[None, :, None]
    start = col == np.arange(n_k)[:, None, None]
    return np.where(goal, 0, np.where(start, 1, 2))


def robot_classes(graph: TaskGraph, robot_context: str) -> np.ndarray:
    """(A,) int, the class ``c(a_R)`` of each robot action under ``robot_context``.

    Raises:
        ConfigError: An unknown ``robot_context`` (the message lists :data:`ROBOT_CONTEXTS`).
    """
    a = np.arange(graph.n_actions)
    if robot_context == "none":
        return np.zeros_like(a)
    if robot_context == "wait":
        return (a != WAIT).astype(np.int64)
    if robot_context == "action":
        return a
    raise ConfigError(f"robot_context must be one of {', '.join(ROBOT_CONTEXTS)}, got "
                      f"{robot_context!r}", field="robot_context")


def change_of_mind(belief: np.ndarray, allowed: np.ndarray, hazard: float) -> np.ndarray:
    """(..., K) the belief after a change of mind with probability ``hazard`` to one of the
    other allowed intentions, uniformly: ``(1 - h) b(ι) + h (1 - b(ι)) / (n - 1)`` on the
    ``n`` allowed ones (``belief`` sums to 1 over them), 0 on the others; unchanged where
    only one is allowed.
    """
    n = allowed.sum(-1, keepdims=True)
    h = np.where(n > 1, hazard, 0.0)
    moved = (1.0 - belief) / np.maximum(n - 1, 1)
    return np.where(allowed, (1.0 - h) * belief + h * moved, 0.0)


def _add(counts: np.ndarray, index: tuple[np.ndarray, ...], weight: np.ndarray) -> None:
    """``counts[index] += weight``, repeated indices summed."""
    flat = np.ravel_multi_index(index, counts.shape)
    counts += np.bincount(flat, weight, minlength=counts.size).reshape(counts.shape)


class CountModel(Tracking):
    """The human model of :class:`~baselines.countqmdp.CountQMDP` and its learning: the
    posterior predictive of the human's action, the wait rates, and the counts an episode
    adds (module docstring of :mod:`baselines.countqmdp`, "Human model" and "Learning").

    The arrays are made by :class:`~baselines.countqmdp.CountQMDP`'s constructor.
    """

    alpha: float
    kappa: float
    rho: float
    wait_weight: float
    hazard: float
    hindsight: str
    by_start: bool
    refined: bool
    classes: np.ndarray
    prior: np.ndarray
    relative: np.ndarray
    roles: np.ndarray
    shared: np.ndarray
    pooled: np.ndarray
    counts: np.ndarray
    _prior_wait: np.ndarray
    _fresh: np.ndarray
    _fresh_pooled: np.ndarray
    _waits_seen: np.ndarray
    _steps_seen: np.ndarray
    _fresh_waits: np.ndarray
    _fresh_steps: np.ndarray

    # ------------------------------------------------------------------ the human model
    def predictive(self, rows: np.ndarray, starts: np.ndarray, intentions: np.ndarray,
                   states: np.ndarray, classes: np.ndarray) -> np.ndarray:
        """(..., A) the posterior predictive ``P(a_H | st, ι, s, c)`` (module docstring).

        The five int arrays broadcast to a common shape (...,).

        Args:
            rows: The runs.
            starts: The episodes' start supports.
            intentions: The intentions ι.
            states: The states.
            classes: The robot classes ``c(a_R)``.
        """
        b, st, io, s, c = np.broadcast_arrays(rows, starts, intentions, states, classes)
        return self._waits(self._refine(self._pooled(b, st, io, s), b, st, io, s, c), b, s, c)

    def wait_rate(self, rows: np.ndarray, states: np.ndarray, classes: np.ndarray
                  ) -> np.ndarray:
        """(...) ``ω(s, c)``, the probability that the human waits in free state ``s`` when
        the robot's action is of class ``c`` (module docstring; arrays broadcast).
        """
        waits = self._waits_seen + self._fresh_waits  # (B, S, C)
        steps = self._steps_seen + self._fresh_steps
        lam = self.wait_weight
        run = ((waits.sum(1)[rows, classes] + lam * self._prior_wait[states])
               / (steps.sum(1)[rows, classes] + lam))
        return (waits[rows, states, classes] + lam * run) / (steps[rows, states, classes] + lam)

    def _waits(self, p: np.ndarray, b: np.ndarray, s: np.ndarray, c: np.ndarray
               ) -> np.ndarray:
        """``p`` (..., A) with the wait of free states replaced by ``ω(s, c)``, the motions
        keeping their proportions.
        """
        free = ~self.graph.is_support_state[s]
        omega = self.wait_rate(b, s, c)[..., None]
        moves = p * (np.arange(p.shape[-1]) != WAIT)
        moves = moves / moves.sum(-1, keepdims=True)
        shared = (1.0 - omega) * moves + omega * (np.arange(p.shape[-1]) == WAIT)
        return np.where(free[..., None], shared, p)

    def _pooled(self, b: np.ndarray, st: np.ndarray, io: np.ndarray, s: np.ndarray
                ) -> np.ndarray:
        """(..., A) ``P1``: levels 1 and 2 of the model for same-shaped index arrays."""
        p = self.prior[st, io, s]  # (..., A)
        if math.isfinite(self.rho):
            seen = self.shared[b[..., None], s[..., None], self.roles[st, io, s][..., None],
                               self.relative[st, io]]
            seen = np.where(self.graph.valid[s], seen, 0.0)
            p = (seen + self.rho * p) / (seen.sum(-1, keepdims=True) + self.rho)
        m = self.pooled[b, io, s] + self._fresh_pooled[b, io, s]
        return (m + self.alpha * p) / (m.sum(-1, keepdims=True) + self.alpha)

    def _refine(self, p1: np.ndarray, b: np.ndarray, st: np.ndarray, io: np.ndarray,
                s: np.ndarray, c: np.ndarray) -> np.ndarray:
        """(..., A) level 3 of the model on ``p1`` (broadcast against the index arrays)."""
        if not self.refined:
            return np.broadcast_to(p1, np.broadcast_shapes(p1.shape, (*c.shape, 1)))
        x = st if self.by_start else np.zeros_like(st)
        n = self.counts[b, x, io, s, c] + self._fresh[b, io, s, c]
        return (n + self.kappa * p1) / (n.sum(-1, keepdims=True) + self.kappa)

    def law(self, rows: np.ndarray | None = None) -> np.ndarray:
        """(R, K, K, S, C, A) the posterior predictive of the runs ``rows`` (default all)
        for every start, ι, state and robot class.
        """
        rows = np.arange(self.n_runs) if rows is None else np.asarray(rows, dtype=np.int64)
        n_k, n_s = self.graph.n_intentions, self.graph.n_states
        n_c = self.counts.shape[4]
        b, st, io, s, c = np.ix_(rows, np.arange(n_k), np.arange(n_k), np.arange(n_s),
                                 np.arange(n_c))
        grid = np.broadcast_arrays(b[..., 0], st[..., 0], io[..., 0], s[..., 0])
        return self._waits(self._refine(self._pooled(*grid)[..., None, :], b, st, io, s, c),
                           b, s, c)

    def likelihood(self, states: np.ndarray, robot_actions: np.ndarray,
                   human_actions: np.ndarray, rows: np.ndarray | None = None,
                   starts: np.ndarray | None = None) -> np.ndarray:
        """(N, K) the model's probability of N steps' human actions under every ι (by
        default each run's current step: ``rows`` every run, ``starts`` their starts).
        """
        rows = np.arange(self.n_runs) if rows is None else np.asarray(rows, dtype=np.int64)
        st = self.start if starts is None else np.asarray(starts, dtype=np.int64)
        io = np.arange(self.graph.n_intentions)[None, :]
        p = self.predictive(rows[:, None], st[:, None], io, states[:, None],
                            self.classes[robot_actions][:, None])  # (N, K, A)
        return np.take_along_axis(p, np.broadcast_to(human_actions[:, None, None],
                                                     (*p.shape[:2], 1)), axis=-1)[..., 0]

    def _may_switch(self, states: np.ndarray, next_states: np.ndarray) -> np.ndarray:
        """Where the filter allows a change of mind: a step that moved the object into
        free space.
        """
        return ~self.graph.is_support_state[next_states] & (next_states != states)

    def add_counts(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Add each run's steps to its counts (module docstring, "Learning"); runs with
        intention -1 add nothing but to the wait rates.
        """
        g = self.graph
        n_k = g.n_intentions
        lengths = np.array([len(tr.human_actions) for tr in traces], dtype=np.int64)
        run = np.repeat(np.arange(len(traces)), lengths)  # per step of every trace
        s = np.concatenate([tr.states[:-1] for tr in traces]).astype(np.int64)
        a_r = np.concatenate([tr.robot_actions for tr in traces]).astype(np.int64)
        a_h = np.concatenate([tr.human_actions for tr in traces]).astype(np.int64)
        free = ~g.is_support_state[s]
        c = self.classes[a_r]
        _add(self._waits_seen, (run[free], s[free], c[free]), (a_h[free] == WAIT) * 1.0)
        _add(self._steps_seen, (run[free], s[free], c[free]), np.ones(int(free.sum())))
        rows = np.flatnonzero((np.asarray(intentions) >= 0) & (lengths > 0))
        if not len(rows):
            return
        goals = np.asarray(intentions, dtype=np.int64)[rows]
        if self.hindsight == "smooth" and self.hazard > 0.0:
            weight = np.concatenate(self.smoothed(rows, [traces[int(i)] for i in rows], goals))
        else:
            weight = np.eye(n_k)[np.repeat(goals, lengths[rows])]
        kept = np.isin(run, rows)  # the steps of the runs that revealed ι, in order
        step, io = np.nonzero(weight > 0)
        w = weight[step, io]
        b_, s_, c_, h_ = (x[kept][step] for x in (run, s, c, a_h))
        st = g.support[np.array([tr.states[0] for tr in traces])][b_]
        x = st if self.by_start else np.zeros_like(st)
        _add(self.shared, (b_, s_, self.roles[st, io, s_], self.relative[st, io, h_]), w)
        _add(self.pooled, (b_, io, s_, h_), w)
        _add(self.counts, (b_, x, io, s_, c_, h_), w)

    def smoothed(self, rows: np.ndarray, traces: Sequence[Trace], goals: np.ndarray
                 ) -> list[np.ndarray]:
        """Per trace, (T, K) ``P(ι_t = ι | the trace's human actions, ι_T = goal)`` under the
        model before the episode and the hazard ``h`` (a forward–backward pass, every trace
        at once; ``rows`` the traces' runs, ``goals`` their revealed intentions).
        """
        g = self.graph
        k, h = g.n_intentions, self.hazard
        rows, goals = np.asarray(rows, dtype=np.int64), np.asarray(goals, dtype=np.int64)
        lengths = np.array([len(tr.human_actions) for tr in traces], dtype=np.int64)
        n, t_max = len(traces), int(lengths.max())
        states = np.stack([np.pad(tr.states, (0, t_max - len(tr.human_actions)), mode="edge")
                           for tr in traces]).astype(np.int64)  # (n, T+1)
        acts = [np.stack([np.pad(getattr(tr, f), (0, t_max - len(tr.human_actions)))
                          for tr in traces]).astype(np.int64)
                for f in ("robot_actions", "human_actions")]  # (n, T) each
        starts = g.support[states[:, 0]]
        lik = self.likelihood(states[:, :-1].ravel(), acts[0].ravel(), acts[1].ravel(),
                              np.repeat(rows, t_max), np.repeat(starts, t_max))
        lik = lik.reshape(n, t_max, k)
        lifted = np.maximum.accumulate(g.support[states] != starts[:, None], axis=1)
        allowed = lifted[..., None] | (np.arange(k) != starts[:, None, None])  # (n, T+1, K)
        on = np.arange(t_max)[None] < lengths[:, None]  # (n, T) real steps
        free = self._may_switch(states[:, :-1], states[:, 1:]) & on  # a change after step t
        fwd = np.zeros((n, t_max, k))  # P(ι_t | the actions up to t)
        b = allowed[:, 0] / allowed[:, 0].sum(-1, keepdims=True)
        for t in range(t_max):
            post = b * lik[:, t] * allowed[:, t]
            total = post.sum(-1, keepdims=True)
            b = np.where(total > 0, post / np.where(total > 0, total, 1.0), b)
            fwd[:, t] = b
            b = np.where(free[:, t, None], change_of_mind(b, allowed[:, t + 1], h), b)
        # v(ι) ∝ P(the actions after step t, ι_T = goal | ι after step t's change = ι).
        last = np.eye(k)[goals]
        v = last.copy()
        out = np.zeros((n, t_max, k))
        for t in range(t_max - 1, -1, -1):
            m = allowed[:, t + 1]
            moved = (1 - h) * v + h * (((v * m).sum(-1, keepdims=True) - v)
                                       / np.maximum(m.sum(-1, keepdims=True) - 1, 1))
            v = np.where(free[:, t, None], moved, v)  # back through step t's change
            post = fwd[:, t] * v
            total = post.sum(-1, keepdims=True)
            out[:, t] = np.where(total > 0, post / np.where(total > 0, total, 1.0), last)
            v = np.where(on[:, t, None], v * lik[:, t], v)
            v = v / np.maximum(v.max(-1, keepdims=True), 1e-300)  # its scale is free
        return [out[i, :lengths[i]] for i in range(n)]
