"""The loop every compiled learning kernel runs: :func:`mdps` does a chosen sequence of steps
(:data:`STATE_REWARD`, :data:`JOINT_REWARD`, :data:`SOLVE`, :data:`SOFTMAX`) for MDPs
lo..hi-1, with the tables it takes (:func:`own_last`, :func:`own_last_index`,
:func:`valid_lists`), the elimination order of its policy evaluation
(:func:`elimination_rank`) and that evaluation's and improvement's inner loops.

Part of the compiled kernels (numba), imported through :mod:`agents.learning._jit`; the
arrays are those described there. numba's ``cache=True`` keys a compiled function by its own
file only: after editing this file, delete the ``*.nbi``/``*.nbc`` files of
``agents/learning/__pycache__`` (or set ``NUMBA_CACHE_DIR`` afresh) so that the kernels of
:mod:`~agents.learning._jit` and :mod:`~agents.learning._jit_learner` that call it are
compiled again.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

_NEG = -1e300


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


#: Steps of :func:`mdps`: the expected reward from a reward per next state
#: (:func:`partner_backup`) or from a joint reward (:func:`partner_reward`), policy
#: iteration (:func:`solve_partner_q`), the soft-max of its Q (:func:`softmax`).
STATE_REWARD, JOINT_REWARD, SOLVE, SOFTMAX = 1, 2, 4, 8


@njit(cache=True, nogil=True)
def mdps(steps, nxt_t, partner, values, joint_t, valid, vidx, n_valid, rank, terminal, gamma,
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
    """The policy iteration's scratch for S states, made once per :func:`mdps` call.

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
    yet: see :func:`mdps`).
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
def placeholders():
    """Placeholders for the arrays of :func:`mdps` that a kernel's steps do not read.

    Int (1, 1, 1), float (1, 1), float (1, 1, 1), bool (1, 1), int (1, 1), int (1,),
    uint (1,).
    """
    return (np.zeros((1, 1, 1), np.int64), np.zeros((1, 1)), np.zeros((1, 1, 1)),
            np.zeros((1, 1), np.bool_), np.zeros((1, 1), np.int64), np.zeros(1, np.int64),
            np.zeros(1, np.uint64))
