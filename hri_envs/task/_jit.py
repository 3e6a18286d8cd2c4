"""Compiled kernels of :mod:`hri_envs.task.partner_mdp` (numba, optional).

Imported only by :func:`hri_envs.task.partner_mdp.kernels` when numba is importable and
``HRI_ENVS_NO_JIT`` is not set. Each kernel is the loop form of a numpy function of
``partner_mdp`` and takes the same (already flattened, C-contiguous, float64 / int64)
arrays: ``next_state`` (S, A, P) int, ``partner`` (N, S, P), ``terminal`` (N,) int with -1
for "no absorbing state". ``cache=True`` compiles once per machine (the compiled code is
kept beside this file, or in ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_NEG = -1e300


@njit(cache=True, nogil=True, inline="always")
def _support(partner, k, s, idx):
    """Write the partner actions of nonzero probability in state s of MDP k to idx; count."""
    n = 0
    for p in range(partner.shape[2]):
        if partner[k, s, p] != 0.0:
            idx[n] = p
            n += 1
    return n


@njit(cache=True, nogil=True)
def partner_backup(next_state, partner, values, terminal):
    """(N, S, A): Σ_p partner[n, s, p] values[n, next_state[s, a, p]]; terminal rows values."""
    n_b = partner.shape[0]
    n_s, n_a, n_p = next_state.shape
    out = np.empty((n_b, n_s, n_a))
    idx = np.empty(n_p, np.int64)
    for k in range(n_b):
        term = terminal[k]
        for s in range(n_s):
            if s == term:
                for a in range(n_a):
                    out[k, s, a] = values[k, s]
                continue
            n_sup = _support(partner, k, s, idx)
            for a in range(n_a):
                acc = 0.0
                for c in range(n_sup):
                    p = idx[c]
                    acc += partner[k, s, p] * values[k, next_state[s, a, p]]
                out[k, s, a] = acc
    return out


@njit(cache=True, nogil=True)
def _solve_in_place(m, b, cols, count):
    """Solve m x = b into b by Gaussian elimination without pivoting, skipping zeros.

    ``m`` (S, S) is overwritten; ``cols`` (S, S) int and ``count`` (S,) int are scratch
    space (the columns right of the diagonal where each row of U is nonzero). The matrices
    here, I - γ P_π with P_π a (sub-)stochastic matrix and γ < 1, are strictly diagonally
    dominant by rows, which elimination preserves: no pivot is small and no pivoting is
    needed. They have a handful of entries per row and little fill-in, so most updates are
    skipped.
    """
    n = m.shape[0]
    for k in range(n):
        nc = 0
        for j in range(k + 1, n):
            if m[k, j] != 0.0:
                cols[k, nc] = j
                nc += 1
        count[k] = nc
        d = m[k, k]
        for i in range(k + 1, n):
            f = m[i, k]
            if f != 0.0:
                f /= d
                for c in range(nc):
                    j = cols[k, c]
                    m[i, j] -= f * m[k, j]
                b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for c in range(count[k]):
            j = cols[k, c]
            acc -= m[k, j] * b[j]
        b[k] = acc / m[k, k]


@njit(cache=True, nogil=True)
def solve_partner_q(next_state, partner, reward, valid, terminal, gamma, policy,
                    warm, max_iter):
    """(Q (N, S, A), greedy (N, S)) by policy iteration, as ``partner_mdp.solve_partner_q``.

    ``warm``: whether ``policy`` (N, S) holds the starting actions; otherwise each MDP
    starts from the greedy actions of its immediate reward.
    """
    n_b = partner.shape[0]
    n_s, n_a, n_p = next_state.shape
    q = np.empty((n_b, n_s, n_a))
    greedy = np.empty((n_b, n_s), np.int64)
    m = np.empty((n_s, n_s))
    v = np.empty(n_s)
    act = np.empty(n_s, np.int64)
    cols = np.empty((n_s, n_s), np.int64)
    count = np.empty(n_s, np.int64)
    idx = np.empty(n_p, np.int64)
    for k in range(n_b):
        term = terminal[k]
        for s in range(n_s):
            if warm:
                act[s] = policy[k, s]
            else:
                best, best_a = _NEG - 1.0, 0
                for a in range(n_a):
                    x = reward[k, s, a] if valid[s, a] else _NEG
                    if x > best:
                        best, best_a = x, a
                act[s] = best_a
        for _ in range(max_iter):
            m[:, :] = 0.0
            for s in range(n_s):
                m[s, s] = 1.0
                v[s] = reward[k, s, act[s]]
                if s == term:
                    m[s, s] -= gamma
                    continue
                a = act[s]
                for p in range(n_p):
                    w = partner[k, s, p]
                    if w != 0.0:
                        m[s, next_state[s, a, p]] -= gamma * w
            _solve_in_place(m, v, cols, count)
            changed = False
            for s in range(n_s):
                if s == term:
                    for a in range(n_a):
                        q[k, s, a] = reward[k, s, a] + gamma * v[term]
                else:
                    n_sup = _support(partner, k, s, idx)
                    for a in range(n_a):
                        acc = 0.0
                        for c in range(n_sup):
                            p = idx[c]
                            acc += partner[k, s, p] * v[next_state[s, a, p]]
                        q[k, s, a] = reward[k, s, a] + gamma * acc
                best, best_a = _NEG - 1.0, 0
                for a in range(n_a):
                    x = q[k, s, a] if valid[s, a] else _NEG
                    if x > best:
                        best, best_a = x, a
                current = q[k, s, act[s]] if valid[s, act[s]] else _NEG
                # Keep the current action on (numerical) ties so the iteration terminates.
                if best - current > 1e-10 * (1.0 + abs(best)):
                    act[s] = best_a
                    changed = True
            if not changed:
                break
        for s in range(n_s):
            best, best_a = -np.inf, 0
            for a in range(n_a):
                if valid[s, a] and q[k, s, a] > best:
                    best, best_a = q[k, s, a], a
            greedy[k, s] = best_a
    return q, greedy


@njit(cache=True, nogil=True)
def expected_feature_counts(next_state, partner, policy, features, start, terminal,
                            horizon):
    """(N, F) expected feature counts, as ``partner_mdp.expected_feature_counts``."""
    n_b = partner.shape[0]
    n_s, n_a, n_p = next_state.shape
    n_f = features.shape[-1]
    out = np.zeros((n_b, n_f))
    t_pi = np.empty((n_s, n_s))
    d = np.empty(n_s)
    nxt = np.empty(n_s)
    svf = np.empty(n_s)
    for k in range(n_b):
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
    return out


@njit(cache=True, nogil=True)
def partner_reward(reward, partner, terminal):
    """(N, S, A): Σ_p partner[n, s, p] reward[s, a, p]; 0 in each MDP's terminal state."""
    n_b = partner.shape[0]
    n_s, n_a, n_p = reward.shape
    out = np.zeros((n_b, n_s, n_a))
    for k in range(n_b):
        for s in range(n_s):
            if s == terminal[k]:
                continue
            for a in range(n_a):
                acc = 0.0
                for p in range(n_p):
                    w = partner[k, s, p]
                    if w != 0.0:
                        acc += w * reward[s, a, p]
                out[k, s, a] = acc
    return out


@njit(cache=True, nogil=True)
def softmax(q, valid, temperature):
    """(N, S, A) soft-max of ``temperature * q`` over the valid actions of each state."""
    n_b, n_s, n_a = q.shape
    out = np.zeros((n_b, n_s, n_a))
    for k in range(n_b):
        for s in range(n_s):
            top = -np.inf
            for a in range(n_a):
                if valid[s, a]:
                    z = temperature * q[k, s, a]
                    if z > top:
                        top = z
            total = 0.0
            for a in range(n_a):
                if valid[s, a]:
                    e = np.exp(temperature * q[k, s, a] - top)
                    out[k, s, a] = e
                    total += e
            for a in range(n_a):
                out[k, s, a] /= total
    return out


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
