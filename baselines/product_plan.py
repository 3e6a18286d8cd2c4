"""Exact plans on the product of the task's and the human's states (:func:`plan_product`).

For a :class:`~hri_envs.humans.finite_state.FiniteStateHuman` the world within an episode is
Markov in the node ``(start, ι, lifted, s, z)`` (:func:`node_index`); the references of
:mod:`baselines.product` follow these plans.

**Objective.** What the benchmark measures: the expected undiscounted sum of the robot's
reward over the run's episodes, each cut at ``max_steps``. Within an episode, backward
induction over the steps left ``t`` (``t = 0``: cut) with the chance over the human's action
and its change of mind. Across episodes, the value of the human's state at the end of an
episode is ``cont(z) = Σ_z' carry[z, z'] W_{e+1}(z')``, where ``W_e(z)`` is the expected
value of episodes ``e ..`` when episode ``e`` starts in ``z`` (start and ι drawn as the
benchmark draws them: start uniform, ι uniform among the others), so the plan of episode
``e`` maximises the episode's reward plus ``cont`` of where it leaves the human. Where
``cont`` cannot depend on ``z`` (the human forgets between episodes, or every root's
episode value is 0, the largest a reward can sum to), one plan serves every episode and the
passes over episodes are skipped: it is the same optimum. Backward induction stops early
once the values stop changing (to 1e-12): the policy is then the same for more steps left.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.bounds import reward_table
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.tables import TableHumans
from hri_envs.task import episode as rules
from hri_envs.task.graph import TaskGraph

#: Values that change by less than this between two numbers of steps left count as settled.
SETTLED = 1e-12


@dataclass(frozen=True)
class ProductPlan:
    """An exact plan for one finite-state human (see the module docstring).

    Nodes are ``n = (((start K + ι) 2 + lifted) S + s) Z + z``.

    Attributes:
        human: The model planned for.
        horizon: T = ``max_steps``.
        policies: Per episode index (one entry when one plan serves every episode),
            (T_e + 1, N) int8: the optimal robot action with ``min(t, T_e)`` steps left.
        q: Per episode index, (N, A) the action values with the most steps left planned
            (``-inf`` on invalid actions).
        value: Per episode index, (N,) the value with T steps left (at the roots: the
            expected episode reward plus the continuation).
        episode_value: (K, K, Z) the expected reward of the *first* planned episode alone
            (no continuation) from each root ``(start, ι, z)``; NaN where ι = start.
    """

    human: FiniteStateHuman
    horizon: int
    policies: tuple[np.ndarray, ...]
    q: tuple[np.ndarray, ...]
    value: tuple[np.ndarray, ...]
    episode_value: np.ndarray

    def index(self, episode: int) -> int:
        """The plan entry for the 0-based episode index (the last one beyond)."""
        return min(int(episode), len(self.policies) - 1)


def node_index(graph: TaskGraph, n_z: Any, start: Any, intention: Any, lifted: Any, s: Any,
               z: Any) -> Any:
    """The product node of ``(start, ι, lifted, s, z)`` (ints or arrays that broadcast)."""
    k, n_s = graph.n_intentions, graph.n_states
    return ((((np.asarray(start) * k + intention) * 2 + np.asarray(lifted, dtype=np.int64))
             * n_s + s) * n_z + z)


@dataclass(frozen=True)
class _Edges:
    node: np.ndarray  # (E,) source node
    act: np.ndarray  # (E,) robot action
    prob: np.ndarray  # (E,)
    reward: np.ndarray  # (E,)
    succ: np.ndarray  # (E,) successor node, N for the end of the episode
    z_end: np.ndarray  # (E,) the human's state where the episode ends (else 0)
    valid: np.ndarray  # (N, A) the robot's valid actions
    n_nodes: int


def _edges(graph: TaskGraph, human: FiniteStateHuman, r0: float, reward: str) -> _Edges:
    """Every (node, a_R) -> successor with its probability and reward, vectorised."""
    g = graph
    k, n_s, n_a, n_z = g.n_intentions, g.n_states, g.n_actions, human.n_z
    st, io, lf, s, z, a_r, a_h = np.ix_(np.arange(k), np.arange(k), np.arange(2),
                                        np.arange(n_s), np.arange(n_z), np.arange(n_a),
                                        np.arange(n_a))
    slot = a_r if human.reacts else 0
    law = human.law[z, st, io, s, slot, a_h]  # (K, K, 2, S, Z, A, A)
    shape = (k, k, 2, n_s, n_z, n_a, n_a)
    mask = np.broadcast_to((law > 0) & g.valid[s, a_r], shape)
    law = np.broadcast_to(law, shape)
    i_st, i_io, i_lf, i_s, i_z, i_ar, i_ah = np.nonzero(mask)
    p = law[mask]
    s2 = g.next_state[i_s, i_ar, i_ah]
    r_tab = reward_table(g, r0, reward)  # (K, 2, S, A, A)
    r = r_tab[i_st, i_lf, i_s, i_ar, i_ah]
    lf2 = i_lf.astype(bool) | rules.left_start(g, s2, i_st)
    over = rules.episode_over(g, s2, i_st, lf2)
    z2 = human.next_z[i_z, i_st, i_io, i_s, i_ar, i_ah].astype(np.int64)
    node = node_index(g, n_z, i_st, i_io, i_lf, i_s, i_z)
    n_nodes = k * k * 2 * n_s * n_z
    parts = []
    h = np.zeros(len(p)) if human.switch is None else np.where(over, 0.0, human.switch[z2, s2])
    stay = p * (1.0 - h)
    succ = np.where(over, n_nodes, node_index(g, n_z, i_st, i_io, lf2, s2, z2))
    parts.append((node, i_ar, stay, r, succ, np.where(over, z2, 0)))
    if human.switch is not None and np.any(h > 0):
        assert human.switched is not None
        moved = h > 0
        for shift in range(1, k):
            new_io = (i_io + shift) % k
            z3 = human.switched[z2]
            succ2 = node_index(g, n_z, i_st, new_io, lf2, s2, z3)
            parts.append((node[moved], i_ar[moved], (p * h / (k - 1))[moved], r[moved],
                          succ2[moved], np.zeros(int(moved.sum()), dtype=np.int64)))
    cols = [np.concatenate(c) for c in zip(*parts, strict=True)]
    keep = cols[2] > 0
    valid = np.broadcast_to(g.valid[None, None, None, :, None, :],
                            (k, k, 2, n_s, n_z, n_a)).reshape(n_nodes, n_a)
    node_, act_, prob_, rew_, succ_, z_end_ = (c[keep] for c in cols)
    return _Edges(node_, act_, prob_, rew_, succ_, z_end_, valid, n_nodes)


def _pass(e: _Edges, n_a: int, n_z: int, horizon: int, cont: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Backward induction of one episode with continuation ``cont`` (Z,): (policy rows,
    Q with the most steps left, V with T steps left).
    """
    n = e.n_nodes
    z_of = np.arange(n) % n_z
    flat = e.node * n_a + e.act
    terminal = e.succ == n
    term_value = cont[e.z_end]
    immediate = np.bincount(flat, weights=e.prob * (e.reward + np.where(terminal, term_value,
                                                                          0.0)),
                            minlength=n * n_a)
    w_next = np.where(terminal, 0.0, e.prob)
    succ = np.where(terminal, 0, e.succ)
    v = cont[z_of].copy()  # t = 0: cut; the run goes on from the carried state
    rows = [np.zeros(n, dtype=np.int8)]
    q: np.ndarray = np.zeros((n, n_a))
    for _t in range(1, horizon + 1):
        summed = immediate + np.bincount(flat, weights=w_next * v[succ], minlength=n * n_a)
        q = np.where(e.valid, summed.reshape(n, n_a), -np.inf)
        best = np.argmax(q, axis=1)
        new_v = q[np.arange(n), best]
        rows.append(best.astype(np.int8))
        settled = np.max(np.abs(new_v - v)) < SETTLED
        v = new_v
        if settled:
            break
    return np.stack(rows), q, v


_CACHE: dict[tuple[object, ...], ProductPlan] = {}


def plan_product(graph: TaskGraph, human: FiniteStateHuman, *, r0: float, max_steps: int = 100,
                 reward: str = "paper", episodes: int = 1) -> ProductPlan:
    """The exact plan for ``human`` over ``episodes`` episodes (see the module docstring);
    cached per (human, r0, max_steps, reward, episodes).
    """
    rules.reward_rule(reward)  # a ConfigError listing the registered rules
    key = (human.fingerprint, float(r0), int(max_steps), reward, int(episodes))
    if key in _CACHE:
        return _CACHE[key]
    e = _edges(graph, human, r0, reward)
    k, n_z, n_a = graph.n_intentions, human.n_z, graph.n_actions
    st, io, z = np.meshgrid(np.arange(k), np.arange(k), np.arange(n_z), indexing="ij")
    roots = node_index(graph, n_z, st, io, 0, rules.start_state(graph, st), z)  # (K, K, Z)
    others = st != io

    def expected(v: np.ndarray) -> np.ndarray:  # (Z,) mean over start and ι ≠ start
        vals = np.where(others, v[roots], 0.0).sum((0, 1))
        return vals / others[:, :, 0].sum()

    zero = np.zeros(n_z)
    pol, q, v = _pass(e, n_a, n_z, max_steps, zero)
    first = np.where(others, v[roots], np.nan)
    plans = [(pol, q, v)]
    if human.remembers and episodes > 1 and np.any(first[others] < 0.0):
        plans = []
        w = zero
        for _ in range(episodes):  # the last episode first
            pol, q, v = _pass(e, n_a, n_z, max_steps, human.carry @ w)
            plans.append((pol, q, v))
            w = expected(v)
        plans.reverse()
    out = ProductPlan(human, int(max_steps), tuple(p[0] for p in plans),
                      tuple(p[1] for p in plans), tuple(p[2] for p in plans), first)
    if len(_CACHE) > 256:
        _CACHE.clear()
    _CACHE[key] = out
    return out


# --------------------------------------------------------------------------- which human
def model_of_row(human: ScriptedHuman | BatchHuman, row: int
                 ) -> ScriptedHuman | FiniteStateHuman | None:
    """The model of row ``row``'s human in its current episode (None: no model, e.g. a human
    class of the user's).
    """
    if isinstance(human, ScriptedHuman):
        return human
    if isinstance(human, FiniteStateHumans):
        return human.model_of(row)
    if isinstance(human, TableHumans):
        return human.current[row]
    return None
