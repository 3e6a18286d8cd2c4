"""Adaptive humans: partners who learn from the robot, across steps and episodes.

Each is a :class:`~hri_envs.humans.finite_state.FiniteStateHuman` whose internal state ``z``
is what it has learned about the robot; ``z`` carries over from one episode to the next
(for :func:`wary_human`, partly forgotten). "The human's action" ``a*`` below is its
preference's action (:func:`~hri_envs.humans.scripted.preference_human`) in the state, for
its start and current intention; a *wrong* robot motion is a valid robot motion other than
``a*`` at a step where the human wanted to move.

* :func:`follower_human` — **follows the robot's route** after the robot proposed it ``k``
  times in a row. The human knows two routes, its own preference and another one; a robot
  motion that is the other route's action where the two differ is a proposal, one that is
  its own route's action there resets the count. At the ``k``-th proposal in a row (counted
  across episodes) the human adopts the other route in that very step (it moves with the
  robot) and keeps it; proposals of its old route may later bring it back the same way.
  ``z = (route, count)``, ``Z = 2 k``.
* :func:`trust_human` — **a trust level that rises and falls**, from 0 to ``levels``. A
  robot motion that is ``a*`` raises it by ``rise``, a wrong robot motion lowers it by
  ``fall``. The more the human trusts, the more it lets the robot lead: wherever it wanted
  to move, it waits with probability ``passive · trust / levels`` (a robot that waits too
  then leaves a passive partner alone: r⁻). ``Z = levels + 1``, starting at ``start``.
* :func:`wary_human` — **resists more after wrong robot actions**. A wary human first
  yields to the robot: when the robot makes a wrong motion, it waits (the object goes the
  robot's way) with probability ``1 - wariness / levels`` and resists (insists on ``a*``:
  the robot's motion is counteracted) otherwise. Every wrong robot motion raises its
  wariness by 1 (up to ``levels``); it forgets ``forgive`` levels between episodes. It needs
  the robot's action of the same step; where a seat does not know it, it acts by ``a*``.
  ``Z = levels + 1``, starting at 0.
"""

from __future__ import annotations

import numpy as np

from hri_envs.checks import check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, carry_to, one_hot
from hri_envs.humans.scripted import preference_human
from hri_envs.task.actions import TAKE_OFF, WAIT
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["follower_human", "trust_human", "wary_human"]


def _wrong(graph: TaskGraph, table: np.ndarray) -> np.ndarray:
    """(K, K, S, A) a robot action ``a_R`` is a wrong motion: valid, a motion, other than the
    human's action ``table[start, ι, s]``, at a step where the human wanted to move.
    """
    a = np.arange(graph.n_actions)
    valid_motion = graph.valid & (a >= TAKE_OFF)  # (S, A)
    moving = table >= TAKE_OFF
    return valid_motion[None, None] & moving[..., None] & (a != table[..., None])


def follower_human(graph: TaskGraph, *, k: int = 3, preference: str | None = None,
                   other: str | None = None) -> FiniteStateHuman:
    """A human who adopts the robot's route after ``k`` proposals in a row (module docstring).

    Args:
        graph: The task graph.
        k: Proposals in a row that make it switch routes (>= 1).
        preference: Its own route at the start (default: the scenario's).
        other: The route the robot can talk it into (default: the scenario's next preference
            after ``preference``).
    """
    k = check_whole(k, "k", minimum=1, maximum=50)
    prefs = spec_of(graph).preferences
    own = preference_human(graph, preference)
    if other is None:
        other = prefs[(prefs.index(own.name) + 1) % len(prefs)]
    if not isinstance(other, str) or other not in prefs or other == own.name:
        raise ConfigError(f"other must be a {graph.name} preference other than {own.name!r}: "
                          f"one of {', '.join(p for p in prefs if p != own.name)}; got "
                          f"{other!r}", field="other")
    tables = np.stack([own.route_table, preference_human(graph, other).route_table])  # (2,K,K,S)
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    n_z = 2 * k
    act = np.zeros((n_z, n_k, n_k, n_s, n_a + 1), dtype=np.int64)
    next_z = np.zeros((n_z, n_k, n_k, n_s, n_a, n_a), dtype=np.int16)
    a_r = np.arange(n_a)[:, None]  # the robot's action on the (a_R, a_H) axes of next_z
    for route in (0, 1):
        mine, theirs = tables[route], tables[1 - route]
        differ = (mine != theirs)[..., None, None]  # (K, K, S, 1, 1)
        proposal = differ & (a_r == theirs[..., None, None])  # (K, K, S, A, 1)
        own_step = differ & (a_r == mine[..., None, None])
        for count in range(k):
            z = route * k + count
            act[z] = mine[..., None]
            if count == k - 1:  # this proposal is the k-th: move with the robot
                adopt = proposal[..., 0]  # (K, K, S, A)
                act[z, ..., :n_a] = np.where(adopt, theirs[..., None], mine[..., None])
            switched = (1 - route) * k
            bumped = switched if count == k - 1 else z + 1
            next_z[z] = np.where(proposal, bumped, np.where(own_step, route * k, z))
    return FiniteStateHuman(graph, f"follower(k={k},{own.name}->{other})",
                            one_hot(act, n_a), next_z, np.eye(n_z), family="follower",
                            params=(("k", k), ("preference", own.name), ("other", other)))


def trust_human(graph: TaskGraph, *, levels: int = 4, start: int = 1, rise: int = 1,
                fall: int = 2, passive: float = 0.6, preference: str | None = None
                ) -> FiniteStateHuman:
    """A human whose trust in the robot rises and falls (module docstring).

    Args:
        graph: The task graph.
        levels: The highest trust level (>= 1).
        start: The trust level of the run's first episode (0 .. levels).
        rise: Levels gained per robot motion that is the human's action (>= 0).
        fall: Levels lost per wrong robot motion (>= 0).
        passive: Probability of letting the robot lead (waiting) at full trust, in [0, 1].
        preference: Its preference (default: the scenario's).
    """
    levels = check_whole(levels, "levels", minimum=1, maximum=50)
    start = check_whole(start, "start", minimum=0, maximum=levels)
    rise = check_whole(rise, "rise", minimum=0, maximum=levels)
    fall = check_whole(fall, "fall", minimum=0, maximum=levels)
    passive = check_real(passive, "passive", low=0.0, high=1.0,
                         allowed="a probability in [0, 1]")
    base = preference_human(graph, preference)
    table = base.route_table
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    n_z = levels + 1
    moving = (table >= TAKE_OFF)[None, ..., None]  # (1, K, K, S, 1)
    p_wait = passive * np.arange(n_z)[:, None, None, None, None] / levels  # (Z, 1, 1, 1, 1)
    law = np.broadcast_to(one_hot(table, n_a)[None], (n_z, n_k, n_k, n_s, n_a)).copy()
    law = np.where(moving, (1.0 - p_wait) * law, law)
    law[..., WAIT] += np.where(moving[..., 0], p_wait[..., 0], 0.0)
    a = np.arange(n_a)
    led = (a[:, None] == table[..., None, None]) & (table >= TAKE_OFF)[..., None, None]
    wrong = _wrong(graph, table)[..., None]  # (K, K, S, A, 1)
    z = np.arange(n_z)[:, None, None, None, None, None]
    next_z = np.where(led[None], np.minimum(z + rise, levels),
                      np.where(wrong[None], np.maximum(z - fall, 0), z)).astype(np.int16)
    next_z = np.broadcast_to(next_z, (n_z, n_k, n_k, n_s, n_a, n_a)).copy()
    return FiniteStateHuman(
        graph, f"trust(levels={levels},start={start},rise={rise},fall={fall},"
        f"passive={passive:g})", law[:, :, :, :, None, :], next_z, np.eye(n_z), z0=start,
        family="trust", params=(("levels", levels), ("start", start), ("rise", rise),
                                ("fall", fall), ("passive", passive),
                                ("preference", base.name)))


def wary_human(graph: TaskGraph, *, levels: int = 3, forgive: int = 1,
               preference: str | None = None) -> FiniteStateHuman:
    """A human who resists more after each wrong robot motion (module docstring).

    Args:
        graph: The task graph.
        levels: Wariness at which it always resists (>= 1).
        forgive: Wariness levels forgotten between episodes (>= 0).
        preference: Its preference (default: the scenario's).
    """
    levels = check_whole(levels, "levels", minimum=1, maximum=50)
    forgive = check_whole(forgive, "forgive", minimum=0, maximum=levels)
    base = preference_human(graph, preference)
    table = base.route_table
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    n_z = levels + 1
    wrong = _wrong(graph, table)  # (K, K, S, A)
    own = one_hot(table, n_a)[..., None, :]  # (K, K, S, 1, A)
    yield_p = 1.0 - np.arange(n_z) / levels  # (Z,)
    wait = one_hot(np.full(table.shape, WAIT), n_a)[..., None, :]
    law = np.broadcast_to(own[None], (n_z, n_k, n_k, n_s, n_a + 1, n_a)).copy()
    mixed = yield_p[:, None, None, None, None, None] * wait[None] \
        + (1.0 - yield_p)[:, None, None, None, None, None] * own[None]
    law[..., :n_a, :] = np.where(wrong[None, ..., None], mixed, law[..., :n_a, :])
    z = np.arange(n_z)[:, None, None, None, None, None]
    next_z = np.where(wrong[None, ..., None], np.minimum(z + 1, levels), z).astype(np.int16)
    next_z = np.broadcast_to(next_z, (n_z, n_k, n_k, n_s, n_a, n_a)).copy()
    carry = carry_to(np.maximum(np.arange(n_z) - forgive, 0), n_z)
    return FiniteStateHuman(graph, f"wary(levels={levels},forgive={forgive})", law, next_z,
                            carry, family="wary",
                            params=(("levels", levels), ("forgive", forgive),
                                    ("preference", base.name)))
