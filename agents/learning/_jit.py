"""Compiled kernels of :mod:`agents.learning.partner_mdp` (numba, optional).

Imported only by :func:`agents.learning.compiled.kernels` when numba is importable and
``HRI_ENVS_NO_JIT`` is not set. Each kernel is the loop form of a numpy function of
``partner_mdp`` and takes the same (already flattened, C-contiguous, float64 / int64)
arrays: ``next_state`` (S, A, P) int, ``partner`` (N, S, P), ``terminal`` (N,) int with -1
for "no absorbing state". Every step of the learning math runs in
:func:`~agents.learning._jit_mdps.mdps`; the
batch kernels :func:`solve_soft` and :func:`expected_feature_counts` do the MDPs lo..hi-1
into results the caller made, so that threads can share a batch (``partner_mdp``). All
kernels release the GIL. ``cache=True`` compiles once per machine (the compiled code is
kept beside this file, or in ``NUMBA_CACHE_DIR``).

This module is the kernels' one entry: it holds the kernels of ``partner_mdp`` and
re-exports those of :mod:`agents.learning._jit_learner` (Algorithm 1's steps and the feature
counts) and the tables of :mod:`agents.learning._jit_mdps` that callers use. numba keys a
cached kernel by its own file only: after editing ``_jit_mdps.py`` or ``_jit_learner.py``,
delete the ``*.nbi``/``*.nbc`` files of ``agents/learning/__pycache__`` (a kernel of another
file that calls an edited one would otherwise run its cached old code).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from agents.learning._jit_learner import (
    expected_feature_counts,
    human_models,
    irl_steps,
    learner_tables,
    loop_free_path,
    robot_models,
)
from agents.learning._jit_mdps import (
    JOINT_REWARD,
    SOFTMAX,
    SOLVE,
    STATE_REWARD,
    elimination_rank,
    mdps,
    own_last,
    own_last_index,
    placeholders,
    valid_lists,
)

__all__ = [
    "belief_policy",
    "elimination_rank",
    "expected_feature_counts",
    "human_models",
    "irl_steps",
    "learner_tables",
    "loop_free_counts",
    "out_of_range",
    "own_last",
    "own_last_index",
    "partner_backup",
    "partner_reward",
    "robot_models",
    "solve_partner_q",
    "solve_soft",
    "valid_lists",
]


@njit(cache=True, nogil=True)
def out_of_range(x, low, high):
    """Whether an entry of the int array ``x`` lies outside [low, high) (one pass)."""
    for v in x.ravel():
        if v < low or v >= high:
            return True
    return False


@njit(cache=True, nogil=True)
def partner_backup(next_state, partner, values, terminal):
    """(N, S, A): Σ_p partner[n, s, p] values[n, next_state[s, a, p]]; terminal rows values."""
    n_b, n_s, n_a = partner.shape[0], next_state.shape[0], next_state.shape[1]
    out = np.empty((n_b, n_s, n_a))
    _, _, f3, b2, i2, i1, u1 = placeholders()
    mdps(STATE_REWARD, own_last_index(next_state), partner, values, f3, b2, i2, i1, u1, terminal,
          0.0, i2, False, 0, 1.0, out, f3, i2, f3, 0, n_b)
    return out


@njit(cache=True, nogil=True)
def partner_reward(reward, partner, terminal):
    """(N, S, A): Σ_p partner[n, s, p] reward[s, a, p]; 0 in each MDP's terminal state."""
    n_b, n_s, n_a = partner.shape[0], reward.shape[0], reward.shape[1]
    out = np.empty((n_b, n_s, n_a))
    i3, f2, f3, b2, i2, i1, u1 = placeholders()
    mdps(JOINT_REWARD, i3.astype(np.uint64), partner, f2, own_last(reward), b2, i2, i1, u1,
          terminal, 0.0, i2, False, 0, 1.0, out, f3, i2, f3, 0, n_b)
    return out


@njit(cache=True, nogil=True)
def solve_partner_q(next_state, partner, reward, valid, terminal, gamma, policy,
                    warm, max_iter):
    """(Q (N, S, A), greedy (N, S)) by policy iteration, as ``partner_mdp.solve_partner_q``.

    ``warm``: whether ``policy`` (N, S) holds the starting actions; otherwise each MDP
    starts from the greedy actions of its immediate reward.
    """
    n_b, n_s, n_a = partner.shape[0], next_state.shape[0], next_state.shape[1]
    vidx, n_valid = valid_lists(valid)
    q = np.empty((n_b, n_s, n_a))
    greedy = np.empty((n_b, n_s), np.int64)
    _, f2, f3, _, _, _, _ = placeholders()
    nxt_t = own_last_index(next_state)
    mdps(SOLVE, nxt_t, partner, f2, f3, valid, vidx, n_valid, elimination_rank(nxt_t, valid),
          terminal, gamma, policy, warm, max_iter, 1.0, reward, q, greedy, f3, 0, n_b)
    return q, greedy


@njit(cache=True, nogil=True)
def belief_policy(q, belief, states, baseline, valid, temperature, eta):
    """(B, A) bounded soft-max of Σ_ι belief[b, ι] q[b, ι, states[b], :] (baseline < 0: none)."""
    n_b, n_i, _, n_a = q.shape
    out = np.zeros((n_b, n_a))
    mixed = np.empty(n_a)
    for b in range(n_b):
        s = states[b]
        top = -np.inf
        for a in range(n_a):
            acc = 0.0
            for i in range(n_i):
                acc += belief[b, i] * q[b, i, s, a]
            mixed[a] = temperature * acc
            if valid[s, a] and mixed[a] > top:
                top = mixed[a]
        total = 0.0
        for a in range(n_a):
            if valid[s, a]:
                e = np.exp(mixed[a] - top)
                out[b, a] = e
                total += e
        best = 0.0
        for a in range(n_a):
            out[b, a] /= total
            if out[b, a] > best:
                best = out[b, a]
        bound = eta * best
        if baseline[b] >= 0 and out[b, baseline[b]] > bound:
            bound = out[b, baseline[b]]
        bound *= 1 - 1e-12
        kept = 0.0
        for a in range(n_a):
            if out[b, a] >= bound:
                kept += out[b, a]
            else:
                out[b, a] = 0.0
        for a in range(n_a):
            out[b, a] /= kept
    return out


@njit(cache=True, nogil=True)
def loop_free_counts(features, states, offsets, intentions):
    """Loop removal and feature counts per trace, as ``partner_mdp.loop_free_counts``.

    ``states`` holds the traces one after another, trace b in
    ``states[offsets[b]:offsets[b + 1]]`` (at least one state each); see
    :func:`loop_free_path`.

    Returns:
        ``(counts (B, F), start (B,), horizon (B,))``.
    """
    n_b = offsets.shape[0] - 1
    n_s, n_f = features.shape[1], features.shape[2]
    counts = np.zeros((n_b, n_f))
    start = np.empty(n_b, np.int64)
    horizon = np.empty(n_b, np.int64)
    where = np.full(n_s, -1, np.int64)
    path = np.empty(max(1, states.shape[0]), np.int64)
    for b in range(n_b):
        horizon[b] = loop_free_path(features[intentions[b]], states, offsets[b],
                                     offsets[b + 1], where, path, counts, b)
        start[b] = path[0]
    return counts, start, horizon


@njit(cache=True, nogil=True)
def solve_soft(next_state, partner, values, joint, use_joint, valid, terminal, gamma, policy,
               warm, max_iter, temperature, q, greedy, soft, lo, hi):
    """Q, greedy actions and soft-max policy of the MDPs lo..hi-1, as ``partner_mdp.solve_soft``.

    The reward is :func:`partner_reward` of ``joint`` (S, A, P) when ``use_joint``, else
    :func:`partner_backup` of ``values`` (N, S); then :func:`solve_partner_q` and
    :func:`softmax` of its Q at ``temperature``: the steps of :func:`mdps` that those
    kernels take, MDP by MDP, so the numbers are theirs bit for bit. Writes into ``q``
    (N, S, A), ``greedy`` (N, S) and ``soft`` (N, S, A) zeros, which the caller made: the
    threads that share a batch write into one result (arrays each of them allocated and
    freed made the C library map and unmap memory, which stalled both cores).
    """
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    steps = (JOINT_REWARD if use_joint else STATE_REWARD) | SOLVE | SOFTMAX
    vidx, n_valid = valid_lists(valid)
    nxt_t = own_last_index(next_state)
    mdps(steps, nxt_t, partner, values, own_last(joint), valid, vidx, n_valid,
          elimination_rank(nxt_t, valid), terminal, gamma, policy, warm, max_iter, temperature,
          np.empty((1, n_s, n_a)), q, greedy, soft, lo, hi)


