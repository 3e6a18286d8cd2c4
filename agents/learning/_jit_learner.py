"""Algorithm 1's compiled steps (numba): the tables an update makes once
(:func:`learner_tables`), the ME-IRL step (:func:`irl_steps`), the human model
(:func:`human_models`) and the robot model (:func:`robot_models`), each for runs lo..hi-1,
as :class:`agents.learning.algorithm1._CompiledSteps` calls them; and the loop-free counts
of one trace they share with :func:`agents.learning._jit.loop_free_counts`.

Imported through :mod:`agents.learning._jit` (which re-exports the steps). numba's
``cache=True`` keys a compiled function by its own file only: after editing this file,
delete the ``*.nbi``/``*.nbc`` files of ``agents/learning/__pycache__`` so that
:mod:`~agents.learning._jit`'s kernels are compiled again.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from agents.learning._jit_mdps import (
    JOINT_REWARD,
    SOFTMAX,
    SOLVE,
    STATE_REWARD,
    elimination_rank,
    mdps,
    own_last,
    own_last_index,
    valid_lists,
)


@njit(cache=True, nogil=True, inline="always")
def loop_free_path(phi, states, t0, t1, where, path, counts, b):
    """Loop removal and feature counts of the trace ``states[t0:t1]``; its path's length.

    Whenever a state comes again, the path drops back to its earlier visit
    (``mdp.remove_loops``); ``counts[b]`` then adds ``phi`` (S, F) along the path in order, a
    row at a time, starting from the first row (as numpy sums a (T, F) array over its first
    axis when F > 1). The path is left in ``path``; ``where`` (S,), a state's position on
    the path or -1, is all -1 before and after.
    """
    n_f = phi.shape[1]
    n = 0
    for t in range(t0, t1):
        s = states[t]
        i = where[s]
        if i >= 0:  # back at an earlier state: drop the loop
            for u in range(i, n):
                where[path[u]] = -1
            n = i
        where[s] = n
        path[n] = s
        n += 1
    for f in range(n_f):
        counts[b, f] = phi[path[0], f]
    where[path[0]] = -1
    for u in range(1, n):
        where[path[u]] = -1
        for f in range(n_f):
            counts[b, f] += phi[path[u], f]
    return n


@njit(cache=True, nogil=True)
def learner_tables(next_r, valid, reward):
    """The tables :func:`irl_steps`, :func:`human_models` and :func:`robot_models` take, made
    once per update.

    Args:
        next_r: (S, A_R, A_H) int the robot's joint table (the human's is its transpose).
        valid: (S, A) bool valid actions of both partners.
        reward: (S, A_R, A_H) the robot's joint reward.

    Returns:
        ``(nxt_r, nxt_h, next_h, joint_t, vidx, n_valid, rank)``: the robot's and the
        human's tables for :func:`mdps` (unsigned, the partner's action first), the
        human's joint table (int, own action first, for :func:`expected_feature_counts`),
        the reward with the human's action first, :func:`valid_lists` and
        :func:`elimination_rank` (the same for both partners).
    """
    nxt_r = own_last_index(next_r)
    vidx, n_valid = valid_lists(valid)
    return (nxt_r, next_r.astype(np.uint64), own_last(next_r), own_last(reward), vidx,
            n_valid, elimination_rank(nxt_r, valid))


@njit(cache=True, nogil=True)
def irl_steps(nxt_h, next_h, valid, vidx, n_valid, rank, features, terminal, theta, r_state,
              pi_r, warm_h, warm, states, offsets, intentions, gamma, temperature, max_iter,
              learning_rate, theta_out, lo, hi):
    """One ME-IRL step of each run lo..hi-1 into ``theta_out`` (the Learner's, run by run).

    For run b whose ``intentions[b]`` ι >= 0: the loop-free counts of its trace
    (:func:`loop_free_counts`), the soft-max policy of the human MDP of ι at
    ``temperature`` (:func:`solve_soft` with the state reward ``r_state[b, ι]`` and the
    partner ``pi_r[b, ι]``, warm-started from ``warm_h[b, ι]`` if ``warm``), its expected
    feature counts (:func:`expected_feature_counts`), then ``mdp.irl_step``: θ plus
    ``learning_rate`` times the difference, rescaled to max |θ| = 1. A run with ι < 0 keeps
    its θ. Each number is made by the same operations as those functions make it.

    Args:
        nxt_h: (S, P, A) unsigned, the human's table for :func:`mdps` (the robot first).
        next_h: (S, A, P) int the human's joint table (own action first).
        valid: (S, A) bool.
        vidx: See :func:`learner_tables`, as ``n_valid`` and ``rank``.
        n_valid: See ``vidx``.
        rank: See ``vidx``.
        features: (I, S, F) φ.
        terminal: (I,) int absorbing state of each intention's MDP.
        theta: (B, F) θ before the step.
        r_state: (B, I, S) the state reward θ·φ(s, ι) of ``theta``.
        pi_r: (B, I, S, P) the robot's policies the human model assumes.
        warm_h: (B, I, S) int starting actions of the human's policy iteration.
        warm: Whether ``warm_h`` is used.
        states: The traces one after another; run b's is ``states[offsets[b]:offsets[b+1]]``.
        offsets: (B + 1,) int.
        intentions: (B,) int the revealed intention, -1 for none.
        gamma: Discount.
        temperature: Of the soft-max (the IRL temperature).
        max_iter: Cap on improvement rounds.
        learning_rate: λ.
        theta_out: (B, F) written for the runs lo..hi-1.
        lo: First run.
        hi: One past the last run.
    """
    n_s, n_f, n_a = features.shape[1], features.shape[2], valid.shape[1]
    r = np.empty((1, n_s, n_a))
    q = np.empty((1, n_s, n_a))
    greedy = np.empty((1, n_s), np.int64)
    soft = np.empty((1, n_s, n_a))
    expected = np.empty((1, n_f))
    counts = np.empty((1, n_f))
    start = np.empty(1, np.int64)
    horizon = np.empty(1, np.int64)
    where = np.full(n_s, -1, np.int64)
    path = np.empty(max(1, states.shape[0]), np.int64)
    unused = np.zeros((1, 1, 1))
    for b in range(lo, hi):
        i = intentions[b]
        if i < 0:
            for f in range(n_f):
                theta_out[b, f] = theta[b, f]
            continue
        horizon[0] = loop_free_path(features[i], states, offsets[b], offsets[b + 1], where,
                                     path, counts, 0)
        start[0] = path[0]
        soft[:, :, :] = 0.0
        mdps(STATE_REWARD | SOLVE | SOFTMAX, nxt_h, pi_r[b, i:i + 1], r_state[b, i:i + 1],
              unused, valid, vidx, n_valid, rank, terminal[i:i + 1], gamma,
              warm_h[b, i:i + 1], warm, max_iter, temperature, r, q, greedy, soft, 0, 1)
        expected[:, :] = 0.0
        expected_feature_counts(next_h, pi_r[b, i:i + 1], soft, features[i:i + 1], start,
                                terminal[i:i + 1], horizon, expected, 0, 1)
        scale = 0.0
        for f in range(n_f):
            x = theta[b, f] + learning_rate * (counts[0, f] - expected[0, f])
            theta_out[b, f] = x
            scale = max(scale, abs(x))
        if scale > 0:
            for f in range(n_f):
                theta_out[b, f] /= scale


@njit(cache=True, nogil=True)
def human_models(nxt_h, valid, vidx, n_valid, rank, terminal, r_state, pi_r, warm_h, warm,
                 gamma, temperature, max_iter, q_h, greedy_h, pi_h, lo, hi):
    """The human model of the runs lo..hi-1 (Alg. 1 l. 20-22, the Learner's).

    For each intention ι of run b: :func:`solve_soft` of the human MDP (state reward
    ``r_state[b, ι]``, the robot's policy ``pi_r[b, ι]`` substituted, soft-max at
    ``temperature``, the human's τ_H) into ``q_h``, ``greedy_h`` and ``pi_h``,
    warm-started from ``warm_h`` if ``warm``. The numbers are :func:`solve_soft`'s bit for
    bit (its steps, MDP by MDP).

    Args:
        nxt_h: (S, P, A) unsigned, the human's table for :func:`mdps` (the robot first),
            and the valid actions' lists and the elimination order: :func:`learner_tables`;
            the same for ``vidx``, ``n_valid`` and ``rank``.
        valid: (S, A) bool (both partners').
        vidx: See ``nxt_h``.
        n_valid: See ``nxt_h``.
        rank: See ``nxt_h``.
        terminal: (I,) int absorbing state of each intention's MDP.
        r_state: (B, I, S) the human's state reward θ·φ(·, ι) per run and intention.
        pi_r: (B, I, S, A) the robot's policies the human model assumes.
        warm_h: (B, I, S) int starting actions of the policy iterations.
        warm: Whether ``warm_h`` is used.
        gamma: Discount.
        temperature: τ_H of the human model's soft-max.
        max_iter: Cap on improvement rounds.
        q_h: Outputs, (B, I, S, A) floats and (B, I, S) ints, written for runs lo..hi-1;
            the same for ``greedy_h`` and ``pi_h``.
        greedy_h: See ``q_h``.
        pi_h: See ``q_h``.
        lo: First run.
        hi: One past the last run.
    """
    n_b, n_i, n_s = r_state.shape
    n, n_a = n_b * n_i, valid.shape[1]
    first, last = lo * n_i, hi * n_i  # run b's intention ι is MDP b * I + ι (see _goals)
    soft = pi_h.reshape(n, n_s, n_a)
    soft[first:last] = 0.0
    mdps(STATE_REWARD | SOLVE | SOFTMAX, nxt_h, pi_r.reshape(n, n_s, n_a),
          r_state.reshape(n, n_s), np.zeros((1, 1, 1)), valid, vidx, n_valid, rank,
          _goals(terminal, n, first, last), gamma, warm_h.reshape(n, n_s), warm, max_iter,
          temperature, np.empty((1, n_s, n_a)), q_h.reshape(n, n_s, n_a),
          greedy_h.reshape(n, n_s), soft, first, last)


@njit(cache=True, nogil=True)
def robot_models(nxt_r, joint_t, valid, vidx, n_valid, rank, terminal, pi_h, warm_r, warm,
                 gamma, temperature, max_iter, q_r, greedy_r, pi_r, lo, hi):
    """The robot's Q of the runs lo..hi-1 and the robot policy the human model assumes
    (Alg. 1 l. 3-5, the Learner's).

    For each intention ι of run b: :func:`solve_soft` of the robot's MDP (the joint reward,
    the human model ``pi_h[b, ι]`` substituted, soft-max at ``temperature``) into ``q_r``,
    ``greedy_r`` and ``pi_r``, warm-started from ``warm_r`` if ``warm``. The numbers are
    :func:`solve_soft`'s bit for bit (its steps, MDP by MDP).

    Args:
        nxt_r: (S, P, A) unsigned, the robot's table for :func:`mdps` (the human first),
            ``joint_t`` the robot's joint reward with the human's action first, and the
            valid actions' lists and the elimination order: :func:`learner_tables`; the
            same for ``vidx``, ``n_valid`` and ``rank``.
        joint_t: See ``nxt_r``.
        valid: (S, A) bool (both partners').
        vidx: See ``nxt_r``.
        n_valid: See ``nxt_r``.
        rank: See ``nxt_r``.
        terminal: (I,) int absorbing state of each intention's MDP.
        pi_h: (B, I, S, A) the human model π̂_H (:func:`human_models`).
        warm_r: (B, I, S) int starting actions of the policy iterations.
        warm: Whether ``warm_r`` is used.
        gamma: Discount.
        temperature: Of the robot policy the human model assumes.
        max_iter: Cap on improvement rounds.
        q_r: Outputs, (B, I, S, A) floats and (B, I, S) ints, written for runs lo..hi-1;
            the same for ``greedy_r`` and ``pi_r``.
        greedy_r: See ``q_r``.
        pi_r: See ``q_r``.
        lo: First run.
        hi: One past the last run.
    """
    n_b, n_i, n_s, n_a = pi_h.shape
    n = n_b * n_i
    first, last = lo * n_i, hi * n_i  # run b's intention ι is MDP b * I + ι (see _goals)
    soft = pi_r.reshape(n, n_s, n_a)
    soft[first:last] = 0.0
    mdps(JOINT_REWARD | SOLVE | SOFTMAX, nxt_r, pi_h.reshape(n, n_s, n_a), np.zeros((1, 1)),
          joint_t, valid, vidx, n_valid, rank, _goals(terminal, n, first, last), gamma,
          warm_r.reshape(n, n_s), warm, max_iter, temperature, np.empty((1, n_s, n_a)),
          q_r.reshape(n, n_s, n_a), greedy_r.reshape(n, n_s), soft, first, last)


@njit(cache=True, nogil=True, inline="always")
def _goals(terminal, n, first, last):
    """(N,) int the absorbing state of each of a batch's N = B * I MDPs (set for first..last-1).

    The runs' MDPs lie one after another, run b's intention ι as MDP b * I + ι, so that
    one :func:`mdps` call per model takes a part of the runs, on views made once (a view
    per run made the threads count references on the same arrays).
    """
    n_i = terminal.shape[0]
    goal = np.empty(n, np.int64)
    for k in range(first, last):
        goal[k] = terminal[k % n_i]
    return goal


@njit(cache=True, nogil=True)
def expected_feature_counts(next_state, partner, policy, features, start, terminal, horizon,
                            out, lo, hi):
    """Expected feature counts of the MDPs lo..hi-1 into ``out`` (N, F) zeros.

    As ``partner_mdp.expected_feature_counts``; the caller makes ``out`` (see
    :func:`solve_soft`).
    """
    n_s, n_a, n_p = next_state.shape
    n_f = features.shape[-1]
    t_pi = np.empty((n_s, n_s))
    d = np.empty(n_s)
    nxt = np.empty(n_s)
    svf = np.empty(n_s)
    for k in range(lo, hi):
        t_pi[:, :] = 0.0
        for s in range(n_s):
            if s == terminal[k]:
                continue
            for a in range(n_a):
                wa = policy[k, s, a]
                if wa == 0.0:
                    continue
                for p in range(n_p):
                    w = partner[k, s, p]
                    if w != 0.0:
                        t_pi[s, next_state[s, a, p]] += wa * w
        d[:] = 0.0
        d[start[k]] = 1.0
        svf[:] = d
        for _ in range(1, horizon[k]):
            nxt[:] = 0.0
            for s in range(n_s):
                x = d[s]
                if x != 0.0:
                    for z in range(n_s):
                        nxt[z] += x * t_pi[s, z]
            for s in range(n_s):
                d[s] = nxt[s]
                svf[s] += nxt[s]
        for s in range(n_s):
            x = svf[s]
            if x != 0.0:
                for f in range(n_f):
                    out[k, f] += x * features[k, s, f]
