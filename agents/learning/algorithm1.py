"""The Learner's update, Algorithm 1 (l. 17-22, then l. 3-5), and the arrays it reuses.

After every episode the paper's Learner

1. removes the loops from the episode's state trace and counts its features (l. 17);
2. makes one maximum-entropy IRL step on θ for the intention the episode revealed: the
   trace's counts against those the soft-max policy of the human MDP expects (l. 18-19);
3. recomputes its human model: per intention, the human's Q on the human MDP (reward θ·φ,
   the robot's current policy substituted) and π̂_H = softmax(τ_H Q_H) (l. 20-22);
4. recomputes its robot model: per intention, the robot's Q on the robot MDP (the joint
   reward R_R, π̂_H substituted) and the soft-max robot policy the human model assumes
   (l. 3-5).

:func:`reference_update` is that, step by step, in numpy: the readable reference.
:func:`update_models` gives the same numbers, bit for bit, from compiled kernels (the runs
cut into parts that threads take, :mod:`agents.learning.partner_mdp`), and falls back to
the reference where the kernels are off. :func:`update` is what the Learner calls: the
graph's :class:`Tables`, the :class:`Params`, the current :class:`Models` and, optionally,
a :class:`Workspace` whose arrays the update writes into.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from agents.learning import mdp
from agents.learning.partner_mdp import (
    _c,
    _check_iteration,
    _check_range,
    _check_shape,
    _in_parts,
    _joined,
    _valid,
    expected_feature_counts,
    kernels,
    loop_free_counts,
    solve_soft,
)
from agents.learning.partner_mdp import preload as preload_kernels
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp
from hri_envs.task.graph import TaskGraph

__all__ = ["Models", "Params", "Tables", "Workspace", "preload", "reference_update", "update",
           "update_models"]


class Tables(NamedTuple):
    """A graph's tables in the layouts the kernels take (own, writeable, contiguous copies,
    so that neither the kernels copy them per call nor a read-only variant is compiled).

    Attributes:
        next_state: (S, A, A) int64 joint table ``next_state[s, a_R, a_H]``.
        valid: (S, A) bool valid actions (of both partners).
        reward: (S, A, A) float64 the robot's joint reward R_R (with the Learner's r0).
        features: (I, S, F) float64 φ(s, ι).
        terminal: (I,) int64 the absorbing goal state of each intention.
    """

    next_state: np.ndarray
    valid: np.ndarray
    reward: np.ndarray
    features: np.ndarray
    terminal: np.ndarray

    @classmethod
    def of(cls, graph: TaskGraph, r0: float) -> Tables:
        """The tables of ``graph`` with the robot reward of ``r0``."""
        return cls(np.array(graph.next_state, dtype=np.int64), np.array(graph.valid, dtype=bool),
                   np.array(graph.reward(r0), dtype=np.float64),
                   np.array(graph.features, dtype=np.float64),
                   np.array(graph.terminal, dtype=np.int64))


class Params(NamedTuple):
    """The update's parameters (the Learner's configuration, :class:`agents.config.
    LearnerConfig`).

    Attributes:
        gamma: Discount γ in [0, 1) of every Q-iteration.
        human_temperature: τ_H of π̂_H.
        robot_temperature: τ of the robot policy the human model assumes.
        irl_temperature: τ of the IRL's soft-max policy.
        learning_rate: λ of the IRL step.
        max_iter: Cap on policy-improvement rounds.
    """

    gamma: float
    human_temperature: float
    robot_temperature: float
    irl_temperature: float
    learning_rate: float
    max_iter: int = 100


class Models(NamedTuple):
    """The Learner's model of both partners after :func:`update_models` (B runs, I intentions).

    Attributes:
        theta: (B, F) feature weights of the human's reward.
        state_reward: (B, I, S) that reward, θ·φ(s, ι).
        q_h: (B, I, S, A) the human's Q.
        greedy_h: (B, I, S) int its greedy actions (the next update's warm start).
        pi_h: (B, I, S, A) the human policy estimate π̂_H.
        q_r: (B, I, S, A) the robot's Q.
        greedy_r: (B, I, S) int its greedy actions.
        pi_r: (B, I, S, A) the robot's soft-max policy the human model assumes.
    """

    theta: np.ndarray
    state_reward: np.ndarray
    q_h: np.ndarray
    greedy_h: np.ndarray
    pi_h: np.ndarray
    q_r: np.ndarray
    greedy_r: np.ndarray
    pi_r: np.ndarray


class Workspace:
    """Arrays an update may write its results into, handed over explicitly.

    A learner that keeps nothing of an earlier update's models gives them to its workspace
    (:meth:`give`) when an update replaces them; the next update writes into them
    (:meth:`take`) instead of fresh arrays, which spares the allocator fresh pages (about a
    sixth of a 100-run update's time). So with a workspace, the arrays a learner exposes
    are overwritten by the update after next: whoever keeps them copies them. The benchmark
    gives its learners one; a learner made without one never overwrites an array.
    """

    def __init__(self) -> None:
        self._spare: Models | None = None

    def give(self, models: Models) -> None:
        """Models no one reads any more: the next update may write into their arrays."""
        self._spare = models

    def take(self) -> Models | None:
        """The arrays to write the next update into (None: fresh ones)."""
        spare, self._spare = self._spare, None
        return spare


def update(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
           last: Models | None = None, *, state_reward: np.ndarray | None = None,
           state_traces: Sequence[np.ndarray] | None = None,
           intentions: np.ndarray | None = None, workspace: Workspace | None = None
           ) -> Models:
    """One update of a batch of Learners: :func:`update_models` from their current models.

    Args:
        tables: The graph's tables.
        params: The update's parameters.
        theta: (B, F) θ before the update.
        pi_r: (B, I, S, A) the robot's policies the human model assumed so far.
        last: The models of the last update, whose greedy actions warm-start every policy
            iteration; None for the first update.
        state_reward: (B, I, S) θ·φ of ``theta`` if the caller has it (``last``'s, when θ has
            not changed since), to spare computing it again.
        state_traces: B state sequences, or None: no IRL step (the models of ``theta``).
        intentions: (B,) int the intention each trace revealed, -1 for none.
        workspace: Where the result is written (:class:`Workspace`), or None: new arrays.
    """
    warm = None if last is None else (last.greedy_h, last.greedy_r)
    return update_models(*tables, theta, pi_r, warm, gamma=params.gamma,
                         human_temperature=params.human_temperature,
                         robot_temperature=params.robot_temperature,
                         irl_temperature=params.irl_temperature,
                         learning_rate=params.learning_rate, state_traces=state_traces,
                         intentions=intentions, max_iter=params.max_iter,
                         state_reward=state_reward,
                         out=None if workspace is None else workspace.take())


def update_models(
    next_state: np.ndarray,
    valid: np.ndarray,
    reward: np.ndarray,
    features: np.ndarray,
    terminal: np.ndarray,
    theta: np.ndarray,
    pi_r: np.ndarray,
    warm: tuple[np.ndarray, np.ndarray] | None,
    *,
    gamma: float,
    human_temperature: float,
    robot_temperature: float,
    irl_temperature: float,
    learning_rate: float,
    state_traces: Sequence[np.ndarray] | None = None,
    intentions: np.ndarray | None = None,
    max_iter: int = 100,
    state_reward: np.ndarray | None = None,
    out: Models | None = None,
) -> Models:
    """The Learner's update of its models (Alg. 1 l. 17-22 and 3-5) for B runs in one call.

    1. With ``state_traces``: one ME-IRL step on θ per run whose intention was revealed
       (``intentions[b] >= 0``; -1 keeps θ): the loop-free counts of its trace against the
       counts the soft-max policy (at ``irl_temperature``) of the human MDP of that
       intention expects (reward θ·φ, the robot's ``pi_r`` substituted), then
       :func:`agents.learning.mdp.irl_step`.
    2. The human model: for every intention, the soft-max solution of the human MDP
       (reward θ·φ with the new θ, ``pi_r`` substituted, at ``human_temperature``).
    3. The robot's Q: the soft-max solution of its MDP (joint ``reward``, the new π̂_H
       substituted, at ``robot_temperature``).

    Every policy iteration is warm-started from ``warm``'s greedy actions if given.

    Where the kernels are on, the runs are cut into parts that the threads take in one
    hand-out per call (:func:`~agents.learning.partner_mdp.set_threads`); each part goes
    through the compiled :func:`agents.learning._jit.irl_steps`, numpy's θ·φ of the new θ, and
    :func:`agents.learning._jit.partner_models`: the same numbers, bit for bit, as the calls
    listed above, which :func:`reference_update` makes (the path without the kernels).

    Args:
        next_state: (S, A, A) int joint table, the robot's action first; the human's MDP
            uses its transpose.
        valid: (S, A) bool valid actions (of both partners).
        reward: (S, A, A) the robot's joint reward.
        features: (I, S, F) φ(s, ι).
        terminal: (I,) int the absorbing goal state of each intention.
        theta: (B, F) θ before the update.
        pi_r: (B, I, S, A) the robot's policies the human model assumed so far.
        warm: ``(greedy_h, greedy_r)`` (B, I, S) int of the last update, or None.
        gamma: Discount in [0, 1).
        human_temperature: τ_H of π̂_H.
        robot_temperature: τ of the robot policy the human model assumes.
        irl_temperature: τ of the IRL's soft-max policy.
        learning_rate: λ of the IRL step.
        state_traces: B state sequences (each at least one state), or None: no IRL step.
        intentions: (B,) int the intention each trace revealed, -1 for none.
        max_iter: Cap on improvement rounds.
        state_reward: (B, I, S) θ·φ of ``theta``, if the caller has it (the
            ``state_reward`` of the update that made this θ; its values are trusted), to
            spare the compiled path computing it again; None: computed.
        out: Arrays to write the new models into (all but ``theta``, which is always new
            when θ changes), of the shapes and types of the result and sharing no memory
            with the inputs; None: new arrays. Reusing the arrays of an earlier update
            spares the allocator fresh pages (about a sixth of a 100-run update's time).

    Returns:
        The new :class:`Models`.

    Raises:
        ConfigError: An array of the wrong shape, an index out of range, or what
            :func:`~agents.learning.partner_mdp.solve_soft` refuses.
    """
    phi = _c(np.asarray(features), np.float64)
    th = _c(np.asarray(theta), np.float64)
    if phi.ndim != 3 or th.ndim != 2:
        raise ConfigError(f"features must be (I, S, F) and theta (B, F), got shapes "
                          f"{phi.shape} and {th.shape}",
                          field="features" if phi.ndim != 3 else "theta")
    n_i, n_s, n_f = phi.shape
    n_a = np.shape(valid)[-1]
    n_b = len(th)
    nxt = _c(np.asarray(next_state), np.int64)
    _check_shape("next_state", nxt, (n_s, n_a, n_a))
    _check_range("next_state", nxt, 0, n_s)
    ok = _valid(valid, n_s, n_a)
    joint = _c(np.asarray(reward), np.float64)
    _check_shape("reward", joint, (n_s, n_a, n_a))
    term = _c(np.asarray(terminal), np.int64)
    _check_shape("terminal", term, (n_i,))
    _check_range("terminal", term, -1, n_s)
    _check_shape("theta", th, (n_b, n_f))
    pi = _c(np.asarray(pi_r), np.float64)
    _check_shape("pi_r", pi, (n_b, n_i, n_s, n_a))
    if warm is not None:
        warm = (_c(np.asarray(warm[0]), np.int64), _c(np.asarray(warm[1]), np.int64))
        for name, w in zip(("greedy_h", "greedy_r"), warm, strict=True):
            _check_shape(name, w, (n_b, n_i, n_s))
            _check_range(name, w, 0, n_a)
    _check_iteration(gamma, max_iter)
    if state_reward is not None:
        state_reward = _c(np.asarray(state_reward), np.float64)
        _check_shape("state_reward", state_reward, (n_b, n_i, n_s))
    if out is not None:
        _check_out(out, (n_b, n_i, n_s, n_a))
    intent = None
    if state_traces is not None:
        intent = _c(np.asarray(intentions).reshape(-1), np.int64)
        if len(intent) != n_b or len(state_traces) != n_b:
            raise ConfigError(f"give one trace and one intention per run ({n_b}), got "
                              f"{len(state_traces)} and {len(intent)}", field="intentions")
        _check_range("intentions", intent, -1, n_i)
        states, offsets = _joined(state_traces, n_s)
    jit = kernels()
    if jit is None or n_f < 2:  # (numpy sums a single feature's counts pairwise)
        made = reference_update(
            Tables(nxt, ok, joint, phi, term),
            Params(gamma, human_temperature, robot_temperature, irl_temperature, learning_rate,
                   max_iter), th, pi, warm, state_traces, intent)
        if out is None:
            return made
        for into, value in zip(out[1:], made[1:], strict=True):
            np.copyto(into, value)
        return Models(made.theta, *out[1:])
    nxt_r, nxt_h, next_h, joint_t, vidx, n_valid, rank = jit.learner_tables(nxt, ok, joint)
    shape = (n_b, n_i, n_s, n_a)
    theta_new = th if intent is None else np.empty_like(th)
    if out is None:
        new = Models(theta_new, np.empty(shape[:3]), np.empty(shape),
                     np.empty(shape[:3], np.int64), np.empty(shape), np.empty(shape),
                     np.empty(shape[:3], np.int64), np.empty(shape))
    else:
        new = Models(theta_new, *out[1:])
    w_h, w_r = warm if warm is not None else (np.zeros(shape[:3], np.int64),) * 2
    if intent is not None and state_reward is None:
        state_reward = np.einsum("isf,bf->bis", phi, th)

    def runs(lo: int, hi: int) -> None:
        if intent is not None:
            jit.irl_steps(nxt_h, next_h, ok, vidx, n_valid, rank, phi, term, th, state_reward,
                          pi, w_h, warm is not None, states, offsets, intent, float(gamma),
                          float(irl_temperature), int(max_iter), float(learning_rate),
                          new.theta, lo, hi)
        # numpy's θ·φ (its sums' order is numpy's), a part at a time: the same numbers
        np.einsum("isf,bf->bis", phi, new.theta[lo:hi], out=new.state_reward[lo:hi])
        jit.partner_models(nxt_r, nxt_h, joint_t, ok, vidx, n_valid, rank, term,
                           new.state_reward, pi, w_h, w_r, warm is not None, float(gamma),
                           float(human_temperature), float(robot_temperature), int(max_iter),
                           new.q_h, new.greedy_h, new.pi_h, new.q_r, new.greedy_r, new.pi_r,
                           lo, hi)

    _in_parts(runs, n_b, mdps=n_b * (2 * n_i + (state_traces is not None)))
    return new


def _check_out(out: Models, shape: tuple[int, ...]) -> None:
    """Raise ConfigError unless ``out`` can take :func:`update_models`' results."""
    for name in Models._fields[1:]:
        arr = getattr(out, name)
        ints = name.startswith("greedy")
        want = shape[:3] if ints or name == "state_reward" else shape
        if (type(arr) is not np.ndarray or arr.shape != want
                or arr.dtype != (np.int64 if ints else np.float64)
                or not arr.flags.c_contiguous or not arr.flags.writeable):
            raise ConfigError(f"out.{name} must be a writeable C-contiguous "
                              f"{'int64' if ints else 'float64'} array of shape {want}",
                              field=f"out.{name}")


@task_mdp.one_blas_thread()
def reference_update(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
                     warm: tuple[np.ndarray, np.ndarray] | None = None,
                     state_traces: Sequence[np.ndarray] | None = None,
                     intentions: np.ndarray | None = None) -> Models:
    """Algorithm 1's update for B runs, step by step in numpy (the reference).

    The arguments are those of :func:`update_models` (checked by it); BLAS runs on one thread
    (:func:`hri_envs.task.mdp.one_blas_thread`: numpy's solves are small).
    """
    nxt, valid, reward, features, terminal = tables
    gamma, max_iter = params.gamma, params.max_iter
    next_h = np.ascontiguousarray(np.swapaxes(nxt, 1, 2))  # the human's view: own action first
    if state_traces is not None:
        assert intentions is not None
        # l. 17: the loop-free trace of each run whose episode revealed its intention.
        revealed = intentions >= 0
        shown = np.where(revealed, intentions, 0)
        counts, start, horizon = loop_free_counts(features, state_traces, shown)
        # l. 18: the feature counts the human MDP of that intention expects (reward θ·φ, the
        # robot's current policy substituted, soft-max at the IRL temperature).
        rows = np.arange(len(theta))
        term = terminal[shown]
        pi = pi_r[rows, shown]  # (B, S, A) the robot's policy the human expects
        phi = features[shown]  # (B, S, F)
        r_state = np.einsum("bsf,bf->bs", phi, theta)
        # Nearly the human MDP of the last update for the revealed intention (same θ, π_R
        # one update newer): start from its greedy policy, which is mostly still optimal.
        start_from = None if warm is None else warm[0][rows, shown]
        _, _, policy = solve_soft(next_h, pi, valid, gamma, params.irl_temperature,
                                  state_reward=r_state, terminal=term, policy=start_from,
                                  max_iter=max_iter)
        expected = expected_feature_counts(next_h, pi, policy, phi, start, term, horizon)
        # l. 19: one gradient step on θ, rescaled to max |θ| = 1; truncated runs keep theirs.
        new = mdp.irl_step(theta, counts, expected, params.learning_rate)
        theta = np.where(revealed[:, None], new, theta)
    # l. 20-22: the human model π̂_H = softmax(τ_H Q_H) per intention, on the human MDP.
    r_all = np.einsum("isf,bf->bis", features, theta)  # (B, I, S)
    goal = terminal[None, :]
    q_h, greedy_h, pi_h = solve_soft(next_h, pi_r, valid, gamma, params.human_temperature,
                                     state_reward=r_all, terminal=goal,
                                     policy=None if warm is None else warm[0],
                                     max_iter=max_iter)
    # l. 3-5: the robot's Q per intention on the robot MDP (R_R, π̂_H substituted), and the
    # soft-max robot policy the human model assumes in the next update.
    q_r, greedy_r, pi_r = solve_soft(nxt, pi_h, valid, gamma, params.robot_temperature,
                                     joint_reward=reward, terminal=goal,
                                     policy=None if warm is None else warm[1],
                                     max_iter=max_iter)
    return Models(theta, r_all, q_h, greedy_h, pi_h, q_r, greedy_r, pi_r)


def preload() -> bool:
    """Load every compiled kernel of the update now; whether the compiled path is on.

    :func:`agents.learning.partner_mdp.preload`, then a tiny update (its own kernels), so
    that worker processes forked afterwards inherit them loaded.
    """
    if not preload_kernels():
        return False
    nxt, zero = np.zeros((1, 1, 1), np.int64), np.zeros(1, np.int64)
    update_models(nxt, np.ones((1, 1), np.bool_), np.zeros((1, 1, 1)), np.zeros((1, 1, 2)),
                  zero, np.zeros((1, 2)), np.ones((1, 1, 1, 1)), None, gamma=0.5,
                  human_temperature=1.0, robot_temperature=1.0, irl_temperature=1.0,
                  learning_rate=0.1, state_traces=[zero], intentions=zero)
    return True
