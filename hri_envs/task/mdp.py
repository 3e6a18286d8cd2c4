"""Planning on the task graph: soft-max policies, Q-iteration, partner transitions.

What the task model and the scripted humans need of MDP math (a Boltzmann human solves its
own Q-iteration; the Passive baseline's actions are part of the task's conventions). The
learners' own math (bounded soft-max, the Bayes filter, loop removal, ME-IRL) builds on this
in :mod:`agents.learning`.

Shapes: ``I`` intentions, ``S`` states, ``A`` actions; ``...`` any number of leading axes
(independent MDPs). Actions that are not valid in a state (``valid[s, a] == False``) take no
part in any max, soft-max or expectation.

Q-functions are solved exactly by policy iteration: the greedy policy is evaluated with a
batched linear solve and improved until it no longer changes. For the discounted
Q-iteration of the paper (Eq. 1, ``Q(s,a) = Σ_s' T(s'|s,a) [R + γ V(s')]`` with
``V(s) = max_a Q(s,a)``) this reaches the same fixed point as iterating the Bellman backup,
in a handful of solves instead of hundreds of sweeps.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, NamedTuple

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.task.actions import BOTH, PUT_ON
from hri_envs.task.episode import arrived
from hri_envs.task.graph import TOGGLE, WAIT, TaskGraph

__all__ = [
    "PartnerIndex",
    "absorbing",
    "cost_to_goal",
    "free_motions",
    "human_transition",
    "improve_policy",
    "one_blas_thread",
    "partner_index",
    "passive_actions",
    "passive_policy",
    "q_iteration",
    "robot_transition",
    "softmax",
    "solve_q",
]

_NEG = -1e300

@functools.cache
def _blas_controllers() -> tuple[Any, ...]:
    """The BLAS libraries loaded (numpy's), as threadpoolctl controllers; found once."""
    from threadpoolctl import ThreadpoolController

    return tuple(ThreadpoolController().select(user_api="blas").lib_controllers)


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the enclosed block (or decorated function) with BLAS on one thread.

    The learning math makes many small products and solves (36-state matrices, batches of a
    few hundred): a BLAS that splits each of them over threads spends more time handing work
    out than computing, and far more so when other jobs load the machine (10x slower
    measured on 2 busy cores). Threads do not change the numbers, only the time. The
    setting is process-wide while the block runs and is restored after it.
    """
    controllers = _blas_controllers()
    before = [c.get_num_threads() for c in controllers]
    for c, n in zip(controllers, before, strict=True):
        if n != 1:
            c.set_num_threads(1)
    try:
        yield
    finally:
        for c, n in zip(controllers, before, strict=True):
            if n != 1:
                c.set_num_threads(n)


def softmax(q: np.ndarray, valid: np.ndarray, temperature: float) -> np.ndarray:
    """Soft-max policy ``π(a|s) ∝ exp(τ Q(s,a))`` over valid actions (Eq. 2).

    Args:
        q: (..., S, A) action values.
        valid: (S, A) bool (or broadcastable to ``q``).
        temperature: τ > 0.

    Returns:
        (..., S, A) probabilities, zero on invalid actions, summing to 1 over A.
    """
    z = np.where(valid, temperature * q, -np.inf)
    z = z - z.max(axis=-1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


class PartnerIndex(NamedTuple):
    """A joint transition table as one 0/1 matrix per state, for building partner transitions.

    It depends only on the graph, so :func:`partner_index` builds it once per read-only
    ``next_state`` array and keeps it.

    Attributes:
        shape: (S, A_self, A_partner) of the table.
        onehot: (S, A_partner, A_self * S) float, ``onehot[s, p, a * S + s'] = 1`` where
            ``next_state[s, a, p] = s'``.
    """

    shape: tuple[int, int, int]
    onehot: np.ndarray


#: (data address, shape, strides) -> (the array owning the memory, its index).
_INDEX_CACHE: dict[tuple[int, tuple[int, ...], tuple[int, ...]], tuple[object, PartnerIndex]] = {}


def partner_index(next_state: np.ndarray) -> PartnerIndex:
    """The :class:`PartnerIndex` of ``next_state`` (S, A_self, A_partner).

    Cached when the memory's owner is read-only (the task graph's arrays are), keyed by the
    memory and layout, so each graph pays for it once per process; other arrays are indexed
    afresh each call.
    """
    owner = next_state if next_state.base is None else next_state.base
    key = (next_state.ctypes.data, next_state.shape, next_state.strides)
    hit = _INDEX_CACHE.get(key)
    if hit is not None and hit[0] is owner:
        return hit[1]
    n_s, n_a, n_p = next_state.shape
    s, a, p = np.indices((n_s, n_a, n_p))
    onehot = np.zeros((n_s, n_p, n_a, n_s))
    onehot[s, p, a, next_state] = 1.0
    index = PartnerIndex((n_s, n_a, n_p), onehot.reshape(n_s, n_p, n_a * n_s))
    if isinstance(owner, np.ndarray) and not owner.flags.writeable:
        if len(_INDEX_CACHE) >= 16:
            _INDEX_CACHE.clear()
        _INDEX_CACHE[key] = (owner, index)
    return index


def _partner_transition(next_state: np.ndarray, partner: np.ndarray) -> np.ndarray:
    """Σ_p π_p(p|s) 1[next_state[s, a, p] = s'] as a dense (..., S, A, S) array.

    ``next_state`` is (S, A_self, A_partner). One batched product per state of the partner
    policy with the graph's cached 0/1 matrix (:func:`partner_index`), written straight into
    the (..., S, A, S) result: one BLAS call instead of index arithmetic and temporaries.
    Each cell sums the same products in increasing p as the earlier ``bincount``
    construction (multiplying by 1 and adding 0 are exact), so the result is the same to
    the bit (tests/test_learner_reference.py).
    """
    index = partner_index(next_state)
    n_s, n_a, n_p = index.shape
    lead = partner.shape[:-2]
    flat = partner.reshape(-1, n_s, n_p)
    out = np.empty((flat.shape[0], n_s, n_a * n_s))
    np.matmul(flat.transpose(1, 0, 2), index.onehot, out=out.transpose(1, 0, 2))
    return out.reshape(*lead, n_s, n_a, n_s)


def robot_transition(next_state: np.ndarray, pi_h: np.ndarray) -> np.ndarray:
    """T_R(s'|s, ι, a_R) = Σ_{a_H} π̂_H(a_H|s, ι) T(s'|s, a_R, a_H).

    Args:
        next_state: (S, A, A) the joint transition ``next_state[s, a_R, a_H]``.
        pi_h: (..., S, A) human policy.

    Returns:
        (..., S, A, S).
    """
    return _partner_transition(next_state, pi_h)


def human_transition(next_state: np.ndarray, pi_r: np.ndarray) -> np.ndarray:
    """T_H(s'|s, ι, a_H) = Σ_{a_R} π_R(a_R|s, ι) T(s'|s, a_R, a_H).

    Args:
        next_state: (S, A, A) the joint transition ``next_state[s, a_R, a_H]``.
        pi_r: (..., S, A) robot policy.

    Returns:
        (..., S, A, S).
    """
    return _partner_transition(np.swapaxes(next_state, 1, 2), pi_r)


def solve_q(
    transition: np.ndarray,
    reward: np.ndarray,
    valid: np.ndarray,
    gamma: float,
    *,
    policy: np.ndarray | None = None,
    max_iter: int = 100,
) -> np.ndarray:
    """Optimal Q of a discounted MDP by policy iteration (exact Eq. 1 fixed point).

    Args:
        transition: (..., S, A, S) T(s'|s, a).
        reward: (..., S, A) expected immediate reward of (s, a).
        valid: (S, A) bool.
        gamma: Discount in [0, 1).
        policy: (..., S) int greedy actions to start from (a warm start), optional.
        max_iter: Cap on improvement rounds.

    Returns:
        (..., S, A) Q, with invalid actions holding the value they would have (masked by
        the callers).

    Only the MDPs whose policy changed in a round are evaluated again (the others would
    give the same Q again), so a warm-started batch costs about one solve per MDP.
    """
    if not 0.0 <= gamma < 1.0:
        raise ConfigError(f"gamma must be in [0, 1), got {gamma}", field="gamma")
    if max_iter < 1:
        raise ConfigError(f"max_iter must be >= 1, got {max_iter}", field="max_iter")
    lead, (n_s, n_a) = transition.shape[:-3], transition.shape[-3:-1]
    flat_t = np.ascontiguousarray(transition).reshape(-1, n_s, n_a, n_s)  # (N, S, A, S)
    flat_r = np.ascontiguousarray(reward).reshape(-1, n_s, n_a)  # (N, S, A)
    n = flat_t.shape[0]
    by_state = flat_t.reshape(n * n_s * n_a, n_s)  # row (n, s, a): T(.|s, a)
    by_pair = flat_t.reshape(n, n_s * n_a, n_s)
    r_flat = flat_r.reshape(-1)
    if policy is None:
        act = np.where(valid, flat_r, _NEG).argmax(axis=-1)  # (N, S)
    else:
        act = np.broadcast_to(policy, (*lead, n_s)).reshape(n, n_s)
    act = act.copy()
    pair = np.arange(n_s) * n_a  # flat index of (s, a=0) within one MDP
    eye = np.eye(n_s)
    q = np.empty((n, n_s, n_a))
    todo = np.arange(n)  # the MDPs whose policy still changes; the others are final
    for _ in range(max_iter):
        every = len(todo) == n
        act_t = act if every else act[todo]
        chosen = (todo[:, None] * (n_s * n_a) + pair) + act_t  # (K, S): flat (n, s, act)
        p = by_state[chosen.ravel()].reshape(-1, n_s, n_s)  # (K, S, S) under the policy
        r = r_flat[chosen].reshape(-1, n_s, 1)
        v = np.linalg.solve(eye - gamma * p, r)  # (K, S, 1)
        if every:
            q_t = flat_r + gamma * np.matmul(by_pair, v).reshape(n, n_s, n_a)
        else:
            q_t = flat_r[todo] + gamma * np.matmul(by_pair[todo], v).reshape(-1, n_s, n_a)
        q[todo] = q_t
        new_act, changed = improve_policy(q_t, valid, act_t)
        if not changed.any():
            break
        act[todo] = new_act
        # An MDP whose policy did not change would give the same Q again: it is done.
        todo = todo[changed]
    return q.reshape(*lead, n_s, n_a)


def improve_policy(q: np.ndarray, valid: np.ndarray, act: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """One policy-improvement step of policy iteration.

    Args:
        q: (K, S, A) Q of the current policies.
        valid: (S, A) bool.
        act: (K, S) int, the current policies' actions.

    Returns:
        (K, S) the improved actions and (K,) bool, whether an MDP's policy changed. The
        current action is kept on (numerical) ties, so that the iteration terminates.
    """
    q_masked = np.where(valid, q, _NEG)
    best = q_masked.max(axis=-1)
    current = np.take_along_axis(q_masked, act[..., None], axis=-1)[..., 0]
    improve = best - current > 1e-10 * (1.0 + np.abs(best))
    return np.where(improve, q_masked.argmax(axis=-1), act), improve.any(axis=-1)


def q_iteration(
    transition: np.ndarray,
    state_reward: np.ndarray,
    valid: np.ndarray,
    terminal: np.ndarray,
    gamma: float,
) -> np.ndarray:
    """Q-iteration with a state reward R(s') and an absorbing terminal state per intention.

    ``Q(s, a) = Σ_s' T(s'|s,a) [R(s') + γ V(s')]``; the terminal state of intention ι loops on
    itself collecting R(terminal) forever (as in the paper's code).

    Args:
        transition: (..., I, S, A, S).
        state_reward: (..., I, S).
        valid: (S, A) bool.
        terminal: (I,) terminal state per intention.
        gamma: Discount.

    Returns:
        (..., I, S, A).
    """
    transition = absorbing(transition, terminal)
    reward = np.einsum("...saz,...z->...sa", transition, state_reward)
    return solve_q(transition, reward, valid, gamma)


def absorbing(transition: np.ndarray, terminal: np.ndarray, *, copy: bool = True) -> np.ndarray:
    """``transition`` (..., I, S, A, S) with intention ι's terminal state looping on itself.

    Works on a copy unless ``copy=False``.
    """
    out = transition.copy() if copy else transition
    idx = np.arange(len(terminal))
    out[..., idx, terminal, :, :] = 0.0
    out[..., idx, terminal, :, terminal] = 1.0
    return out


def passive_policy(graph: TaskGraph, start: int) -> np.ndarray:
    """(S, A) one-hot policy of the Passive agent (Alg. 2) for an episode from ``start``.

    Grasp at the start support, let go at any other support, wait everywhere else.
    """
    return np.eye(graph.n_actions)[passive_actions(graph, np.asarray(start))]


def passive_actions(graph: TaskGraph, start: np.ndarray, lifted: np.ndarray | None = None
                    ) -> np.ndarray:
    """The Passive baseline's action in every state, per episode.

    Args:
        graph: The task graph.
        start: (...,) start support of each episode.
        lifted: (...,) bool, whether the object has left the start (then the start counts as
            a goal, so the robot lets go there too). Default False.

    Returns:
        (..., S) int actions.
    """
    start = np.asarray(start)[..., None]
    lifted_ = np.zeros(start.shape, bool) if lifted is None else np.asarray(lifted)[..., None]
    states = np.arange(graph.n_states)
    holds = (graph.grasp & 2) > 0
    can_end = arrived(graph, states, start, lifted_)  # (..., S) where the robot lets go
    grasp_here = (graph.support == start) & ~holds & ~lifted_
    release_here = holds & can_end
    return np.where(grasp_here | release_here, TOGGLE, WAIT)


def free_motions(graph: TaskGraph) -> np.ndarray:
    """(S, A) bool, the human's valid motions (putting on, taking off, moving) in free
    states; False at the supports and for waiting and grasping.
    """
    moves = graph.valid & (np.arange(graph.n_actions) >= PUT_ON)[None]
    moves[graph.is_support_state] = False
    return moves


def cost_to_goal(graph: TaskGraph, step: np.ndarray) -> np.ndarray:
    """(..., K, S) the cheapest cost of the human's motions from free state ``s`` until the
    object rests on goal support ``k``, held by both, while the robot waits.

    Args:
        graph: The task graph.
        step: (..., S, A) the cost of taking motion ``a`` in state ``s`` (``inf``: never
            taken), for each of any leading cases (e.g. the episode's start support).

    Support states other than the goal held by both are never entered (``inf``); so is a
    free state with no route to the goal. The iteration (Bellman–Ford on the deterministic
    graph) stops when nothing changes, within S + 1 rounds.
    """
    n_k, n_s = graph.n_intentions, graph.n_states
    free = ~graph.is_support_state
    nxt = graph.next_state[:, WAIT, :]  # (S, A) where the human's motion leads
    dist = np.full((*step.shape[:-2], n_k, n_s), np.inf)
    goals = np.arange(n_k)
    dist[..., goals, graph.support_state(goals, BOTH)] = 0.0
    step = step[..., None, :, :]  # one row per goal
    for _ in range(n_s + 1):
        new = np.where(free, (step + dist[..., nxt]).min(-1), dist)
        if np.array_equal(new, dist):
            break
        dist = new
    return dist
