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
:func:`update` is what the Learner calls: the graph's :class:`Tables`, the :class:`Params`,
θ, π_R, the last :class:`Models` and, optionally, a :class:`Workspace` whose arrays the
update writes into. It gives the reference's numbers, bit for bit, from compiled kernels
(:class:`_CompiledSteps`: the IRL step, the human model and the robot's Q, the runs cut
into parts that threads take, :mod:`agents.learning.partner_mdp`), and falls back to the
reference where the kernels are off. :func:`update_models`, the same update from the
tables and parameters as separate arguments, is deprecated.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from types import ModuleType
from typing import NamedTuple

import numpy as np

from agents.learning import mdp
from agents.learning.compiled import (
    check_iteration,
    check_range,
    check_shape,
    contiguous,
    in_parts,
    joined_traces,
    kernels,
    valid_table,
)
from agents.learning.learner_data import Models, Params, Tables, Workspace
from agents.learning.partner_mdp import expected_feature_counts, loop_free_counts, solve_soft
from agents.learning.partner_mdp import preload as preload_kernels
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp

__all__ = ["Models", "Params", "Tables", "Workspace", "preload", "reference_update", "update",
           "update_models"]


def update(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
           last: Models | None = None, *, state_reward: np.ndarray | None = None,
           state_traces: Sequence[np.ndarray] | None = None,
           intentions: np.ndarray | None = None, workspace: Workspace | None = None
           ) -> Models:
    """The Learner's update of its models (Alg. 1 l. 17-22 and 3-5) for B runs in one call.

    1. With ``state_traces``: one ME-IRL step on θ per run whose intention was revealed
       (``intentions[b] >= 0``; -1 keeps θ): the loop-free counts of its trace against the
       counts the soft-max policy (at the IRL temperature) of the human MDP of that
       intention expects (reward θ·φ, the robot's ``pi_r`` substituted), then
       :func:`agents.learning.mdp.irl_step`.
    2. The human model: for every intention, the soft-max solution of the human MDP
       (reward θ·φ with the new θ, ``pi_r`` substituted, at τ_H).
    3. The robot's Q: the soft-max solution of its MDP (the joint reward, the new π̂_H
       substituted, at the robot temperature).

    Every policy iteration is warm-started from ``last``'s greedy actions if given.

    Where the kernels are on, the runs are cut into parts that the threads take in one
    hand-out per call (:func:`~agents.learning.partner_mdp.set_threads`); each part goes
    through the compiled steps (:class:`_CompiledSteps`) with numpy's θ·φ of the new θ
    between the IRL step and the human model: the same numbers, bit for bit, as
    :func:`reference_update`, the path without the kernels.

    Args:
        tables: The graph's tables.
        params: The update's parameters.
        theta: (B, F) θ before the update.
        pi_r: (B, I, S, A) the robot's policies the human model assumed so far.
        last: The models of the last update, whose greedy actions warm-start every policy
            iteration (only ``greedy_h`` and ``greedy_r`` are read); None for the first
            update.
        state_reward: (B, I, S) θ·φ of ``theta`` if the caller has it (``last``'s, when θ has
            not changed since; its values are trusted), to spare computing it again.
        state_traces: B state sequences (each at least one state), or None: no IRL step (the
            models of ``theta``).
        intentions: (B,) int the intention each trace revealed, -1 for none.
        workspace: Where the result is written (:class:`Workspace`: the arrays it was given,
            of the shapes and types of the result and sharing no memory with the inputs;
            all but ``theta``, which is always new when θ changes), or None: new arrays.

    Returns:
        The new :class:`Models`.

    Raises:
        ConfigError: An array of the wrong shape, an index out of range, or what
            :func:`~agents.learning.partner_mdp.solve_soft` refuses.
    """
    warm = None if last is None else (last.greedy_h, last.greedy_r)
    out = None if workspace is None else workspace.take()
    return _update(tables, params, theta, pi_r, warm, state_reward, state_traces, intentions,
                   out)


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
    """Deprecated: :func:`update`, which takes the tables and parameters as objects.

    ``update_models(*tables, theta, pi_r, (greedy_h, greedy_r), gamma=..., ..., out=out)``
    is ``update(Tables(*tables), Params(gamma, ...), theta, pi_r, last, ...,
    workspace=w)`` with ``last`` holding those greedy actions and ``w`` a
    :class:`Workspace` given ``out``. Arguments and results are :func:`update`'s: the five
    tables of :class:`Tables`, then θ, π_R and the warm starts ``(greedy_h, greedy_r)``
    (or None), the six numbers of :class:`Params` by name, and the arrays to write into.
    Kept for one release (CHANGELOG.md, "Deprecated").
    """
    warnings.warn("agents.learning.algorithm1.update_models is deprecated; use "
                  "agents.learning.algorithm1.update(Tables(...), Params(...), theta, pi_r, "
                  "last, ..., workspace=...)", DeprecationWarning, stacklevel=2)
    return _update(Tables(next_state, valid, reward, features, terminal),
                   Params(gamma, human_temperature, robot_temperature, irl_temperature,
                          learning_rate, max_iter),
                   theta, pi_r, warm, state_reward, state_traces, intentions, out)


def _update(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
            warm: tuple[np.ndarray, np.ndarray] | None, state_reward: np.ndarray | None,
            state_traces: Sequence[np.ndarray] | None, intentions: np.ndarray | None,
            out: Models | None) -> Models:
    """:func:`update` from the warm starts ``(greedy_h, greedy_r)`` and the arrays to
    write into (``out``), each or both None: the compiled steps where the kernels are on,
    else the reference.
    """
    batch = _checked(tables, params, theta, pi_r, warm, state_reward, state_traces,
                     intentions, out)
    jit = kernels()
    # (numpy sums a single feature's counts pairwise)
    if jit is None or batch.tables.features.shape[2] < 2:
        made = reference_update(batch.tables, params, batch.theta, batch.pi_r, batch.warm,
                                state_traces, batch.intentions)
        return made if out is None else _written(made, out)
    return _compiled_update(_CompiledSteps(jit, batch, params), batch, out)


class _Batch(NamedTuple):
    """An update's inputs, checked, in the kernels' types (C-contiguous float64 or int64).

    Attributes:
        tables: The tables.
        theta: (B, F) θ before the update.
        pi_r: (B, I, S, A) the robot's policies the human model assumed so far.
        warm: ``(greedy_h, greedy_r)`` (B, I, S) the warm starts, or None.
        state_reward: (B, I, S) θ·φ of ``theta`` if the caller gave it.
        intentions: (B,) the revealed intentions (-1: none), or None: no IRL step.
        states: The traces one after another (with ``intentions``).
        offsets: (B + 1,) trace b is ``states[offsets[b]:offsets[b + 1]]``.
    """

    tables: Tables
    theta: np.ndarray
    pi_r: np.ndarray
    warm: tuple[np.ndarray, np.ndarray] | None
    state_reward: np.ndarray | None
    intentions: np.ndarray | None
    states: np.ndarray | None
    offsets: np.ndarray | None


def _checked(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
             warm: tuple[np.ndarray, np.ndarray] | None, state_reward: np.ndarray | None,
             state_traces: Sequence[np.ndarray] | None, intentions: np.ndarray | None,
             out: Models | None) -> _Batch:
    """The inputs of :func:`_update`, checked before any kernel runs (the kernels index
    without bounds checks).

    Raises:
        ConfigError: An array of the wrong shape, an index out of range, or parameters
            :func:`~agents.learning.partner_mdp.solve_soft` refuses.
    """
    phi = contiguous(np.asarray(tables.features), np.float64)
    th = contiguous(np.asarray(theta), np.float64)
    if phi.ndim != 3 or th.ndim != 2:
        raise ConfigError(f"features must be (I, S, F) and theta (B, F), got shapes "
                          f"{phi.shape} and {th.shape}",
                          field="features" if phi.ndim != 3 else "theta")
    n_i, n_s, n_f = phi.shape
    n_a = np.shape(tables.valid)[-1]
    n_b = len(th)
    nxt = contiguous(np.asarray(tables.next_state), np.int64)
    check_shape("next_state", nxt, (n_s, n_a, n_a))
    check_range("next_state", nxt, 0, n_s)
    ok = valid_table(tables.valid, n_s, n_a)
    joint = contiguous(np.asarray(tables.reward), np.float64)
    check_shape("reward", joint, (n_s, n_a, n_a))
    term = contiguous(np.asarray(tables.terminal), np.int64)
    check_shape("terminal", term, (n_i,))
    check_range("terminal", term, -1, n_s)
    check_shape("theta", th, (n_b, n_f))
    pi = contiguous(np.asarray(pi_r), np.float64)
    check_shape("pi_r", pi, (n_b, n_i, n_s, n_a))
    if warm is not None:
        warm = (contiguous(np.asarray(warm[0]), np.int64),
                contiguous(np.asarray(warm[1]), np.int64))
        for name, w in zip(("greedy_h", "greedy_r"), warm, strict=True):
            check_shape(name, w, (n_b, n_i, n_s))
            check_range(name, w, 0, n_a)
    check_iteration(params.gamma, params.max_iter)
    if state_reward is not None:
        state_reward = contiguous(np.asarray(state_reward), np.float64)
        check_shape("state_reward", state_reward, (n_b, n_i, n_s))
    if out is not None:
        _check_out(out, (n_b, n_i, n_s, n_a))
    intent = states = offsets = None
    if state_traces is not None:
        intent = contiguous(np.asarray(intentions).reshape(-1), np.int64)
        if len(intent) != n_b or len(state_traces) != n_b:
            raise ConfigError(f"give one trace and one intention per run ({n_b}), got "
                              f"{len(state_traces)} and {len(intent)}", field="intentions")
        check_range("intentions", intent, -1, n_i)
        states, offsets = joined_traces(state_traces, n_s)
    return _Batch(Tables(nxt, ok, joint, phi, term), th, pi, warm, state_reward, intent,
                  states, offsets)


def _check_out(out: Models, shape: tuple[int, ...]) -> None:
    """Raise ConfigError unless ``out`` can take :func:`update`'s results."""
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


def _written(made: Models, out: Models) -> Models:
    """``made``, its arrays (all but θ) copied into ``out``'s."""
    for into, value in zip(out[1:], made[1:], strict=True):
        np.copyto(into, value)
    return Models(made.theta, *out[1:])


def _compiled_update(steps: _CompiledSteps, batch: _Batch, out: Models | None) -> Models:
    """Algorithm 1's update from the compiled kernels, run by run in parts.

    The runs are cut into parts that the threads take in one hand-out
    (:func:`~agents.learning.partner_mdp.set_threads`); each part goes through the steps in
    the paper's order, writing into the new models (``out``'s arrays, or new ones).
    """
    features, irl = batch.tables.features, batch.intentions is not None
    n_b, n_i, n_s, n_a = batch.pi_r.shape
    new = _new_models(batch.theta, (n_b, n_i, n_s, n_a), irl, out)
    old_reward = None  # θ·φ of the old θ for the IRL step (the caller's, or numpy's)
    if irl:
        old_reward = (batch.state_reward if batch.state_reward is not None
                      else np.einsum("isf,bf->bis", features, batch.theta))

    def runs(lo: int, hi: int) -> None:
        if old_reward is not None:  # l. 17-19: one ME-IRL step on θ per revealing run
            steps.irl_step(old_reward, new.theta, lo, hi)
        # θ·φ of the new θ: numpy's (its sums' order is numpy's), a part at a time
        np.einsum("isf,bf->bis", features, new.theta[lo:hi], out=new.state_reward[lo:hi])
        steps.human_model(new, lo, hi)  # l. 20-22: π̂_H = softmax(τ_H Q_H) per intention
        steps.robot_model(new, lo, hi)  # l. 3-5: the robot's Q and the policy π̂_H assumes

    in_parts(runs, n_b, mdps=n_b * (2 * n_i + irl))
    return new


def _new_models(theta: np.ndarray, shape: tuple[int, int, int, int], irl: bool,
                out: Models | None) -> Models:
    """The arrays an update writes into: ``out``'s, or new ones; θ new if it changes."""
    theta_new = np.empty_like(theta) if irl else theta
    if out is not None:
        return Models(theta_new, *out[1:])
    return Models(theta_new, np.empty(shape[:3]), np.empty(shape),
                  np.empty(shape[:3], np.int64), np.empty(shape), np.empty(shape),
                  np.empty(shape[:3], np.int64), np.empty(shape))


class _CompiledSteps:
    """Algorithm 1's steps as the compiled kernels (:mod:`agents.learning._jit`) take them.

    The one place where the update's objects (:class:`Tables`, :class:`Params`, the checked
    inputs and the new :class:`Models`) become the flat arrays and plain numbers of an
    ``@njit`` call: numba's kernels take arrays, not the NamedTuples that hold them. Made
    once per update, with the tables the kernels derive from the graph's
    (:func:`~agents.learning._jit.learner_tables`); each step does the runs lo..hi-1 and
    may run in several threads at once.
    """

    def __init__(self, jit: ModuleType, batch: _Batch, params: Params) -> None:
        t = batch.tables
        self._jit, self._batch, self._params = jit, batch, params
        (self._nxt_r, self._nxt_h, self._next_h, self._joint_t, self._vidx, self._n_valid,
         self._rank) = jit.learner_tables(t.next_state, t.valid, t.reward)
        self._warm = batch.warm is not None
        warm = batch.warm
        if warm is None:  # (unread)
            zeros = np.zeros(batch.pi_r.shape[:3], np.int64)
            warm = (zeros, zeros)
        self._warm_h: np.ndarray = warm[0]
        self._warm_r: np.ndarray = warm[1]

    def irl_step(self, state_reward: np.ndarray, theta_out: np.ndarray, lo: int, hi: int
                 ) -> None:
        """Alg. 1 l. 17-19, the IRL step, into ``theta_out``, from θ·φ of the old θ.

        :func:`agents.learning._jit.irl_steps`.
        """
        b, t, p = self._batch, self._batch.tables, self._params
        self._jit.irl_steps(
            self._nxt_h, self._next_h, t.valid, self._vidx, self._n_valid, self._rank,
            t.features, t.terminal, b.theta, state_reward, b.pi_r, self._warm_h, self._warm,
            b.states, b.offsets, b.intentions, float(p.gamma), float(p.irl_temperature),
            int(p.max_iter), float(p.learning_rate), theta_out, lo, hi)

    def human_model(self, new: Models, lo: int, hi: int) -> None:
        """Alg. 1 l. 20-22, the human model, into ``new.q_h``, ``.greedy_h``, ``.pi_h``.

        From ``new.state_reward`` and the π_R of the inputs:
        :func:`agents.learning._jit.human_models`.
        """
        t, p = self._batch.tables, self._params
        self._jit.human_models(
            self._nxt_h, t.valid, self._vidx, self._n_valid, self._rank, t.terminal,
            new.state_reward, self._batch.pi_r, self._warm_h, self._warm, float(p.gamma),
            float(p.human_temperature), int(p.max_iter), new.q_h, new.greedy_h, new.pi_h,
            lo, hi)

    def robot_model(self, new: Models, lo: int, hi: int) -> None:
        """Alg. 1 l. 3-5, the robot's Q, into ``new.q_r``, ``.greedy_r``, ``.pi_r``.

        From ``new.pi_h``: :func:`agents.learning._jit.robot_models`.
        """
        t, p = self._batch.tables, self._params
        self._jit.robot_models(
            self._nxt_r, self._joint_t, t.valid, self._vidx, self._n_valid, self._rank,
            t.terminal, new.pi_h, self._warm_r, self._warm, float(p.gamma),
            float(p.robot_temperature), int(p.max_iter), new.q_r, new.greedy_r, new.pi_r,
            lo, hi)


@task_mdp.one_blas_thread()
def reference_update(tables: Tables, params: Params, theta: np.ndarray, pi_r: np.ndarray,
                     warm: tuple[np.ndarray, np.ndarray] | None = None,
                     state_traces: Sequence[np.ndarray] | None = None,
                     intentions: np.ndarray | None = None) -> Models:
    """Algorithm 1's update for B runs, step by step in numpy (the reference).

    The arguments are those of :func:`update` (checked by it), the last update's greedy
    actions ``(greedy_h, greedy_r)`` as ``warm``; BLAS runs on one thread
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
    tables = Tables(nxt, np.ones((1, 1), np.bool_), np.zeros((1, 1, 1)), np.zeros((1, 1, 2)),
                    zero)
    update(tables, Params(0.5, 1.0, 1.0, 1.0, 0.1), np.zeros((1, 2)), np.ones((1, 1, 1, 1)),
           state_traces=[zero], intentions=zero)
    return True
