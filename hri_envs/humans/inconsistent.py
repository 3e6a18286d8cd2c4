"""Inconsistent humans: intentions that change mid-episode, preferences that change at random.

Both are :class:`~hri_envs.humans.finite_state.FiniteStateHuman` models that follow a
scripted preference (:func:`~hri_envs.humans.scripted.preference_human`) otherwise.

* :func:`fickle_human` — **changes its mind mid-episode at random times**: after every step
  that leaves the object in free space, with probability ``hazard`` its intention becomes
  one of the other supports, uniformly (the start support too: then it brings the object
  back), at most ``changes`` times per episode. Unlike turning back halfway (an episode rule
  at a fixed point), the time and the new goal are random; the human reports the new ι
  (:meth:`~hri_envs.humans.protocol.BatchHuman.revised_intentions`) and the seat applies it.
  ``z`` = the changes so far in the episode, ``Z = changes + 1``.
* :func:`moody_human` — **changes its preference at random episodes**: at the end of each
  episode, with probability ``p`` it switches to another of ``preferences`` (uniformly),
  again and again, not at one drift point. ``z`` = the current preference.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hri_envs.checks import check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, carry_to, keep_z, one_hot
from hri_envs.humans.scripted import preference_human
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["fickle_human", "moody_human"]


def fickle_human(graph: TaskGraph, *, hazard: float = 0.15, changes: int = 1,
                 preference: str | None = None) -> FiniteStateHuman:
    """A human who changes its intention mid-episode at random times (module docstring).

    Args:
        graph: The task graph.
        hazard: Probability per step in free space of changing its mind, in [0, 1].
        changes: The most changes per episode (>= 1).
        preference: Its preference (default: the scenario's).
    """
    hazard = check_real(hazard, "hazard", low=0.0, high=1.0, allowed="a probability in [0, 1]")
    changes = check_whole(changes, "changes", minimum=1, maximum=20)
    base = preference_human(graph, preference)
    n_z = changes + 1
    law = np.broadcast_to(one_hot(base.route_table, graph.n_actions)[None, ..., None, :],
                          (n_z, *base.route_table.shape, 1, graph.n_actions))
    free = ~graph.is_support_state
    switch = np.where((np.arange(n_z) < changes)[:, None] & free[None], hazard, 0.0)
    return FiniteStateHuman(graph, f"fickle(hazard={hazard:g},changes={changes})", law,
                            keep_z(graph, n_z), carry_to([0] * n_z, n_z), switch=switch,
                            switched=np.minimum(np.arange(n_z) + 1, changes), family="fickle",
                            params=(("hazard", hazard), ("changes", changes),
                                    ("preference", base.name)))


def moody_human(graph: TaskGraph, *, p: float = 0.25,
                preferences: Sequence[str] | str | None = None) -> FiniteStateHuman:
    """A human whose preference changes at random episodes (module docstring).

    Args:
        graph: The task graph.
        p: Probability per episode of switching to another preference, in [0, 1].
        preferences: The preferences it moves between, the first one at the start
            (a sequence, or names joined by "+"; default: all of the scenario's, up to 4,
            the default first).
    """
    p = check_real(p, "p", low=0.0, high=1.0, allowed="a probability in [0, 1]")
    allowed = spec_of(graph).preferences
    if preferences is None:
        first = spec_of(graph).default_preference
        names = [first, *[q for q in allowed if q != first]][:4]
    else:
        names = preferences.split("+") if isinstance(preferences, str) else list(preferences)
    if len(names) < 2 or len(set(names)) != len(names) or not all(
            isinstance(q, str) and q in allowed for q in names):
        raise ConfigError(f"preferences must name at least two different {graph.name} "
                          f"preferences (joined by '+'), of {', '.join(allowed)}; got "
                          f"{preferences!r}", field="preferences")
    n_z = len(names)
    tables = np.stack([preference_human(graph, q).route_table for q in names])  # (Z, K, K, S)
    law = one_hot(tables, graph.n_actions)[..., None, :]
    carry = np.full((n_z, n_z), p / (n_z - 1))
    np.fill_diagonal(carry, 1.0 - p)
    return FiniteStateHuman(graph, f"moody(p={p:g},{'+'.join(names)})", law, keep_z(graph, n_z),
                            carry, family="moody",
                            params=(("p", p), ("preferences", "+".join(names))))
