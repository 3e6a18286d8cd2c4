"""Misspecified humans: preferences over quantities the Learner's features φ do not encode.

The Learner models the human as Boltzmann-rational for a reward ``θᵀφ(s, ι)`` over 26
features: RBFs (σ = 2 cm, 10°) of the distance to the intended support, to the nearest other
support and to the carrying height (docs/task-model.md). The humans here want something
else, computed from the scenario's geometry (the graph's waypoint positions in metres):

* :func:`low_human` — **keeps the object low**: every step costs ``1 + w · (z' - z_min)``,
  the height of the waypoint entered above the lowest waypoint, in metres (a cost linear in
  height, which no RBF feature is).
* :func:`avoid_human` — **avoids passing near a support**: every step costs
  ``1 + w · exp(-d² / 2σ²)``, ``d`` the distance in metres from the waypoint entered to the
  resting position of the support to avoid (σ in metres, much wider than φ's 2 cm).
* :func:`rotate_low_human` — **minimises the effort of rotating**: a rotation costs
  ``w · (z - z_min)`` on top of its step, so the human rotates the object as low as the
  route allows, taking extra steps down and up for it.
* :func:`impatient_human` — **impatient**: it expects the robot to lead. While the robot
  has waited fewer than ``k`` times in the episode at a step where the human wanted to move,
  a robot that waits is answered with a wait (nothing moves: r⁻ for the robot); after the
  robot's ``k``-th such wait the human takes over and follows its preference for the rest
  of the episode. A robot motion is answered as by the scripted human. It needs the robot's
  action of the same step (the benchmark, the robot envs); where a seat does not know it,
  it acts as the scripted human. A finite-state human (``z`` = the robot's waits so far,
  forgotten at the episode's end).

The first three plan their route from wherever the object is, with the robot assumed to wait
(as the scripted humans re-plan), the cheapest route to the intended support by dynamic
programming; among equally cheap actions they take their base preference's. They are
deterministic :class:`~hri_envs.humans.scripted.ScriptedHuman` tables, so the exact
``blind`` reference fits them. They grasp and let go as every scripted human does.
"""

from __future__ import annotations

import numpy as np

from hri_envs.checks import check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, carry_to, one_hot
from hri_envs.humans.scripted import ScriptedHuman, preference_human, support_actions
from hri_envs.task import mdp
from hri_envs.task.actions import ROTATE, TAKE_OFF, WAIT
from hri_envs.task.graph import TaskGraph

__all__ = ["avoid_human", "cost_route", "impatient_human", "low_human", "rotate_low_human"]

#: Costs within this of the cheapest count as ties (broken by the base preference).
_TIE = 1e-9


def cost_route(graph: TaskGraph, cost: np.ndarray, prefer: np.ndarray) -> np.ndarray:
    """(K, K, S) the cheapest route's action ``table[start, goal, s]``, robot waiting.

    Args:
        graph: The task graph.
        cost: (K, S, A) the extra cost (>= 0, besides 1 per step) of taking motion ``a`` in
            free state ``s`` in an episode from support ``start`` (the first axis).
        prefer: (K, K, S) the base preference's actions, which break ties.

    Every motion costs 1 plus ``cost``; resting on the goal held by both costs nothing more,
    any other support is never entered. Support states get the scripted grasp behaviour
    (:func:`~hri_envs.humans.scripted.support_actions`).
    """
    g = graph
    free = ~g.is_support_state
    moves = mdp.free_motions(g)  # (S, A)
    step = np.where(moves[None], 1.0 + cost, np.inf)  # (K, S, A)
    dist = mdp.cost_to_goal(g, step)  # (K start, K goal, S)
    cand = step[:, None] + dist[:, :, g.next_state[:, WAIT, :]]  # (K, K, S, A)
    best = cand.min(-1, keepdims=True)
    ties = cand <= best + _TIE
    preferred = np.take_along_axis(ties, np.asarray(prefer, dtype=np.int64)[..., None], -1)[..., 0]
    table = np.where(preferred, prefer, np.argmax(ties, axis=-1)).astype(np.int64)
    table = np.where(free[None, None] & np.isfinite(best[..., 0]), table, WAIT)
    support_actions(g, table)
    return table


def _scripted(graph: TaskGraph, table: np.ndarray, name: str) -> ScriptedHuman:
    policy = one_hot(table, graph.n_actions)
    never = np.full((graph.n_intentions,) * 2, -1, dtype=np.int64)
    return ScriptedHuman(graph, policy, name, never)


def _heights(graph: TaskGraph) -> np.ndarray:
    """(S,) the height of each free state above the lowest waypoint [m] (0 at supports)."""
    z = graph.position[:, 2]
    free = ~graph.is_support_state
    return np.where(free, z - z[free].min(), 0.0)


def _entered(graph: TaskGraph, per_state: np.ndarray) -> np.ndarray:
    """(S, A) ``per_state`` of the free state each motion enters (0 for put on)."""
    nxt = graph.next_state[:, WAIT, :]
    return np.where(graph.is_support_state[nxt], 0.0, per_state[nxt])


def low_human(graph: TaskGraph, *, w: float = 4.0, preference: str | None = None
              ) -> ScriptedHuman:
    """A human who keeps the object low: a step costs ``1 + w · (height above the lowest
    waypoint [m])`` of the waypoint entered.

    Args:
        graph: The task graph.
        w: Cost per metre of height, per step (> 0).
        preference: The base preference that breaks ties (default: the scenario's).
    """
    w = check_real(w, "w", low=0.0, low_open=True, high=1e3, allowed="a weight in (0, 1000]")
    base = preference_human(graph, preference)
    cost = np.broadcast_to(w * _entered(graph, _heights(graph)),
                           (graph.n_intentions, graph.n_states, graph.n_actions))
    return _scripted(graph, cost_route(graph, cost, base.route_table), f"low(w={w:g})")


def avoid_human(graph: TaskGraph, *, support: str = "A", w: float = 3.0, sigma: float = 0.3,
                preference: str | None = None) -> ScriptedHuman:
    """A human who avoids passing near ``support``: a step costs
    ``1 + w · exp(-d² / 2σ²)``, ``d`` [m] from the waypoint entered to the support's resting
    position.

    Args:
        graph: The task graph.
        support: The support's name (e.g. "A").
        w: The cost right at the support (> 0).
        sigma: The width σ of the avoided zone [m] (> 0).
        preference: The base preference that breaks ties (default: the scenario's).
    """
    names = graph.support_names
    if not isinstance(support, str) or support not in names:
        raise ConfigError(f"support must be one of {', '.join(names)}, got {support!r}",
                          field="support")
    w = check_real(w, "w", low=0.0, low_open=True, high=1e3, allowed="a weight in (0, 1000]")
    sigma = check_real(sigma, "sigma", low=0.0, low_open=True, high=100.0,
                       allowed="a width in (0, 100] m")
    p_k = graph.scenario.supports[names.index(support)].position
    d2 = ((graph.position - p_k) ** 2).sum(-1)
    near = w * np.exp(-d2 / (2.0 * sigma ** 2))
    cost = np.broadcast_to(_entered(graph, near),
                           (graph.n_intentions, graph.n_states, graph.n_actions))
    base = preference_human(graph, preference)
    return _scripted(graph, cost_route(graph, cost, base.route_table),
                     f"avoid(support={support},w={w:g},sigma={sigma:g})")


def rotate_low_human(graph: TaskGraph, *, w: float = 4.0, preference: str | None = None
                     ) -> ScriptedHuman:
    """A human who rotates the object as low as it can: a rotation costs
    ``w · (height above the lowest waypoint [m])`` besides its step.

    Args:
        graph: The task graph.
        w: Cost per metre of height at which it rotates (> 0).
        preference: The base preference that breaks ties (default: the scenario's).
    """
    w = check_real(w, "w", low=0.0, low_open=True, high=1e3, allowed="a weight in (0, 1000]")
    extra = np.zeros((graph.n_states, graph.n_actions))
    extra[:, ROTATE] = w * _heights(graph)
    cost = np.broadcast_to(extra, (graph.n_intentions, graph.n_states, graph.n_actions))
    base = preference_human(graph, preference)
    return _scripted(graph, cost_route(graph, cost, base.route_table), f"rotate-low(w={w:g})")


def impatient_human(graph: TaskGraph, *, k: int = 2, preference: str | None = None
                    ) -> FiniteStateHuman:
    """A human who takes over after the robot waited ``k`` times in an episode (see the
    module docstring).

    Args:
        graph: The task graph.
        k: The robot waits it answers by waiting, per episode (>= 1).
        preference: Its preference (default: the scenario's).

    Returns:
        A finite-state human with ``Z = k + 1`` (``z``: the robot's waits so far, at steps
        where the human wanted to move; reset at the episode's end).
    """
    k = check_whole(k, "k", minimum=1, maximum=50)
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    table = preference_human(graph, preference).route_table  # (K, K, S)
    moving = table >= TAKE_OFF
    n_z = k + 1
    act = np.broadcast_to(table[None, :, :, :, None], (n_z, n_k, n_k, n_s, n_a + 1)).copy()
    waiting = moving[None] & (np.arange(n_z) < k)[:, None, None, None]
    act[..., WAIT] = np.where(waiting, WAIT, act[..., WAIT])
    counted = moving[None, :, :, :, None, None] & (np.arange(n_a) == WAIT)[:, None]
    z = np.arange(n_z)[:, None, None, None, None, None]
    next_z = np.minimum(z + counted, k).astype(np.int16)
    next_z = np.broadcast_to(next_z, (n_z, n_k, n_k, n_s, n_a, n_a)).copy()
    return FiniteStateHuman(graph, f"impatient(k={k})", one_hot(act, n_a), next_z,
                            carry_to([0] * n_z, n_z), family="impatient",
                            params=(("k", k), ("preference", preference)))
