"""How the sparse learning math runs: whether the compiled kernels are on, the threads a batch
of MDPs is shared among, and the checked, contiguous form the kernels take their inputs in.

The compiled kernels (:mod:`agents.learning._jit`) are used when numba is importable and the
environment variable ``HRI_ENVS_NO_JIT`` is not set to a non-empty value other than ``0``
(:func:`kernels`); they index without bounds checks, so :mod:`agents.learning.partner_mdp`
and :mod:`agents.learning.algorithm1` check every input with the functions here first.
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

from hri_envs.errors import ConfigError


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


def in_parts(solve: Callable[[int, int], None], n_items: int, mdps: int | None = None
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


def check_range(name: str, x: np.ndarray, low: int, high: int) -> None:
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


def terminal_states(terminal: np.ndarray | int | None, lead: tuple[int, ...]) -> np.ndarray:
    """(N,) int64 absorbing state per MDP (-1: none) from a value broadcastable to ``lead``."""
    if terminal is None:
        return np.full(int(np.prod(lead)), -1, np.int64)
    return as_shape(terminal, lead, np.int64, "terminal").reshape(-1)


def as_shape(x: np.ndarray | int, shape: tuple[int, ...], dtype: type, name: str) -> np.ndarray:
    """``x`` broadcast to ``shape``, as :func:`contiguous`.

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
    return contiguous(arr, dtype)


def check_shape(name: str, x: np.ndarray, shape: tuple[int, ...]) -> None:
    """Raise ConfigError unless ``x`` has ``shape`` (the kernels index by the others' sizes)."""
    if x.shape != shape:
        raise ConfigError(f"{name} must have shape {shape}, got {x.shape}", field=name)


def valid_table(valid: np.ndarray, n_s: int, n_a: int) -> np.ndarray:
    """The (S, A) valid-action table as the kernels take it, its shape checked."""
    ok = contiguous(np.asarray(valid), dtype=np.bool_)
    check_shape("valid", ok, (n_s, n_a))
    return ok


def contiguous(x: np.ndarray, dtype: type) -> np.ndarray:
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


def check_iteration(gamma: float, max_iter: int) -> None:
    """Raise ConfigError unless ``gamma`` is in [0, 1) and ``max_iter`` >= 1."""
    if not 0.0 <= gamma < 1.0:
        raise ConfigError(f"gamma must be in [0, 1), got {gamma}", field="gamma")
    if max_iter < 1:
        raise ConfigError(f"max_iter must be >= 1, got {max_iter}", field="max_iter")


def trace_lengths(state_traces: Sequence[np.ndarray]) -> np.ndarray:
    """(B,) the traces' lengths.

    Raises:
        ConfigError: A trace is empty.
    """
    lengths = np.array([len(t) for t in state_traces], np.int64)
    if len(lengths) and lengths.min() < 1:
        raise ConfigError("every state trace must hold at least one state",
                          field="state_traces")
    return lengths


def joined_traces(state_traces: Sequence[np.ndarray], n_s: int) -> tuple[np.ndarray, np.ndarray]:
    """The traces one after another, and (B + 1,) where each starts (the kernels' form).

    Raises:
        ConfigError: A trace is empty, or a state is out of range.
    """
    lengths = trace_lengths(state_traces)
    states = contiguous(np.concatenate(state_traces) if len(state_traces)
                        else np.zeros(0, np.int64), np.int64)
    check_range("state_traces", states, 0, n_s)
    offsets = np.zeros(len(lengths) + 1, np.int64)
    np.cumsum(lengths, out=offsets[1:])
    return states, offsets


def iteration_inputs(next_state: np.ndarray, partner: np.ndarray, gamma: float,
                      terminal: np.ndarray | int | None, policy: np.ndarray | None,
                      max_iter: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Checked, flattened inputs of a policy iteration
    (:func:`~agents.learning.partner_mdp.solve_partner_q`,
    :func:`~agents.learning.partner_mdp.solve_soft`): ``(next_state, partner (N, S, P),
    terminal (N,), starting actions (N, S), whether they are a warm start)``.

    Raises:
        ConfigError: ``gamma`` outside [0, 1), ``max_iter`` < 1, or an index out of range.
    """
    check_iteration(gamma, max_iter)
    lead = partner.shape[:-2]
    n_s, n_a, n_p = next_state.shape
    nxt = contiguous(next_state, dtype=np.int64)
    check_range("next_state", nxt, 0, n_s)
    pi = contiguous(partner, dtype=np.float64).reshape(-1, n_s, n_p)
    term = terminal_states(terminal, lead)
    check_range("terminal", term, -1, n_s)
    warm = policy is not None
    act = (as_shape(policy, (*lead, n_s), np.int64, "policy").reshape(-1, n_s) if policy is not None
           else np.zeros((len(pi), n_s), np.int64))
    check_range("policy", act, 0, n_a)
    return nxt, pi, term, act, warm
