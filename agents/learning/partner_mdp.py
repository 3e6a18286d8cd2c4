"""The learning math on the sparse joint transition table, without dense transition tensors.

Every (s, a_self, a_partner) leads to exactly one next state ``next_state[s, a, p]``, so an
agent's MDP with the partner's policy π_p substituted never needs the dense
T(s'|s, a) = Σ_p π_p(p|s) 1[next_state[s, a, p] = s'] of
:func:`hri_envs.task.mdp.robot_transition`:

* a backup Σ_s' T(s'|s, a) x(s') is the gather Σ_p π_p(p|s) x(next_state[s, a, p]);
* the policy-evaluation matrix P_π(s, s') of a greedy policy is a scatter of π_p over
  ``next_state[s, π(s), p]``, and the state-to-state matrix of a soft policy likewise.

These functions give the numbers of the dense functions of :mod:`hri_envs.task.mdp` and
:mod:`agents.learning.mdp` (to rounding: sums are taken in another order, differences are
~1e-15) at a fraction of their memory traffic. Shapes: ``S`` states, ``A`` own actions,
``P`` partner actions, ``...``/``N`` any number of independent MDPs. ``terminal`` gives
each MDP's absorbing state (it loops on itself whatever the actions, as
:func:`hri_envs.task.mdp.absorbing` makes it), or -1 for none. The Learner's whole update,
built from these, is :mod:`agents.learning.algorithm1`.

Each function has two implementations whose results agree to rounding, ~1e-15
(tests/test_partner_mdp.py checks them against each other): vectorised numpy, and compiled
loops (:mod:`agents.learning._jit`) used when numba is importable and the environment variable
``HRI_ENVS_NO_JIT`` is not set to a non-empty value other than ``0``. The compiled code is
cached on disk, so a machine compiles it once. Whether the compiled path is on, the threads
a batch is shared among and the checks of the kernels' inputs are
:mod:`agents.learning.compiled`'s (:func:`kernels`, :func:`jit_enabled`, :func:`set_threads`
and :func:`threads` are re-exported here).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from agents.learning import mdp
from agents.learning.compiled import (
    THREADS_ENV,
    as_shape,
    check_range,
    check_shape,
    contiguous,
    in_parts,
    iteration_inputs,
    jit_enabled,
    joined_traces,
    kernels,
    set_threads,
    terminal_states,
    threads,
    trace_lengths,
    valid_table,
)
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp

__all__ = [
    "THREADS_ENV",
    "belief_policy",
    "expected_feature_counts",
    "jit_enabled",
    "kernels",
    "loop_free_counts",
    "partner_backup",
    "partner_reward",
    "preload",
    "set_threads",
    "solve_partner_q",
    "solve_soft",
    "threads",
]

_NEG = -1e300


def partner_backup(next_state: np.ndarray, partner: np.ndarray, values: np.ndarray,
                   terminal: np.ndarray | int | None = None) -> np.ndarray:
    """Σ_s' T(s'|s, a) x(s') for the partner-substituted T, as a gather.

    ``= Σ_p partner(p|s) values(next_state[s, a, p])``; in an MDP's terminal state
    ``values(terminal)`` for every action. With ``values`` a state reward R(s') this is the
    expected reward of :func:`hri_envs.task.mdp.q_iteration`.

    Args:
        next_state: (S, A, P) int joint transition table, own action before the partner's.
        partner: (..., S, P) the partner's policy.
        values: (..., S) a value per next state.
        terminal: (...,) int absorbing state per MDP (-1 none), or None for none.

    Returns:
        (..., S, A).
    """
    lead = partner.shape[:-2]
    n_s, n_a, n_p = next_state.shape
    nxt = contiguous(next_state, dtype=np.int64)
    check_range("next_state", nxt, 0, n_s)
    pi = contiguous(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    x = as_shape(values, (*lead, n_s), np.float64, "values").reshape(-1, n_s)
    term = terminal_states(terminal, lead)
    check_range("terminal", term, -1, n_s)
    jit = kernels()
    if jit is not None:
        out = jit.partner_backup(nxt, pi, x, term)
    else:
        out = _backup_numpy(nxt, pi, x, term)
    return out.reshape(*lead, n_s, n_a)


def _backup_numpy(nxt: np.ndarray, pi: np.ndarray, x: np.ndarray, term: np.ndarray
                  ) -> np.ndarray:
    """:func:`partner_backup` on flat (N, ...) arrays, in numpy."""
    rows = np.arange(len(pi))[:, None, None, None]
    out = np.einsum("nsap,nsp->nsa", x[rows, nxt[None]], pi)
    has = np.flatnonzero(term >= 0)
    out[has, term[has], :] = x[has, term[has], None]
    return out


def partner_reward(reward: np.ndarray, partner: np.ndarray,
                   terminal: np.ndarray | int | None = None) -> np.ndarray:
    """Expected immediate reward Σ_p partner(p|s) R(s, a, p) (as :func:`mdp.robot_reward`).

    Args:
        reward: (S, A, P) reward of (s, own action, partner action).
        partner: (..., S, P) the partner's policy.
        terminal: (...,) int state per MDP whose reward is 0 (the absorbing goal; -1 none),
            or None for none.

    Returns:
        (..., S, A).
    """
    lead = partner.shape[:-2]
    n_s, n_a, n_p = reward.shape
    pi = contiguous(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    term = terminal_states(terminal, lead)
    check_range("terminal", term, -1, n_s)
    jit = kernels()
    if jit is not None:
        r = contiguous(reward, dtype=np.float64)
        out = jit.partner_reward(r, pi, term)
    else:
        out = np.einsum("sap,nsp->nsa", reward, pi)
        has = np.flatnonzero(term >= 0)
        out[has, term[has], :] = 0.0
    return out.reshape(*lead, n_s, n_a)


def belief_policy(q: np.ndarray, belief: np.ndarray, states: np.ndarray, valid: np.ndarray,
                  temperature: float, eta: float, baseline: np.ndarray | None) -> np.ndarray:
    """The robot's bounded soft-max of the belief-weighted Q in each run's state (Eq. 5).

    :func:`agents.learning.mdp.bounded_softmax` of ``Σ_ι belief(ι) q(ι, state, ·)``, in one
    call per step (the study's inner loop).

    Args:
        q: (B, I, S, A) Q per intention.
        belief: (B, I) belief over intentions.
        states: (B,) int each run's state.
        valid: (S, A) bool.
        temperature: τ of the soft-max.
        eta: η of the bound.
        baseline: (B,) int the passive baseline action, or None for no baseline.

    Returns:
        (B, A) probabilities.
    """
    states = contiguous(states, np.int64)
    n_b, n_i, n_s, n_a = q.shape
    check_shape("states", states, (n_b,))
    check_shape("belief", belief, (n_b, n_i))
    check_range("states", states, 0, n_s)
    base = np.full(n_b, -1, np.int64) if baseline is None else contiguous(baseline, np.int64)
    if baseline is not None:
        check_shape("baseline", base, (n_b,))
        check_range("baseline", base, 0, n_a)
    jit = kernels()
    if jit is None:
        rows = np.arange(len(states))
        mixed = np.einsum("bi,bia->ba", belief, q[rows, :, states])
        return mdp.bounded_softmax(mixed, valid[states], temperature, eta, baseline)
    return jit.belief_policy(contiguous(q, np.float64), contiguous(belief, np.float64),
                             states, base, valid_table(valid, n_s, n_a), float(temperature),
                             float(eta))


def solve_partner_q(
    next_state: np.ndarray,
    partner: np.ndarray,
    reward: np.ndarray,
    valid: np.ndarray,
    gamma: float,
    *,
    terminal: np.ndarray | int | None = None,
    policy: np.ndarray | None = None,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray]:
    """Optimal Q of the partner-substituted MDP by policy iteration (Eq. 1 fixed point).

    The same iteration as :func:`hri_envs.task.mdp.solve_q` on
    ``absorbing(transition(next_state, partner), terminal)``: evaluate the greedy policy
    exactly (a linear solve of (I - γ P_π) v = r_π), improve it where an action is better by
    more than 1e-10 relative, stop when no action changes (each MDP on its own).

    Args:
        next_state: (S, A, P) int joint transition table, own action before the partner's.
        partner: (..., S, P) the partner's policy.
        reward: (..., S, A) expected immediate reward of (s, a).
        valid: (S, A) bool valid own actions.
        gamma: Discount in [0, 1).
        terminal: (...,) int absorbing state per MDP (-1 none), or None for none.
        policy: (..., S) int greedy actions to start from (a warm start), optional.
        max_iter: Cap on improvement rounds.

    Returns:
        ``(q, greedy)``: (..., S, A) Q (invalid actions hold the value they would have) and
        (..., S) int the first valid action of highest Q in each state.

    Raises:
        ConfigError: ``gamma`` outside [0, 1) or ``max_iter`` < 1.
    """
    lead = partner.shape[:-2]
    n_s, n_a, _ = next_state.shape
    nxt, pi, term, act, warm = iteration_inputs(next_state, partner, gamma, terminal, policy,
                                                 max_iter)
    r = as_shape(reward, (*lead, n_s, n_a), np.float64, "reward").reshape(-1, n_s, n_a)
    ok = valid_table(valid, n_s, n_a)
    jit = kernels()
    if jit is not None:
        q, greedy = jit.solve_partner_q(nxt, pi, r, ok, term, float(gamma), act, warm,
                                        int(max_iter))
    else:
        q, greedy = _solve_numpy(nxt, pi, r, ok, term, float(gamma), act if warm else None,
                                 max_iter)
    return q.reshape(*lead, n_s, n_a), greedy.reshape(*lead, n_s)


def solve_soft(
    next_state: np.ndarray,
    partner: np.ndarray,
    valid: np.ndarray,
    gamma: float,
    temperature: float,
    *,
    state_reward: np.ndarray | None = None,
    joint_reward: np.ndarray | None = None,
    terminal: np.ndarray | int | None = None,
    policy: np.ndarray | None = None,
    max_iter: int = 100,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reward, optimal Q and soft-max policy of partner-substituted MDPs, in one call.

    The same numbers, bit for bit, as the three calls it stands for::

        reward = partner_backup(next_state, partner, state_reward, terminal)
        # or: partner_reward(joint_reward, partner, terminal)
        q, greedy = solve_partner_q(next_state, partner, reward, valid, gamma,
                                    terminal=terminal, policy=policy, max_iter=max_iter)
        soft = softmax(q, valid, temperature)

    made MDP by MDP in one compiled pass where the kernels are on (one set of checks and
    one call instead of three: the Learner's update makes three of these).

    Args:
        next_state: (S, A, P) int joint transition table, own action before the partner's.
        partner: (..., S, P) the partner's policy.
        valid: (S, A) bool valid own actions.
        gamma: Discount in [0, 1).
        temperature: τ > 0 of the soft-max.
        state_reward: (..., S) a reward per next state (the expected reward of an action is
            its backup, :func:`partner_backup`); give this or ``joint_reward``.
        joint_reward: (S, A, P) reward of (s, own action, partner action)
            (:func:`partner_reward`).
        terminal: (...,) int absorbing state per MDP (-1 none), or None for none.
        policy: (..., S) int greedy actions to start from (a warm start), optional.
        max_iter: Cap on improvement rounds.

    Returns:
        ``(q, greedy, soft)``: (..., S, A) Q, (..., S) int greedy actions and (..., S, A)
        the soft-max policy.

    Raises:
        ConfigError: Not exactly one of ``state_reward`` and ``joint_reward``, or what
            :func:`solve_partner_q` refuses.
    """
    if (state_reward is None) == (joint_reward is None):
        raise ConfigError("give exactly one of state_reward (..., S) and joint_reward "
                          "(S, A, P)", field="state_reward")
    lead = partner.shape[:-2]
    n_s, n_a, _ = next_state.shape
    if joint_reward is not None:
        joint = contiguous(np.asarray(joint_reward), dtype=np.float64)
        check_shape("joint_reward", joint, next_state.shape)
        values = np.zeros((1, 1))
    else:
        assert state_reward is not None
        joint = np.zeros((1, 1, 1))
        values = as_shape(state_reward, (*lead, n_s), np.float64, "state_reward").reshape(-1, n_s)
    use_joint, ok = joint_reward is not None, valid_table(valid, n_s, n_a)
    jit = kernels()
    if jit is None:
        reward = (partner_reward(joint, partner, terminal) if use_joint
                  else partner_backup(next_state, partner, values.reshape(*lead, n_s), terminal))
        q, greedy = solve_partner_q(next_state, partner, reward, ok, gamma,
                                    terminal=terminal, policy=policy, max_iter=max_iter)
        return q, greedy, task_mdp.softmax(q, ok, temperature)
    nxt, pi, term, act, warm = iteration_inputs(next_state, partner, gamma, terminal, policy,
                                                 max_iter)
    n = len(pi)
    q, greedy, soft = (np.empty((n, n_s, n_a)), np.empty((n, n_s), np.int64),
                       np.zeros((n, n_s, n_a)))

    def part(lo: int, hi: int) -> None:
        jit.solve_soft(nxt, pi, values, joint, use_joint, ok, term, float(gamma), act, warm,
                       int(max_iter), float(temperature), q, greedy, soft, lo, hi)

    in_parts(part, n)
    return (q.reshape(*lead, n_s, n_a), greedy.reshape(*lead, n_s),
            soft.reshape(*lead, n_s, n_a))


def _evaluation_matrix(nxt: np.ndarray, pi: np.ndarray, act: np.ndarray, term: np.ndarray,
                       gamma: float) -> np.ndarray:
    """(K, S, S) I - γ P_π for greedy actions ``act`` (K, S), by a scatter of π."""
    n_k, n_s = act.shape
    succ = nxt[np.arange(n_s), act]  # (K, S, P)
    weight = pi.copy()
    has = np.flatnonzero(term >= 0)
    succ[has, term[has], :] = term[has, None]
    weight[has, term[has], :] = 0.0
    weight[has, term[has], 0] = 1.0
    flat = (np.arange(n_k)[:, None, None] * n_s + np.arange(n_s)[:, None]) * n_s + succ
    p = np.bincount(flat.ravel(), weight.ravel(), minlength=n_k * n_s * n_s)
    return np.eye(n_s) - gamma * p.reshape(n_k, n_s, n_s)


def _solve_numpy(nxt: np.ndarray, pi: np.ndarray, r: np.ndarray, valid: np.ndarray,
                 term: np.ndarray, gamma: float, policy: np.ndarray | None, max_iter: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`solve_partner_q` on flat (N, ...) arrays, in numpy (batched solves)."""
    n, n_s, _ = r.shape
    if policy is None:
        act = np.where(valid, r, _NEG).argmax(axis=-1)  # (N, S)
    else:
        act = policy.copy()
    q = np.empty_like(r)
    todo = np.arange(n)  # the MDPs whose policy still changes; the others are final
    for _ in range(max_iter):
        act_t = act[todo]
        m = _evaluation_matrix(nxt, pi[todo], act_t, term[todo], gamma)
        r_t = r[todo]
        v = np.linalg.solve(m, np.take_along_axis(r_t, act_t[..., None], axis=-1))[..., 0]
        q_t = r_t + gamma * _backup_numpy(nxt, pi[todo], v, term[todo])
        q[todo] = q_t
        new_act, changed = task_mdp.improve_policy(q_t, valid, act_t)
        if not changed.any():
            break
        act[todo] = new_act
        todo = todo[changed]
    greedy = np.where(valid, q, -np.inf).argmax(axis=-1)
    return q, greedy


def expected_feature_counts(
    next_state: np.ndarray,
    partner: np.ndarray,
    policy: np.ndarray,
    features: np.ndarray,
    start: np.ndarray,
    terminal: np.ndarray,
    horizon: np.ndarray,
) -> np.ndarray:
    """Expected feature counts of a soft policy over a finite horizon (ME-IRL's E[φ]).

    :func:`agents.learning.mdp.expected_feature_counts` on the partner-substituted MDP: the
    state distribution starts at ``start``, is propagated ``horizon - 1`` times by
    P(s'|s) = Σ_a policy(a|s) Σ_p partner(p|s) 1[next_state[s, a, p] = s'] (built by a
    scatter), no mass leaves the terminal state, and the counts sum φ over the ``horizon``
    steps.

    Args:
        next_state: (S, A, P) int joint transition table, own action before the partner's.
        partner: (N, S, P) the partner's policy.
        policy: (N, S, A) the soft policy.
        features: (N, S, F) φ.
        start: (N,) int start states.
        terminal: (N,) int terminal states (absorbing, not propagated).
        horizon: (N,) int number of states of each demonstration (>= 1).

    Returns:
        (N, F).
    """
    n_s, n_a, n_p = next_state.shape
    nxt = contiguous(next_state, dtype=np.int64)
    check_range("next_state", nxt, 0, n_s)
    pi = contiguous(partner, dtype=np.float64)
    own = contiguous(policy, dtype=np.float64)
    phi = contiguous(features, dtype=np.float64)
    start_, term, hor = (contiguous(np.asarray(x), dtype=np.int64)
                         for x in (start, terminal, horizon))
    n = len(pi)
    for name, arr, shape in (("partner", pi, (n, n_s, n_p)), ("policy", own, (n, n_s, n_a)),
                             ("features", phi, (n, n_s, phi.shape[-1])),
                             ("start", start_, (n,)), ("terminal", term, (n,)),
                             ("horizon", hor, (n,))):
        check_shape(name, arr, shape)
    check_range("start", start_, 0, n_s)
    check_range("terminal", term, -1, n_s)
    jit = kernels()
    if jit is not None:
        out = np.zeros((len(pi), phi.shape[-1]))

        def counts(lo: int, hi: int) -> None:
            jit.expected_feature_counts(nxt, pi, own, phi, start_, term, hor, out, lo, hi)

        in_parts(counts, len(pi))
        return out
    n_b = len(pi)
    rows = np.arange(n_b)
    weight = own[:, :, :, None] * pi[:, :, None, :]  # (N, S, A, P)
    ends = term >= 0  # -1: no absorbing state
    weight[rows[ends], term[ends]] = 0.0
    flat = (rows[:, None, None, None] * n_s + np.arange(n_s)[:, None, None]) * n_s + nxt
    p = np.bincount(flat.ravel(), weight.ravel(), minlength=n_b * n_s * n_s)
    p = p.reshape(n_b, n_s, n_s)
    d = np.zeros((n_b, n_s))
    d[rows, start_] = 1.0
    svf = d.copy()
    for t in range(1, int(hor.max())):
        d = np.einsum("bs,bsz->bz", d, p)
        svf += d * (t < hor)[:, None]
    return np.einsum("bs,bsf->bf", svf, phi)


def loop_free_counts(features: np.ndarray, state_traces: Sequence[np.ndarray],
                     intentions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Loop removal and feature counts of each trace, in one call (ME-IRL's demonstrations).

    The numbers of :func:`agents.learning.mdp.demonstrations` (bit for bit: the same path,
    and φ summed along it in the same order) without its per-trace Python work; the paths
    themselves are not returned.

    Args:
        features: (I, S, F) φ(s, ι).
        state_traces: B state sequences (each (T+1,), at least one state, ints in [0, S)).
        intentions: (B,) int the intention of each trace, in [0, I).

    Returns:
        ``(counts, start, horizon)``: (B, F) Σ φ along each loop-free path, (B,) its first
        state, (B,) its number of states.

    Raises:
        ConfigError: A trace is empty, or a state or intention is out of range.
    """
    n_i, n_s, n_f = features.shape
    intent = contiguous(np.asarray(intentions).reshape(-1), np.int64)
    if len(intent) != len(state_traces):
        raise ConfigError(f"intentions must have one entry per trace ({len(state_traces)}), "
                          f"got {len(intent)}", field="intentions")
    check_range("intentions", intent, 0, n_i)
    jit = kernels()
    if jit is None or n_f < 2 or not len(state_traces):  # numpy sums one feature pairwise
        trace_lengths(state_traces)
        demo = mdp.demonstrations(features, state_traces, intent)
        return demo.counts, demo.start, demo.horizon
    states, offsets = joined_traces(state_traces, n_s)
    return jit.loop_free_counts(contiguous(features, np.float64), states, offsets, intent)


def preload() -> bool:
    """Load every compiled kernel now; whether the compiled path is on.

    The first compiled call of a process starts numba's code generator (≈ 0.3-0.8 s even
    with the on-disk cache). Calling this before forking worker processes lets them inherit
    the loaded kernels instead of each paying that again.
    """
    jit = kernels()
    if jit is None:
        return False
    nxt = np.zeros((1, 1, 1), np.int64)
    one = np.ones((1, 1, 1))
    none = np.full(1, -1, np.int64)
    zero = np.zeros(1, np.int64)
    valid = np.ones((1, 1), np.bool_)
    jit.partner_backup(nxt, one, np.zeros((1, 1)), none)
    jit.partner_reward(one, one, none)
    jit.solve_partner_q(nxt, one, one, valid, none, 0.5, np.zeros((1, 1), np.int64), False, 1)
    jit.expected_feature_counts(nxt, one, one, one, zero, none, np.ones(1, np.int64),
                                np.zeros((1, 1)), 0, 1)
    jit.belief_policy(np.ones((1, 1, 1, 1)), np.ones((1, 1)), zero, zero, valid, 1.0, 0.5)
    jit.out_of_range(zero, 0, 1)
    jit.loop_free_counts(np.ones((1, 1, 2)), zero, np.array([0, 1]), zero)
    jit.solve_soft(nxt, one, np.zeros((1, 1)), one, False, valid, none, 0.5,
                   np.zeros((1, 1), np.int64), False, 1, 1.0, np.empty((1, 1, 1)),
                   np.empty((1, 1), np.int64), np.zeros((1, 1, 1)), 0, 1)
    return True
