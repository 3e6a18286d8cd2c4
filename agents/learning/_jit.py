"""Compiled kernels of :mod:`agents.learning.partner_mdp` (numba, optional).

Imported only by :func:`agents.learning.partner_mdp.kernels` when numba is importable and
``HRI_ENVS_NO_JIT`` is not set. Each kernel is the loop form of a numpy function of
``partner_mdp`` and takes the same (already flattened, C-contiguous, float64 / int64)
arrays: ``next_state`` (S, A, P) int, ``partner`` (N, S, P), ``terminal`` (N,) int with -1
for "no absorbing state". Every step of the learning math runs in :func:`_mdps`; the
batch kernels :func:`solve_soft` and :func:`expected_feature_counts` do the MDPs lo..hi-1
into results the caller made, so that threads can share a batch (``partner_mdp``). All
kernels release the GIL. ``cache=True`` compiles once per machine (the compiled code is
kept beside this file, or in ``NUMBA_CACHE_DIR``).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

_NEG = -1e300


@njit(cache=True, nogil=True)
def out_of_range(x, low, high):
    """Whether an entry of the int array ``x`` lies outside [low, high) (one pass)."""
    for v in x.ravel():
        if v < low or v >= high:
            return True
    return False


@njit(cache=True, nogil=True)
def _own_last_into(table, out):
    """``out[s, p, a] = table[s, a, p]`` for an (S, A, P) joint table; returns ``out``.

    ``out`` (S, P, A) holds the table with the partner's action before one's own.
    """
    n_s, n_a, n_p = table.shape
    for s in range(n_s):
        for a in range(n_a):
            for p in range(n_p):
                out[s, p, a] = table[s, a, p]
    return out


@njit(cache=True, nogil=True)
def own_last(table):
    """(S, A, P) -> (S, P, A) copy of a joint table: the partner's action before one's own.

    A backup's inner loop over one's own actions then reads consecutive entries.
    """
    n_s, n_a, n_p = table.shape
    return _own_last_into(table, np.empty((n_s, n_p, n_a), table.dtype))


@njit(cache=True, nogil=True)
def own_last_index(table):
    """:func:`own_last` of a table of state indices, as unsigned integers.

    Indexing by an unsigned integer spares the compiled loops numpy's wrap-around of
    negative indices (a shift, a mask and an addition per access); callers have checked
    that the indices are in range.
    """
    n_s, n_a, n_p = table.shape
    return _own_last_into(table, np.empty((n_s, n_p, n_a), np.uint64))


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


@njit(cache=True, nogil=True, inline="always")
def _popcount(x):
    """Number of set bits of the uint64 ``x``."""
    x = x - ((x >> np.uint64(1)) & np.uint64(0x5555555555555555))
    x = (x & np.uint64(0x3333333333333333)) + ((x >> np.uint64(2)) & np.uint64(0x3333333333333333))
    x = (x + (x >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return (x * np.uint64(0x0101010101010101)) >> np.uint64(56)


@njit(cache=True, nogil=True)
def elimination_rank(nxt_t, valid):
    """(S,) uint64: each state's place in the order :func:`_solve_in_place` eliminates in.

    Minimum degree (ties: the lowest state) on the graph that links each state to the
    next state of every pair of valid actions (own and, when both have ``valid``'s
    actions, the partner's; otherwise any partner action), made symmetric: every
    evaluation matrix I - γ P_π has its nonzeros within that pattern. In the natural order
    the wheel's robot matrices take twice the multiply-adds (fill-in); the order does not
    depend on which of the two partners' tables it is given.

    Args:
        nxt_t: (S, P, A) unsigned next states, the partner's action first.
        valid: (S, A) bool valid own actions.
    """
    n_s, n_p, n_a = nxt_t.shape
    one, six, low = np.uint64(1), np.uint64(6), np.uint64(63)
    n_w = (n_s + 63) // 64
    adj = np.zeros((n_s, n_w), np.uint64)
    for s in range(n_s):
        for p in range(n_p):
            if n_p == n_a and not valid[s, p]:
                continue
            for a in range(n_a):
                if valid[s, a]:
                    j = nxt_t[s, p, a]
                    if j != s:
                        adj[s, j >> six] |= one << (j & low)
                        adj[j, s >> 6] |= one << np.uint64(s & 63)
    left = np.zeros(n_w, np.uint64)
    for s in range(n_s):
        left[s >> 6] |= one << np.uint64(s & 63)
    rank = np.empty(n_s, np.uint64)
    nb = np.empty(n_w, np.uint64)
    for t in range(n_s):
        best, best_d = -1, n_s + 1
        for v in range(n_s):
            if left[v >> 6] & (one << np.uint64(v & 63)):
                d = 0
                for w in range(n_w):
                    d += _popcount(adj[v, w] & left[w])
                if d < best_d:
                    best, best_d = v, d
        rank[best] = t
        left[best >> 6] &= ~(one << np.uint64(best & 63))
        for w in range(n_w):  # its remaining neighbours become a clique (the fill-in)
            nb[w] = adj[best, w] & left[w]
        for w in range(n_w):
            bits = nb[w]
            while bits:
                u = (w << 6) | trailing_zeros(bits)
                bits &= bits - one
                for x in range(n_w):
                    adj[u, x] |= nb[x]
                adj[u, u >> 6] &= ~(one << np.uint64(u & 63))
    return rank


@njit(cache=True, nogil=True, inline="always")
def _best(x, k, s, vidx, n_valid):
    """(max, first argmax) of ``x[k, s, :]`` over the valid actions of ``s``.

    ``vidx``, ``n_valid``: :func:`valid_lists`.
    """
    best, best_a = -np.inf, 0
    for u in range(n_valid[s]):
        a = vidx[s, u]
        if x[k, s, a] > best:
            best, best_a = x[k, s, a], a
    return best, best_a


@njit(cache=True, nogil=True)
def _solve_in_place(m, b, bits, cols, n_cols, below):
    """Solve m x = b into b by Gaussian elimination without pivoting, on the nonzeros only.

    ``m`` (S, S) is dense and overwritten. Where it may be nonzero: ``cols[i, :n_cols[i]]``
    are the columns of row i in the order they became so, ``bits[i]`` the same columns as a
    bit set (64 per word), and ``below[j]`` the bit set of the rows other than j whose
    column j may be nonzero; fill-in is added to all three. The matrices here, I - γ P_π
    with P_π a (sub-)stochastic matrix and γ < 1, are strictly diagonally dominant by rows,
    which elimination preserves: no pivot is small and no pivoting is needed. They have a
    handful of entries per row and little fill-in, so the work is proportional to the
    entries rather than to S³.

    Every value is made by the same operations in the same order whatever the bookkeeping
    (rows are updated independently; each back-substitution sum adds its terms in the
    order the row's columns became nonzero), so results do not depend on it bit for bit.
    Indices are unsigned throughout: a signed one costs numpy's wrap-around of negative
    indices on every access.
    """
    n, n_w = np.uint64(m.shape[0]), np.uint64(bits.shape[1])
    one, six, low = np.uint64(1), np.uint64(6), np.uint64(63)
    for k in range(n):
        # Row k gets no more fill: keep only its columns right of the diagonal, in order.
        c = np.uint64(0)
        for u in range(n_cols[k]):
            j = cols[k, u]
            if j > k:
                cols[k, c] = j
                c += one
            else:
                bits[k, j >> six] &= ~(one << (j & low))
        n_cols[k] = c
        d = m[k, k]
        bk = b[k]
        first = (k + one) >> six
        for w in range(first, n_w):
            rows = below[k, w]  # the rows i > k whose column k may be nonzero, in order
            if w == first:
                rows &= ~((one << ((k + one) & low)) - one)
            while rows:
                i = (w << six) | np.uint64(trailing_zeros(rows))
                rows &= rows - one
                mik = m[i, k]
                if mik == 0.0:
                    continue
                f = mik / d
                grows = False
                for v in range(n_w):
                    if bits[k, v] & ~bits[i, v]:
                        grows = True
                        break
                if grows:  # row i gets row k's new columns, in row k's order
                    t = n_cols[i]
                    for u in range(c):
                        j = cols[k, u]
                        bit = one << (j & low)
                        if not bits[i, j >> six] & bit:
                            bits[i, j >> six] |= bit
                            cols[i, t] = j
                            t += one
                            below[j, i >> six] |= one << (i & low)
                    n_cols[i] = t
                for u in range(c):
                    j = cols[k, u]
                    m[i, j] -= f * m[k, j]
                b[i] -= f * bk
    for t in range(n):
        k = n - one - t
        acc = b[k]
        for u in range(n_cols[k]):
            j = cols[k, u]
            acc -= m[k, j] * b[j]
        b[k] = acc / m[k, k]


#: Steps of :func:`_mdps`: the expected reward from a reward per next state
#: (:func:`partner_backup`) or from a joint reward (:func:`partner_reward`), policy
#: iteration (:func:`solve_partner_q`), the soft-max of its Q (:func:`softmax`).
STATE_REWARD, JOINT_REWARD, SOLVE, SOFTMAX = 1, 2, 4, 8


@njit(cache=True, nogil=True)
def _mdps(steps, nxt_t, partner, values, joint_t, valid, vidx, n_valid, rank, terminal, gamma,
          policy, warm, max_iter, temperature, r, q, greedy, soft, lo, hi):
    """The ``steps`` of the MDPs lo..hi-1, one MDP after the other.

    Per MDP: its expected reward (:func:`_expected_reward`), policy iteration (rounds of
    :func:`_evaluation_matrix`, the elimination :func:`_solve_in_place` and
    :func:`_improve`), the soft-max of its Q (:func:`_softmax`).

    The steps are functions of their own that numba inlines here (``inline="always"``),
    and the rounds' loop, its early exit and the elimination's call stay in this function:
    numba counts references to the arrays an inlined function is given (atomic operations,
    one pair per array and call) and LLVM prunes those pairs only where no call and no early
    exit lies between them, so that this function's loops count none (as before the split:
    checked in the LLVM IR). The elimination gets only its own scratch.

    Args:
        steps: Sum of the flags :data:`STATE_REWARD`, :data:`JOINT_REWARD`, :data:`SOLVE`,
            :data:`SOFTMAX`.
        nxt_t: (S, P, A) unsigned next states, the partner's action first
            (:func:`own_last_index`).
        partner: (N, S, P) the partner's policies.
        values: (N, S) reward per next state (STATE_REWARD).
        joint_t: (S, P, A) joint reward, the partner's action first (JOINT_REWARD).
        valid: (S, A) bool valid own actions.
        vidx: (S, A) and ``n_valid`` (S,): :func:`valid_lists` of ``valid``.
        n_valid: See ``vidx``.
        rank: (S,) uint64 each state's place in the elimination order
            (:func:`elimination_rank`; SOLVE).
        terminal: (N,) int absorbing state per MDP, -1 for none.
        gamma: Discount of the policy iteration.
        policy: (N, S) int starting actions of the policy iteration if ``warm``; otherwise
            it starts from the greedy actions of the reward.
        warm: See ``policy``.
        max_iter: Cap on improvement rounds.
        temperature: Of the soft-max.
        r: (N, S, A) the expected rewards, written by a reward step and read by SOLVE; or
            (1, S, A) scratch that each MDP reuses (its shape gives S and A).
        q: (N, S, A) Q: written by SOLVE, read by SOFTMAX.
        greedy: (N, S) int: written by SOLVE.
        soft: (N, S, A) zeros: the soft-max policies, written by SOFTMAX.
        lo: First MDP.
        hi: One past the last MDP.
    """
    n_s, n_a = r.shape[1], r.shape[2]
    m, v, v_ranked, act, bits, below, cols, n_cols = _scratch(n_s)
    z = np.empty(n_a)
    state_reward = (steps & STATE_REWARD) != 0
    for k in range(lo, hi):
        o = k if r.shape[0] > 1 else 0
        term = terminal[k]
        # With a warm start, the expected reward of a state reward is made in the first
        # round's backup, which reads the same next states (each sum takes the same terms
        # in the same order); the evaluation before it needs only the current actions'.
        fill = state_reward and (steps & SOLVE) != 0 and warm
        if steps & (STATE_REWARD | JOINT_REWARD) and not fill:
            _expected_reward(state_reward, k, term, nxt_t, partner, values, joint_t, r, o)
        if steps & SOLVE:
            for s in range(n_s):
                act[s] = policy[k, s] if warm else _best(r, o, s, vidx, n_valid)[1]
            for _ in range(max_iter):
                _evaluation_matrix(k, term, o, fill, act, nxt_t, partner, values, r, rank,
                                   gamma, m, v_ranked, bits, below, cols, n_cols)
                _solve_in_place(m, v_ranked, bits, cols, n_cols, below)
                for s in range(n_s):
                    v[s] = v_ranked[rank[s]]
                changed = _improve(k, term, o, fill, act, v, nxt_t, partner, values, r, valid,
                                   vidx, n_valid, gamma, z, q)
                fill = False
                if not changed:
                    break
            for s in range(n_s):
                greedy[k, s] = _best(q, k, s, vidx, n_valid)[1]
        if steps & SOFTMAX:
            _softmax(k, q, vidx, n_valid, temperature, z, soft)


@njit(cache=True, nogil=True, inline="always")
def _scratch(n_s):
    """The policy iteration's scratch for S states, made once per :func:`_mdps` call.

    ``(m, v, v_ranked, act, bits, below, cols, n_cols)``: the (S, S) matrix I - γ P_π, the
    values (S,) by state and by elimination rank, the current actions (S,) int, and the
    bookkeeping of :func:`_solve_in_place` (unsigned: see there).
    """
    n_w = (n_s + 63) // 64
    return (np.empty((n_s, n_s)), np.empty(n_s), np.empty(n_s), np.empty(n_s, np.int64),
            np.zeros((n_s, n_w), np.uint64), np.zeros((n_s, n_w), np.uint64),
            np.empty((n_s, n_s), np.uint64), np.empty(n_s, np.uint64))


@njit(cache=True, nogil=True, inline="always")
def _expected_reward(state_reward, k, term, nxt_t, partner, values, joint_t, r, o):
    """``r[o, s, a]``: MDP k's expected immediate reward of each own action.

    With ``state_reward``: Σ_p partner[k, s, p] values[k, next state] (the absorbing state
    ``term``: its own value); otherwise Σ_p partner[k, s, p] joint_t[s, p, a] (0 in ``term``).
    """
    n_s, n_p, n_a = r.shape[1], partner.shape[2], r.shape[2]
    for s in range(n_s):
        if s == term and state_reward:
            for a in range(n_a):
                r[o, s, a] = values[k, s]
            continue
        for a in range(n_a):
            r[o, s, a] = 0.0
        if s == term:
            continue
        for p in range(n_p):  # outermost: the A sums proceed together, each in p
            w = partner[k, s, p]
            if w != 0.0:
                if state_reward:
                    for a in range(n_a):
                        r[o, s, a] += w * values[k, nxt_t[s, p, a]]
                else:
                    for a in range(n_a):
                        r[o, s, a] += w * joint_t[s, p, a]


@njit(cache=True, nogil=True, inline="always")
def _evaluation_matrix(k, term, o, fill, act, nxt_t, partner, values, r, rank, gamma, m,
                       v_ranked, bits, below, cols, n_cols):
    """The policy evaluation of MDP k's actions ``act``, (I - γ P_π) v = r_π, for
    :func:`_solve_in_place`: ``m``, the right-hand side ``v_ranked``, and where ``m`` may be
    nonzero (``bits``, ``below``, ``cols``, ``n_cols``).

    Row and column ``rank[s]`` are state s's (the elimination order). With ``fill`` the
    right-hand side is summed from the state reward ``values[k]`` (``r[o]`` is not made
    yet: see :func:`_mdps`).
    """
    n_s, n_p = r.shape[1], partner.shape[2]
    one, six, low = np.uint64(1), np.uint64(6), np.uint64(63)
    m[:, :] = 0.0  # I - γ P_π, and where it is nonzero
    bits[:, :] = 0
    below[:, :] = 0
    for s in range(n_s):  # row and column rank[s] are state s's
        i = rank[s]
        m[i, i] = 1.0
        bits[i, i >> six] = one << (i & low)
        cols[i, 0] = i
        n_cols[i] = 1
        a = act[s]
        if s == term:
            v_ranked[i] = values[k, s] if fill else r[o, s, a]
            m[i, i] -= gamma
            continue
        x = 0.0 if fill else r[o, s, a]
        for p in range(n_p):
            w = partner[k, s, p]
            if w != 0.0:
                if fill:
                    x += w * values[k, nxt_t[s, p, a]]
                j = rank[nxt_t[s, p, a]]
                bit = one << (j & low)
                if not bits[i, j >> six] & bit:
                    bits[i, j >> six] |= bit
                    cols[i, n_cols[i]] = j
                    n_cols[i] += one
                    below[j, i >> six] |= one << (i & low)
                m[i, j] -= gamma * w
        v_ranked[i] = x


@njit(cache=True, nogil=True, inline="always")
def _improve(k, term, o, fill, act, v, nxt_t, partner, values, r, valid, vidx, n_valid, gamma,
             z, q):
    """MDP k's Q of the values ``v`` into ``q[k]``; moves ``act`` to better actions.

    Q(s, a) = r(s, a) + γ Σ_p partner(p|s) v(next state) (with ``fill``, ``r[o]`` is
    summed from ``values[k]`` in the same pass). A state's action changes only where the
    best valid action is better by more than a numerical tie, so the iteration ends.
    Returns whether any action changed.
    """
    n_s, n_p, n_a = r.shape[1], partner.shape[2], r.shape[2]
    changed = False
    for s in range(n_s):
        if s == term:
            for a in range(n_a):
                if fill:
                    r[o, s, a] = values[k, s]
                q[k, s, a] = r[o, s, a] + gamma * v[term]
        else:
            for a in range(n_a):  # Σ_p partner(p|s) v(next) first, as in the evaluation
                z[a] = 0.0
                if fill:
                    r[o, s, a] = 0.0
            for p in range(n_p):
                w = partner[k, s, p]
                if w != 0.0:
                    if fill:
                        for a in range(n_a):
                            j = nxt_t[s, p, a]
                            r[o, s, a] += w * values[k, j]
                            z[a] += w * v[j]
                    else:
                        for a in range(n_a):
                            z[a] += w * v[nxt_t[s, p, a]]
            for a in range(n_a):
                q[k, s, a] = r[o, s, a] + gamma * z[a]
        best, best_a = _best(q, k, s, vidx, n_valid)
        current = q[k, s, act[s]] if valid[s, act[s]] else _NEG
        # Keep the current action on (numerical) ties so the iteration ends.
        if best - current > 1e-10 * (1.0 + abs(best)):
            act[s] = best_a
            changed = True
    return changed


@njit(cache=True, nogil=True, inline="always")
def _softmax(k, q, vidx, n_valid, temperature, z, soft):
    """``soft[k]``: the soft-max of ``temperature * q[k]`` over each state's valid actions.

    Over the valid actions only, in increasing order: the same maximum, exponentials, sum
    and quotients as a pass over every action that skips the invalid ones (a state without
    valid actions divides 0 by 0 as there). ``z`` (A,) is scratch.
    """
    for s in range(q.shape[1]):
        c = n_valid[s]
        if c == 0:
            raise ZeroDivisionError("float division by zero")
        top = -np.inf
        for u in range(c):
            x = temperature * q[k, s, vidx[s, u]]
            z[u] = x
            if x > top:
                top = x
        total = 0.0
        for u in range(c):
            e = np.exp(z[u] - top)
            z[u] = e
            total += e
        for u in range(c):
            soft[k, s, vidx[s, u]] = z[u] / total


@njit(cache=True, nogil=True)
def _unused():
    """Placeholders for the arrays of :func:`_mdps` that a kernel's steps do not read.

    Int (1, 1, 1), float (1, 1), float (1, 1, 1), bool (1, 1), int (1, 1), int (1,),
    uint (1,).
    """
    return (np.zeros((1, 1, 1), np.int64), np.zeros((1, 1)), np.zeros((1, 1, 1)),
            np.zeros((1, 1), np.bool_), np.zeros((1, 1), np.int64), np.zeros(1, np.int64),
            np.zeros(1, np.uint64))


@njit(cache=True, nogil=True)
def partner_backup(next_state, partner, values, terminal):
    """(N, S, A): Σ_p partner[n, s, p] values[n, next_state[s, a, p]]; terminal rows values."""
    n_b, n_s, n_a = partner.shape[0], next_state.shape[0], next_state.shape[1]
    out = np.empty((n_b, n_s, n_a))
    _, _, f3, b2, i2, i1, u1 = _unused()
    _mdps(STATE_REWARD, own_last_index(next_state), partner, values, f3, b2, i2, i1, u1, terminal,
          0.0, i2, False, 0, 1.0, out, f3, i2, f3, 0, n_b)
    return out


@njit(cache=True, nogil=True)
def partner_reward(reward, partner, terminal):
    """(N, S, A): Σ_p partner[n, s, p] reward[s, a, p]; 0 in each MDP's terminal state."""
    n_b, n_s, n_a = partner.shape[0], reward.shape[0], reward.shape[1]
    out = np.empty((n_b, n_s, n_a))
    i3, f2, f3, b2, i2, i1, u1 = _unused()
    _mdps(JOINT_REWARD, i3.astype(np.uint64), partner, f2, own_last(reward), b2, i2, i1, u1,
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
    _, f2, f3, _, _, _, _ = _unused()
    nxt_t = own_last_index(next_state)
    _mdps(SOLVE, nxt_t, partner, f2, f3, valid, vidx, n_valid, elimination_rank(nxt_t, valid),
          terminal, gamma, policy, warm, max_iter, 1.0, reward, q, greedy, f3, 0, n_b)
    return q, greedy


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


@njit(cache=True, nogil=True, inline="always")
def _loop_free_path(phi, states, t0, t1, where, path, counts, b):
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
def loop_free_counts(features, states, offsets, intentions):
    """Loop removal and feature counts per trace, as ``partner_mdp.loop_free_counts``.

    ``states`` holds the traces one after another, trace b in
    ``states[offsets[b]:offsets[b + 1]]`` (at least one state each); see
    :func:`_loop_free_path`.

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
        horizon[b] = _loop_free_path(features[intentions[b]], states, offsets[b],
                                     offsets[b + 1], where, path, counts, b)
        start[b] = path[0]
    return counts, start, horizon


@njit(cache=True, nogil=True)
def solve_soft(next_state, partner, values, joint, use_joint, valid, terminal, gamma, policy,
               warm, max_iter, temperature, q, greedy, soft, lo, hi):
    """Q, greedy actions and soft-max policy of the MDPs lo..hi-1, as ``partner_mdp.solve_soft``.

    The reward is :func:`partner_reward` of ``joint`` (S, A, P) when ``use_joint``, else
    :func:`partner_backup` of ``values`` (N, S); then :func:`solve_partner_q` and
    :func:`softmax` of its Q at ``temperature``: the steps of :func:`_mdps` that those
    kernels take, MDP by MDP, so the numbers are theirs bit for bit. Writes into ``q``
    (N, S, A), ``greedy`` (N, S) and ``soft`` (N, S, A) zeros, which the caller made: the
    threads that share a batch write into one result (arrays each of them allocated and
    freed made the C library map and unmap memory, which stalled both cores).
    """
    n_s, n_a = next_state.shape[0], next_state.shape[1]
    steps = (JOINT_REWARD if use_joint else STATE_REWARD) | SOLVE | SOFTMAX
    vidx, n_valid = valid_lists(valid)
    nxt_t = own_last_index(next_state)
    _mdps(steps, nxt_t, partner, values, own_last(joint), valid, vidx, n_valid,
          elimination_rank(nxt_t, valid), terminal, gamma, policy, warm, max_iter, temperature,
          np.empty((1, n_s, n_a)), q, greedy, soft, lo, hi)


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
        human's tables for :func:`_mdps` (unsigned, the partner's action first), the
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
        nxt_h: (S, P, A) unsigned, the human's table for :func:`_mdps` (the robot first).
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
        horizon[0] = _loop_free_path(features[i], states, offsets[b], offsets[b + 1], where,
                                     path, counts, 0)
        start[0] = path[0]
        soft[:, :, :] = 0.0
        _mdps(STATE_REWARD | SOLVE | SOFTMAX, nxt_h, pi_r[b, i:i + 1], r_state[b, i:i + 1],
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
        nxt_h: (S, P, A) unsigned, the human's table for :func:`_mdps` (the robot first),
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
    _mdps(STATE_REWARD | SOLVE | SOFTMAX, nxt_h, pi_r.reshape(n, n_s, n_a),
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
        nxt_r: (S, P, A) unsigned, the robot's table for :func:`_mdps` (the human first),
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
    _mdps(JOINT_REWARD | SOLVE | SOFTMAX, nxt_r, pi_h.reshape(n, n_s, n_a), np.zeros((1, 1)),
          joint_t, valid, vidx, n_valid, rank, _goals(terminal, n, first, last), gamma,
          warm_r.reshape(n, n_s), warm, max_iter, temperature, np.empty((1, n_s, n_a)),
          q_r.reshape(n, n_s, n_a), greedy_r.reshape(n, n_s), soft, first, last)


@njit(cache=True, nogil=True, inline="always")
def _goals(terminal, n, first, last):
    """(N,) int the absorbing state of each of a batch's N = B * I MDPs (set for first..last-1).

    The runs' MDPs lie one after another, run b's intention ι as MDP b * I + ι, so that
    one :func:`_mdps` call per model takes a part of the runs, on views made once (a view
    per run made the threads count references on the same arrays).
    """
    n_i = terminal.shape[0]
    goal = np.empty(n, np.int64)
    for k in range(first, last):
        goal[k] = terminal[k % n_i]
    return goal
