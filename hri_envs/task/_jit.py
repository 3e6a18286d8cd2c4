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
from numba import njit, prange

_NEG = -1e300


@njit(cache=True, nogil=True)
def out_of_range(x, low, high):
    """Whether an entry of the int array ``x`` lies outside [low, high) (one pass)."""
    for v in x.ravel():
        if v < low or v >= high:
            return True
    return False


@njit(cache=True, nogil=True)
def _backup_state(next_state, partner_s, values, s, out):
    """out[a] = Σ_p partner_s[p] values[next_state[s, a, p]] for one state ``s``.

    The partner's actions outermost: the sums of the A actions are independent, so they
    proceed together (each still adds its terms in increasing p).
    """
    n_a, n_p = next_state.shape[1], next_state.shape[2]
    for a in range(n_a):
        out[a] = 0.0
    for p in range(n_p):
        w = partner_s[p]
        if w != 0.0:
            for a in range(n_a):
                out[a] += w * values[next_state[s, a, p]]


@njit(cache=True, nogil=True)
def _best_valid(x, valid_s):
    """(max, first argmax) of ``x`` (A,) over the valid actions ``valid_s`` (A,)."""
    best, best_a = -np.inf, 0
    for a in range(x.shape[0]):
        if valid_s[a] and x[a] > best:
            best, best_a = x[a], a
    return best, best_a


@njit(cache=True, nogil=True)
def _partner_backup_range(next_state, partner, values, terminal, out, lo, hi):
    """:func:`partner_backup` of the MDPs lo..hi-1 into ``out``."""
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    for k in range(lo, hi):
        term = terminal[k]
        for s in range(n_s):
            if s == term:
                for a in range(n_a):
                    out[k, s, a] = values[k, s]
            else:
                _backup_state(next_state, partner[k, s], values[k], s, out[k, s])


@njit(cache=True, nogil=True)
def partner_backup(next_state, partner, values, terminal):
    """(N, S, A): Σ_p partner[n, s, p] values[n, next_state[s, a, p]]; terminal rows values."""
    n_b = partner.shape[0]
    out = np.empty((n_b, next_state.shape[0], next_state.shape[1]))
    _partner_backup_range(next_state, partner, values, terminal, out, 0, n_b)
    return out


@njit(cache=True, nogil=True)
def _link(pattern, row_cols, row_n, col_rows, col_n, i, j):
    """Record that entry (i, j) of the matrix may be nonzero (once per entry)."""
    if not pattern[i, j]:
        pattern[i, j] = True
        row_cols[i, row_n[i]] = j
        row_n[i] += 1
        col_rows[j, col_n[j]] = i
        col_n[j] += 1


@njit(cache=True, nogil=True)
def _solve_sparse(m, b, pattern, row_cols, row_n, col_rows, col_n):
    """Solve m x = b into b by Gaussian elimination without pivoting, on the nonzeros only.

    ``m`` (S, S) is dense but overwritten; ``pattern`` (S, S) bool and the lists
    ``row_cols[i, :row_n[i]]`` (columns of row i) and ``col_rows[j, :col_n[j]]`` (rows of
    column j) name its possibly nonzero entries (:func:`_link`); fill-in is added to them.
    The matrices here, I - γ P_π with P_π a (sub-)stochastic matrix and γ < 1, are strictly
    diagonally dominant by rows, which elimination preserves: no pivot is small and no
    pivoting is needed. They have a handful of entries per row and little fill-in, so the
    work is proportional to the entries rather than to S³.
    """
    n = m.shape[0]
    for k in range(n):
        d = m[k, k]
        for t in range(col_n[k]):
            i = col_rows[k, t]
            if i <= k or m[i, k] == 0.0:
                continue
            f = m[i, k] / d
            for u in range(row_n[k]):
                j = row_cols[k, u]
                if j > k:
                    _link(pattern, row_cols, row_n, col_rows, col_n, i, j)
                    m[i, j] -= f * m[k, j]
            b[i] -= f * b[k]
    for k in range(n - 1, -1, -1):
        acc = b[k]
        for u in range(row_n[k]):
            j = row_cols[k, u]
            if j > k:
                acc -= m[k, j] * b[j]
        b[k] = acc / m[k, k]


@njit(cache=True, nogil=True)
def _solve_range(next_state, partner, reward, valid, terminal, gamma, policy, warm, max_iter,
                 q, greedy, lo, hi):
    """:func:`solve_partner_q` of the MDPs lo..hi-1 into ``q``, ``greedy`` (own scratch)."""
    n_s, n_a, n_p = next_state.shape
    m = np.empty((n_s, n_s))
    v = np.empty(n_s)
    act = np.empty(n_s, np.int64)
    pattern = np.empty((n_s, n_s), np.bool_)
    row_cols = np.empty((n_s, n_s), np.int64)
    row_n = np.empty(n_s, np.int64)
    col_rows = np.empty((n_s, n_s), np.int64)
    col_n = np.empty(n_s, np.int64)
    acc = np.empty(n_a)
    for k in range(lo, hi):
        term = terminal[k]
        for s in range(n_s):
            act[s] = policy[k, s] if warm else _best_valid(reward[k, s], valid[s])[1]
        for _ in range(max_iter):
            m[:, :] = 0.0  # I - γ P_π, and where it is nonzero
            pattern[:, :] = False
            row_n[:] = 0
            col_n[:] = 0
            for s in range(n_s):
                m[s, s] = 1.0
                _link(pattern, row_cols, row_n, col_rows, col_n, s, s)
                v[s] = reward[k, s, act[s]]
                if s == term:
                    m[s, s] -= gamma
                    continue
                a = act[s]
                for p in range(n_p):
                    w = partner[k, s, p]
                    if w != 0.0:
                        j = next_state[s, a, p]
                        _link(pattern, row_cols, row_n, col_rows, col_n, s, j)
                        m[s, j] -= gamma * w
            _solve_sparse(m, v, pattern, row_cols, row_n, col_rows, col_n)
            changed = False
            for s in range(n_s):
                if s == term:
                    for a in range(n_a):
                        q[k, s, a] = reward[k, s, a] + gamma * v[term]
                else:
                    _backup_state(next_state, partner[k, s], v, s, acc)
                    for a in range(n_a):
                        q[k, s, a] = reward[k, s, a] + gamma * acc[a]
                best, best_a = _best_valid(q[k, s], valid[s])
                current = q[k, s, act[s]] if valid[s, act[s]] else _NEG
                # Keep the current action on (numerical) ties so the iteration terminates.
                if best - current > 1e-10 * (1.0 + abs(best)):
                    act[s] = best_a
                    changed = True
            if not changed:
                break
        for s in range(n_s):
            greedy[k, s] = _best_valid(q[k, s], valid[s])[1]


@njit(cache=True, nogil=True)
def solve_partner_q(next_state, partner, reward, valid, terminal, gamma, policy,
                    warm, max_iter):
    """(Q (N, S, A), greedy (N, S)) by policy iteration, as ``partner_mdp.solve_partner_q``.

    ``warm``: whether ``policy`` (N, S) holds the starting actions; otherwise each MDP
    starts from the greedy actions of its immediate reward.
    """
    n_b = partner.shape[0]
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    q = np.empty((n_b, n_s, n_a))
    greedy = np.empty((n_b, n_s), np.int64)
    _solve_range(next_state, partner, reward, valid, terminal, gamma, policy, warm, max_iter,
                 q, greedy, 0, n_b)
    return q, greedy


@njit(cache=True, nogil=True)
def _feature_counts_range(next_state, partner, policy, features, start, terminal, horizon,
                          out, lo, hi):
    """:func:`expected_feature_counts` of the MDPs lo..hi-1 into ``out`` (zeros)."""
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


@njit(cache=True, nogil=True)
def expected_feature_counts(next_state, partner, policy, features, start, terminal,
                            horizon):
    """(N, F) expected feature counts, as ``partner_mdp.expected_feature_counts``."""
    n_b = partner.shape[0]
    out = np.zeros((n_b, features.shape[-1]))
    _feature_counts_range(next_state, partner, policy, features, start, terminal, horizon,
                          out, 0, n_b)
    return out


@njit(cache=True, nogil=True, parallel=True)
def expected_feature_counts_par(next_state, partner, policy, features, start, terminal,
                                horizon, n_c):
    """:func:`expected_feature_counts` with the MDPs shared out among numba's threads."""
    n_b = partner.shape[0]
    out = np.zeros((n_b, features.shape[-1]))
    n_c = max(1, min(n_b, n_c))
    for c in prange(n_c):
        _feature_counts_range(next_state, partner, policy, features, start, terminal,
                              horizon, out, c * n_b // n_c, (c + 1) * n_b // n_c)
    return out


@njit(cache=True, nogil=True)
def _partner_reward_range(reward, partner, terminal, out, lo, hi):
    """:func:`partner_reward` of the MDPs lo..hi-1 into ``out`` (zeros)."""
    n_s, n_a, n_p = reward.shape
    for k in range(lo, hi):
        for s in range(n_s):
            if s == terminal[k]:
                continue
            for p in range(n_p):  # outermost: see partner_backup
                w = partner[k, s, p]
                if w != 0.0:
                    for a in range(n_a):
                        out[k, s, a] += w * reward[s, a, p]


@njit(cache=True, nogil=True)
def partner_reward(reward, partner, terminal):
    """(N, S, A): Σ_p partner[n, s, p] reward[s, a, p]; 0 in each MDP's terminal state."""
    n_b = partner.shape[0]
    out = np.zeros((n_b, reward.shape[0], reward.shape[1]))
    _partner_reward_range(reward, partner, terminal, out, 0, n_b)
    return out


@njit(cache=True, nogil=True)
def valid_lists(valid):
    """(S, A) each state's valid actions first, in increasing order, and (S,) their count."""
    n_s, n_a = valid.shape
    idx = np.zeros((n_s, n_a), np.int64)
    count = np.zeros(n_s, np.int64)
    for s in range(n_s):
        for a in range(n_a):
            if valid[s, a]:
                idx[s, count[s]] = a
                count[s] += 1
    return idx, count


@njit(cache=True, nogil=True)
def _softmax_range(q, valid, temperature, out, lo, hi):
    """:func:`softmax` of the MDPs lo..hi-1 into ``out`` (zeros).

    Visits the valid actions only (:func:`valid_lists`), in increasing order: the same
    maximum, exponentials, sum and quotients as a pass over every action that skips the
    invalid ones (a state without valid actions divides 0 by 0: ZeroDivisionError, as
    there).
    """
    n_s, n_a = q.shape[1], q.shape[2]
    idx, count = valid_lists(valid)
    z = np.empty(n_a)
    for k in range(lo, hi):
        for s in range(n_s):
            c = count[s]
            if c == 0:
                raise ZeroDivisionError("float division by zero")
            top = -np.inf
            for u in range(c):
                x = temperature * q[k, s, idx[s, u]]
                z[u] = x
                if x > top:
                    top = x
            total = 0.0
            for u in range(c):
                e = np.exp(z[u] - top)
                z[u] = e
                total += e
            for u in range(c):
                out[k, s, idx[s, u]] = z[u] / total


@njit(cache=True, nogil=True)
def softmax(q, valid, temperature):
    """(N, S, A) soft-max of ``temperature * q`` over the valid actions of each state."""
    out = np.zeros(q.shape)
    _softmax_range(q, valid, temperature, out, 0, q.shape[0])
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


@njit(cache=True, nogil=True)
def loop_free_counts(features, states, offsets, intentions):
    """Loop removal and feature counts per trace, as ``partner_mdp.loop_free_counts``.

    ``states`` holds the traces one after another, trace b in
    ``states[offsets[b]:offsets[b + 1]]`` (at least one state each). Whenever a state
    comes again, the path drops back to its earlier visit (``mdp.remove_loops``); the
    counts then add φ along the path in order, a row at a time, starting from the first
    row (as numpy sums a (T, F) array over its first axis when F > 1).

    Returns:
        ``(counts (B, F), start (B,), horizon (B,))``.
    """
    n_b = offsets.shape[0] - 1
    n_s, n_f = features.shape[1], features.shape[2]
    counts = np.zeros((n_b, n_f))
    start = np.empty(n_b, np.int64)
    horizon = np.empty(n_b, np.int64)
    where = np.full(n_s, -1, np.int64)  # a state's position on the path so far, or -1
    path = np.empty(max(1, states.shape[0]), np.int64)
    for b in range(n_b):
        n = 0
        for t in range(offsets[b], offsets[b + 1]):
            s = states[t]
            i = where[s]
            if i >= 0:  # back at an earlier state: drop the loop
                for u in range(i, n):
                    where[path[u]] = -1
                n = i
            where[s] = n
            path[n] = s
            n += 1
        start[b] = path[0]
        horizon[b] = n
        phi = features[intentions[b]]
        for f in range(n_f):
            counts[b, f] = phi[path[0], f]
        where[path[0]] = -1
        for u in range(1, n):
            where[path[u]] = -1
            for f in range(n_f):
                counts[b, f] += phi[path[u], f]
    return counts, start, horizon


#: MDPs per block of :func:`solve_soft`: the reward, Q and policy of a block are made one
#: after the other while its arrays are in cache.
_BLOCK = 16


@njit(cache=True, nogil=True)
def _solve_soft_range(next_state, partner, values, joint, use_joint, valid, terminal, gamma,
                      policy, warm, max_iter, temperature, r, q, greedy, soft, lo, hi):
    """:func:`solve_soft` of the MDPs lo..hi-1, block by block.

    The rewards of a block go to the scratch ``r`` (:data:`_BLOCK`, S, A). The callers
    allocate it before their outputs: freed last, on top of the heap, it made the C library
    hand memory back to the system and fault it in again on every call.
    """
    for b in range(lo, hi, _BLOCK):
        e = min(b + _BLOCK, hi)
        n = e - b
        r_b = r[:n]
        if use_joint:  # partner_reward adds to zeros; partner_backup sets every entry
            r_b[:] = 0.0
            _partner_reward_range(joint, partner[b:e], terminal[b:e], r_b, 0, n)
        else:
            _partner_backup_range(next_state, partner[b:e], values[b:e], terminal[b:e], r_b,
                                  0, n)
        _solve_range(next_state, partner[b:e], r_b, valid, terminal[b:e], gamma,
                     policy[b:e], warm, max_iter, q[b:e], greedy[b:e], 0, n)
        _softmax_range(q[b:e], valid, temperature, soft[b:e], 0, n)


@njit(cache=True, nogil=True)
def solve_soft(next_state, partner, values, joint, use_joint, valid, terminal, gamma, policy,
               warm, max_iter, temperature, n_c):
    """(Q, greedy, soft-max policy) of N MDPs, as ``partner_mdp.solve_soft``.

    The reward is :func:`partner_reward` of ``joint`` (S, A, P) when ``use_joint``, else
    :func:`partner_backup` of ``values`` (N, S); then :func:`solve_partner_q` and
    :func:`softmax` of its Q at ``temperature``. Each step is the same code as those
    kernels, MDP by MDP, so the numbers are theirs bit for bit. ``n_c`` is unused here (see
    :func:`solve_soft_par`).
    """
    n_b = partner.shape[0]
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    r = np.empty((_BLOCK, n_s, n_a))
    q = np.empty((n_b, n_s, n_a))
    greedy = np.empty((n_b, n_s), np.int64)
    soft = np.zeros((n_b, n_s, n_a))
    _solve_soft_range(next_state, partner, values, joint, use_joint, valid, terminal, gamma,
                      policy, warm, max_iter, temperature, r, q, greedy, soft, 0, n_b)
    return q, greedy, soft


@njit(cache=True, nogil=True, parallel=True)
def solve_soft_par(next_state, partner, values, joint, use_joint, valid, terminal, gamma,
                   policy, warm, max_iter, temperature, n_c):
    """:func:`solve_soft` with the MDPs shared out among ``n_c`` of numba's threads."""
    n_b = partner.shape[0]
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    n_c = max(1, min(n_b, n_c))
    r = np.empty((n_c, _BLOCK, n_s, n_a))
    q = np.empty((n_b, n_s, n_a))
    greedy = np.empty((n_b, n_s), np.int64)
    soft = np.zeros((n_b, n_s, n_a))
    for c in prange(n_c):
        _solve_soft_range(next_state, partner, values, joint, use_joint, valid, terminal,
                          gamma, policy, warm, max_iter, temperature, r[c], q, greedy, soft,
                          c * n_b // n_c, (c + 1) * n_b // n_c)
    return q, greedy, soft
