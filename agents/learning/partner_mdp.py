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
cached on disk, so a machine compiles it once (:func:`kernels`).
"""

from __future__ import annotations

import functools
import itertools
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from types import ModuleType

import numpy as np

from agents.learning import mdp
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp

__all__ = [
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


@functools.cache
def kernels() -> ModuleType | None:
    """The compiled kernels (:mod:`agents.learning._jit`), or None for the numpy path.

    None when ``HRI_ENVS_NO_JIT`` is set (to anything but "" or "0") or numba cannot be
    imported. Decided once per process. The first call in a process imports numba and
    loads the kernels from numba's on-disk cache (compiling them the first time on a
    machine, a few seconds).
    """
    if os.environ.get("HRI_ENVS_NO_JIT", "") not in ("", "0"):
        return None
    try:
        from agents.learning import _jit
    except ImportError:
        return None
    return _jit


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


#: Environment variable: threads the compiled kernels share a batch of MDPs among.
THREADS_ENV = "HRI_ENVS_THREADS"
#: Batches smaller than this many MDPs per thread run on one thread (not worth a hand-out).
_MIN_PER_THREAD = 48
_threads: tuple[int, int] | None = None  # (threads, the id of the process that chose them)
_pool: tuple[ThreadPoolExecutor, int, int] | None = None  # (helpers, how many, process id)
_IMPORTED_BY = os.getpid()  # a process forked after the import has another id


def _cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def set_threads(n: int | None) -> None:
    """Share each batch of MDPs among ``n`` threads in this process (None: the default).

    The default is the environment variable ``HRI_ENVS_THREADS``, or else the number of
    cores this process may run on. With more than one thread, a batch is cut into
    consecutive parts that the calling thread and ``n - 1`` helper threads take in turn,
    each solving its part with the serial kernel (which releases the GIL), so the numbers
    do not depend on the number of threads. The setting belongs to the process that made
    it: a child forked from it (a study's worker), or forked from the process that
    imported this module before it chose, runs the kernels on one thread unless it calls
    this itself, so that workers do not oversubscribe the cores. Only the main thread
    hands work out.

    Raises:
        ConfigError: ``n`` < 1, or ``HRI_ENVS_THREADS`` is not a whole number >= 1.
    """
    global _threads
    if n is None:
        raw = os.environ.get(THREADS_ENV, "").strip()
        try:
            n = int(raw) if raw else _cores()
        except ValueError:
            n = 0
        if n < 1:
            raise ConfigError(f"{THREADS_ENV} must be a whole number >= 1, got {raw!r}",
                              field=THREADS_ENV)
    elif n < 1:
        raise ConfigError(f"threads must be >= 1, got {n}", field="threads")
    _threads = (n, os.getpid())


def threads() -> int:
    """Threads the compiled kernels share a batch among in this process (1: serial)."""
    if _threads is None:
        if os.getpid() != _IMPORTED_BY:
            return 1
        set_threads(None)
    assert _threads is not None
    n, pid = _threads
    return n if pid == os.getpid() else 1


def _threads_here(n_mdps: int) -> int:
    """Threads to share a batch of ``n_mdps`` MDPs among here and now (1: the caller's)."""
    n = threads()
    if n == 1 or threading.current_thread() is not threading.main_thread():
        return 1
    return max(1, min(n, n_mdps // _MIN_PER_THREAD))


def _in_parts(solve: Callable[[int, int], None], n_items: int, mdps: int | None = None
              ) -> None:
    """``solve(0, n_items)``, done in consecutive parts on :func:`_threads_here` threads.

    ``solve(lo, hi)`` does the items (MDPs, or runs of ``mdps`` MDPs in all) lo..hi-1,
    writing into results made beforehand. With N threads the batch is cut into 2N parts
    that the calling thread and N - 1 helpers take in turn, so that a thread slowed down
    (its core busy with other work) takes fewer.
    """
    global _pool
    n_t = _threads_here(n_items if mdps is None else mdps)
    n_t = min(n_t, n_items)
    if n_t <= 1:
        solve(0, n_items)
        return
    if _pool is None or _pool[1] < n_t - 1 or _pool[2] != os.getpid():
        if _pool is not None and _pool[2] == os.getpid():
            _pool[0].shutdown(wait=False)  # too few helpers for a larger setting
        _pool = (ThreadPoolExecutor(n_t - 1, thread_name_prefix="hri-envs"), n_t - 1,
                 os.getpid())
    n_p = min(2 * n_t, n_items)
    cuts = [i * n_items // n_p for i in range(n_p + 1)]
    turns = itertools.count()  # next() is atomic under the GIL

    def work() -> None:
        while (i := next(turns)) < n_p:
            solve(cuts[i], cuts[i + 1])

    helpers = [_pool[0].submit(work) for _ in range(n_t - 1)]
    work()
    for helper in helpers:
        helper.result()


def jit_enabled() -> bool:
    """Whether the compiled kernels are used in this process (see :func:`kernels`)."""
    return kernels() is not None


def _check_range(name: str, x: np.ndarray, low: int, high: int) -> None:
    """Raise ConfigError unless every entry of the int array ``x`` is in [low, high).

    The compiled kernels index without bounds checks (an index out of range reads or
    writes outside the array), so every index array is checked before they run (by a
    compiled pass where the kernels are on: a numpy reduction costs more than a small
    kernel call).
    """
    jit = kernels()
    if jit is not None and x.dtype == np.int64 and x.flags.c_contiguous:
        bad = jit.out_of_range(x, low, high)
    else:
        bad = x.size > 0 and (int(x.min()) < low or int(x.max()) >= high)
    if bad:
        raise ConfigError(f"{name} must hold indices in [{low}, {high}), got values from "
                          f"{int(x.min())} to {int(x.max())}", field=name)


def _terminal(terminal: np.ndarray | int | None, lead: tuple[int, ...]) -> np.ndarray:
    """(N,) int64 absorbing state per MDP (-1: none) from a value broadcastable to ``lead``."""
    if terminal is None:
        return np.full(int(np.prod(lead)), -1, np.int64)
    return _flat(terminal, lead, np.int64, "terminal").reshape(-1)


def _flat(x: np.ndarray | int, shape: tuple[int, ...], dtype: type, name: str) -> np.ndarray:
    """``x`` broadcast to ``shape``, as :func:`_c`.

    Raises:
        ConfigError: ``x`` does not broadcast to ``shape`` (the compiled kernels would read
            past its end).
    """
    arr = np.asarray(x)
    if arr.shape != shape:
        try:
            arr = np.broadcast_to(arr, shape)
        except ValueError:
            raise ConfigError(f"{name} has shape {arr.shape}, which does not broadcast to "
                              f"{shape}", field=name) from None
    return _c(arr, dtype)


def _check_shape(name: str, x: np.ndarray, shape: tuple[int, ...]) -> None:
    """Raise ConfigError unless ``x`` has ``shape`` (the kernels index by the others' sizes)."""
    if x.shape != shape:
        raise ConfigError(f"{name} must have shape {shape}, got {x.shape}", field=name)


def _valid(valid: np.ndarray, n_s: int, n_a: int) -> np.ndarray:
    """The (S, A) valid-action table as the kernels take it, its shape checked."""
    ok = _c(np.asarray(valid), dtype=np.bool_)
    _check_shape("valid", ok, (n_s, n_a))
    return ok


def _c(x: np.ndarray, dtype: type) -> np.ndarray:
    """``x`` as a C-contiguous, writeable array of ``dtype`` (copied only if it is not).

    The compiled kernels then see one array type per argument: numba compiles (and caches)
    a separate version for read-only or non-contiguous arrays. The common case, an array
    that already is one, is answered without :func:`numpy.require` (whose generality costs
    more than a small kernel call).
    """
    if type(x) is np.ndarray and x.dtype == dtype:
        flags = x.flags
        if flags.c_contiguous and flags.writeable:
            return x
    return np.require(x, dtype, ("C", "W"))


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
    nxt = _c(next_state, dtype=np.int64)
    _check_range("next_state", nxt, 0, n_s)
    pi = _c(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    x = _flat(values, (*lead, n_s), np.float64, "values").reshape(-1, n_s)
    term = _terminal(terminal, lead)
    _check_range("terminal", term, -1, n_s)
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
    pi = _c(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    term = _terminal(terminal, lead)
    _check_range("terminal", term, -1, n_s)
    jit = kernels()
    if jit is not None:
        r = _c(reward, dtype=np.float64)
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
    states = _c(states, np.int64)
    n_b, n_i, n_s, n_a = q.shape
    _check_shape("states", states, (n_b,))
    _check_shape("belief", belief, (n_b, n_i))
    _check_range("states", states, 0, n_s)
    base = np.full(n_b, -1, np.int64) if baseline is None else _c(baseline, np.int64)
    if baseline is not None:
        _check_shape("baseline", base, (n_b,))
        _check_range("baseline", base, 0, n_a)
    jit = kernels()
    if jit is None:
        rows = np.arange(len(states))
        mixed = np.einsum("bi,bia->ba", belief, q[rows, :, states])
        return mdp.bounded_softmax(mixed, valid[states], temperature, eta, baseline)
    return jit.belief_policy(_c(q, np.float64), _c(belief, np.float64),
                             states, base, _valid(valid, n_s, n_a), float(temperature),
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
    nxt, pi, term, act, warm = _iteration_inputs(next_state, partner, gamma, terminal, policy,
                                                 max_iter)
    r = _flat(reward, (*lead, n_s, n_a), np.float64, "reward").reshape(-1, n_s, n_a)
    ok = _valid(valid, n_s, n_a)
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
        joint = _c(np.asarray(joint_reward), dtype=np.float64)
        _check_shape("joint_reward", joint, next_state.shape)
        values = np.zeros((1, 1))
    else:
        assert state_reward is not None
        joint = np.zeros((1, 1, 1))
        values = _flat(state_reward, (*lead, n_s), np.float64, "state_reward").reshape(-1, n_s)
    use_joint, ok = joint_reward is not None, _valid(valid, n_s, n_a)
    jit = kernels()
    if jit is None:
        reward = (partner_reward(joint, partner, terminal) if use_joint
                  else partner_backup(next_state, partner, values.reshape(*lead, n_s), terminal))
        q, greedy = solve_partner_q(next_state, partner, reward, ok, gamma,
                                    terminal=terminal, policy=policy, max_iter=max_iter)
        return q, greedy, task_mdp.softmax(q, ok, temperature)
    nxt, pi, term, act, warm = _iteration_inputs(next_state, partner, gamma, terminal, policy,
                                                 max_iter)
    n = len(pi)
    q, greedy, soft = (np.empty((n, n_s, n_a)), np.empty((n, n_s), np.int64),
                       np.zeros((n, n_s, n_a)))

    def part(lo: int, hi: int) -> None:
        jit.solve_soft(nxt, pi, values, joint, use_joint, ok, term, float(gamma), act, warm,
                       int(max_iter), float(temperature), q, greedy, soft, lo, hi)

    _in_parts(part, n)
    return (q.reshape(*lead, n_s, n_a), greedy.reshape(*lead, n_s),
            soft.reshape(*lead, n_s, n_a))


def _iteration_inputs(next_state: np.ndarray, partner: np.ndarray, gamma: float,
                      terminal: np.ndarray | int | None, policy: np.ndarray | None,
                      max_iter: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Checked, flattened inputs of a policy iteration (:func:`solve_partner_q`,
    :func:`solve_soft`): ``(next_state, partner (N, S, P), terminal (N,), starting actions
    (N, S), whether they are a warm start)``.

    Raises:
        ConfigError: ``gamma`` outside [0, 1), ``max_iter`` < 1, or an index out of range.
    """
    _check_iteration(gamma, max_iter)
    lead = partner.shape[:-2]
    n_s, n_a, n_p = next_state.shape
    nxt = _c(next_state, dtype=np.int64)
    _check_range("next_state", nxt, 0, n_s)
    pi = _c(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    term = _terminal(terminal, lead)
    _check_range("terminal", term, -1, n_s)
    warm = policy is not None
    act = (_flat(policy, (*lead, n_s), np.int64, "policy").reshape(-1, n_s) if policy is not None
           else np.zeros((len(pi), n_s), np.int64))
    _check_range("policy", act, 0, n_a)
    return nxt, pi, term, act, warm


def _check_iteration(gamma: float, max_iter: int) -> None:
    """Raise ConfigError unless ``gamma`` is in [0, 1) and ``max_iter`` >= 1."""
    if not 0.0 <= gamma < 1.0:
        raise ConfigError(f"gamma must be in [0, 1), got {gamma}", field="gamma")
    if max_iter < 1:
        raise ConfigError(f"max_iter must be >= 1, got {max_iter}", field="max_iter")


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
    nxt = _c(next_state, dtype=np.int64)
    _check_range("next_state", nxt, 0, n_s)
    pi = _c(partner, dtype=np.float64)
    own = _c(policy, dtype=np.float64)
    phi = _c(features, dtype=np.float64)
    start_, term, hor = (_c(np.asarray(x), dtype=np.int64)
                         for x in (start, terminal, horizon))
    n = len(pi)
    for name, arr, shape in (("partner", pi, (n, n_s, n_p)), ("policy", own, (n, n_s, n_a)),
                             ("features", phi, (n, n_s, phi.shape[-1])),
                             ("start", start_, (n,)), ("terminal", term, (n,)),
                             ("horizon", hor, (n,))):
        _check_shape(name, arr, shape)
    _check_range("start", start_, 0, n_s)
    _check_range("terminal", term, -1, n_s)
    jit = kernels()
    if jit is not None:
        out = np.zeros((len(pi), phi.shape[-1]))

        def counts(lo: int, hi: int) -> None:
            jit.expected_feature_counts(nxt, pi, own, phi, start_, term, hor, out, lo, hi)

        _in_parts(counts, len(pi))
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
    intent = _c(np.asarray(intentions).reshape(-1), np.int64)
    if len(intent) != len(state_traces):
        raise ConfigError(f"intentions must have one entry per trace ({len(state_traces)}), "
                          f"got {len(intent)}", field="intentions")
    _check_range("intentions", intent, 0, n_i)
    jit = kernels()
    if jit is None or n_f < 2 or not len(state_traces):  # numpy sums one feature pairwise
        _trace_lengths(state_traces)
        demo = mdp.demonstrations(features, state_traces, intent)
        return demo.counts, demo.start, demo.horizon
    states, offsets = _joined(state_traces, n_s)
    return jit.loop_free_counts(_c(features, np.float64), states, offsets, intent)


def _trace_lengths(state_traces: Sequence[np.ndarray]) -> np.ndarray:
    """(B,) the traces' lengths.

    Raises:
        ConfigError: A trace is empty.
    """
    lengths = np.array([len(t) for t in state_traces], np.int64)
    if len(lengths) and lengths.min() < 1:
        raise ConfigError("every state trace must hold at least one state",
                          field="state_traces")
    return lengths


def _joined(state_traces: Sequence[np.ndarray], n_s: int) -> tuple[np.ndarray, np.ndarray]:
    """The traces one after another, and (B + 1,) where each starts (the kernels' form).

    Raises:
        ConfigError: A trace is empty, or a state is out of range.
    """
    lengths = _trace_lengths(state_traces)
    states = _c(np.concatenate(state_traces) if len(state_traces) else np.zeros(0, np.int64),
                np.int64)
    _check_range("state_traces", states, 0, n_s)
    offsets = np.zeros(len(lengths) + 1, np.int64)
    np.cumsum(lengths, out=offsets[1:])
    return states, offsets
