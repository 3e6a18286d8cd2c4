"""When two humans are the same: their action laws agree on every context they both reach.

A fingerprint (:attr:`~hri_envs.humans.finite_state.FiniteStateHuman.fingerprint`) tells
two humans apart by the exact bytes of their tables, so a Boltzmann human with β = 37 and
the deterministic human it tends to differ by 1e-17 in an action's probability and still
count as two. :func:`behaviour_distance` compares what they do:

    d(h, h') = the largest, over the contexts both reach, of the total variation distance
               between their laws of the next action, P(a_H | start, ι, s, a_R, history)

Both humans are driven by the same history: the pair of their internal states is followed
from their first episode's states ``(z0, z0')`` through every task state ``s`` the object
can reach from the start, every valid robot action ``a_R`` and every human action either
human takes with probability > 0 (so a difference that only shows after a few episodes of
memory counts). The random parts of a human are laws too, compared under the coupling that
keeps the two in step (the probability they part is that law's distance): a change of mind
after a step (its probability per state) and, for two humans of one family with the same
states, the carry of the internal state into the next episode; humans of different families
or state counts are followed into every pair of states their carries allow. Changes of mind
also make the contexts with ι = start reachable; otherwise ι ≠ start, as every schedule has.

Two humans are **the same** when ``d < TOLERANCE`` (0.05): no context of either, reachable by
both, where their next action's law differs by 5 % of its mass or more. Split version 3
(:mod:`hri_envs.humans.splits`) holds no two members that are the same, nor a member the same
as a train or validation human (docs/humans.md, "Split version 3").
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from hri_envs.humans.finite_state import FiniteStateHuman
from hri_envs.task.graph import TaskGraph

__all__ = ["TOLERANCE", "behaviour_distance", "same_behaviour"]

#: Two humans whose :func:`behaviour_distance` is below this are the same human.
TOLERANCE = 0.05


@lru_cache(maxsize=8)
def _reachable_states(graph: TaskGraph) -> np.ndarray:
    """(K, S) bool: the task states the object can reach from each start support (any
    valid joint action), before it rests on a support again.
    """
    n_k, n_s = graph.n_intentions, graph.n_states
    out = np.zeros((n_k, n_s), dtype=bool)
    joint = graph.valid[:, :, None] & graph.valid[:, None, :]
    resting = np.zeros(n_s, dtype=bool)
    resting[graph.terminal] = True
    for k in range(n_k):
        seen = np.zeros(n_s, dtype=bool)
        seen[graph.terminal[k]] = True
        frontier = seen.copy()
        while frontier.any():
            nxt = np.zeros(n_s, dtype=bool)
            nxt[graph.next_state[frontier][joint[frontier]]] = True
            nxt &= ~seen
            seen |= nxt
            frontier = nxt & ~resting
        out[k] = seen
    return out


def _laws(h: FiniteStateHuman) -> np.ndarray:
    """(Z, K, K, S, A, A) the law per robot action (a law that ignores the robot repeated)."""
    n_a = h.graph.n_actions
    law = h.law[..., :n_a, :] if h.reacts else h.law
    return np.broadcast_to(law, (*h.law.shape[:4], n_a, n_a))


def _tv(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return 0.5 * np.abs(p - q).sum(-1)


def behaviour_distance(a: FiniteStateHuman, b: FiniteStateHuman, stop_at: float = 1.0
                       ) -> float:
    """``d(a, b)`` of the module docstring: 0 for humans that act alike, 1 for two that
    take different actions somewhere both reach. The search stops as soon as the distance
    reaches ``stop_at`` (then at least that is returned).
    """
    g = a.graph
    if b.graph is not g and b.graph.name != g.name:
        return 1.0
    la, lb = _laws(a), _laws(b)
    states = _reachable_states(g)
    valid = g.valid.astype(bool)
    switches = a.switch is not None or b.switch is not None
    n_k = g.n_intentions
    pairs = np.ones((n_k, n_k), dtype=bool) if switches else ~np.eye(n_k, dtype=bool)
    context = pairs[:, :, None, None] & states[:, None, :, None] & valid[None, None]  # K,K,S,A
    sw_a = np.zeros((a.n_z, g.n_states)) if a.switch is None else a.switch
    sw_b = np.zeros((b.n_z, g.n_states)) if b.switch is None else b.switch
    aligned = a.family == b.family and a.n_z == b.n_z and a.family != ""
    reached = np.zeros((a.n_z, b.n_z), dtype=bool)
    reached[a.z0, b.z0] = True
    todo = [(int(a.z0), int(b.z0))]
    worst = 0.0
    while todo:
        za, zb = todo.pop()
        pa, pb = la[za], lb[zb]  # (K, K, S, A, A)
        worst = max(worst, float(_tv(pa, pb)[context].max(initial=0.0)))
        worst = max(worst, float(np.abs(sw_a[za] - sw_b[zb]).max(initial=0.0)))
        if aligned:
            worst = max(worst, float(_tv(a.carry[za], b.carry[zb])))
        if worst >= stop_at:
            return worst
        taken = ((pa > 0) | (pb > 0)) & context[..., None]  # (K, K, S, A_R, A_H)
        idx = np.nonzero(taken)
        nxt = {(int(x), int(y)) for x, y in zip(a.next_z[za][idx], b.next_z[zb][idx],
                                                strict=True)}
        if switches:
            nxt.add((int(a.switched[za]) if a.switched is not None else za,
                     int(b.switched[zb]) if b.switched is not None else zb))
        if aligned:
            nxt |= {(int(z), int(z)) for z in np.flatnonzero((a.carry[za] > 0)
                                                              & (b.carry[zb] > 0))}
        else:
            nxt |= {(int(x), int(y)) for x in np.flatnonzero(a.carry[za] > 0)
                    for y in np.flatnonzero(b.carry[zb] > 0)}
        for pair in nxt:
            if not reached[pair]:
                reached[pair] = True
                todo.append(pair)
    return worst


def same_behaviour(a: FiniteStateHuman, b: FiniteStateHuman,
                   tolerance: float = TOLERANCE) -> bool:
    """Whether ``a`` and ``b`` are the same human: ``behaviour_distance(a, b) < tolerance``."""
    return behaviour_distance(a, b, stop_at=tolerance) < tolerance
