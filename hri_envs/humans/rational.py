"""Boltzmann (noisy) versions of the scripted preference humans: rationality β.

A Boltzmann human (:func:`rational_human`) samples its free-space action from
``softmax(β · Q_pref)`` instead of taking the preference's action. ``Q_pref`` is the
human's own value of following its preference: for the action ``a`` in free state ``s``
(the robot assumed to wait),

    ``Q_pref(s, a) = -(1 + max(D(s'), D(s) - 1)) - 1[a ≠ a_pref(s)]``,

where ``s'`` is the state ``a`` leads to, ``D(s)`` the number of steps the preference's
re-planned route needs from ``s`` to rest on the goal (0 on the goal support, a large
cost ``D_MAX`` on a wrong support or when the route does not reach the goal) and
``a_pref(s)`` the preference's action: a step costs 1, leaving the preferred route costs
1 more, and a shortcut off the route earns no more than one step of progress. Following
the route makes exactly one step of progress, so ``Q_pref(s, a_pref) = -D(s)`` exceeds
every other action's value by at least 1: as β → ∞
the Boltzmann human *is* the scripted one (``β = inf`` returns it unchanged). At a support
the scripted grasp action also beats the others by 1, so with a finite β the human may
hesitate to grasp or to let go too.
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.checks import check_real
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task import mdp
from hri_envs.task.graph import WAIT, TaskGraph

__all__ = ["D_MAX", "MAX_RATIONALITY", "preference_q", "rational_human", "validate_rationality"]

#: The cost-to-go of a wrong support or a route that does not reach the goal, in steps.
D_MAX = 100
#: The largest finite rationality β (:func:`validate_rationality`); ``inf`` is allowed too.
MAX_RATIONALITY = 1e6


def validate_rationality(beta: float, field: str = "human_rationality") -> float:
    """Check a rationality β: a number in (0, :data:`MAX_RATIONALITY`], or ``inf`` (the
    deterministic scripted human).

    Only numbers are accepted (``int``, ``float``, numpy scalars): ``True`` is not β = 1 and
    ``"2"`` is not 2; both raise a :class:`ConfigError` naming ``field``. A finite β above the
    bound would overflow ``β · Q`` to NaN probabilities; it is the deterministic human to
    double precision long before (``exp(-β)`` underflows at β ≈ 745), so give ``inf``.
    """
    if isinstance(beta, float | np.floating) and beta == math.inf:
        return math.inf
    return check_real(beta, field, low=0.0, low_open=True, high=MAX_RATIONALITY,
                      allowed=f"a number > 0 or inf (the deterministic human); finite values "
                              f"at most {MAX_RATIONALITY:g}")


def _cost_to_go(graph: TaskGraph, table: np.ndarray) -> np.ndarray:
    """(K, K, S) steps the deterministic ``table[start, goal, s]`` needs to rest on the goal.

    The robot is assumed to wait; at a support the count is 0 on the goal support and
    :data:`D_MAX` elsewhere; routes longer than ``D_MAX`` steps count :data:`D_MAX`.
    """
    n_k, n_s = graph.n_intentions, graph.n_states
    goal = np.arange(n_k)[None, :, None]
    sup = graph.support[None, None, :]
    at_support = sup >= 0
    dist = np.where(at_support, np.where(sup == goal, 0, D_MAX), D_MAX).astype(np.int64)
    dist = np.broadcast_to(dist, (n_k, n_k, n_s)).copy()
    free = ~graph.is_support_state
    nxt = graph.next_state[np.arange(n_s)[None, None, :], WAIT, table]  # (K, K, S)
    for _ in range(D_MAX):
        stepped = np.minimum(1 + np.take_along_axis(dist, nxt, axis=-1), D_MAX)
        new = np.where(free[None, None, :], stepped, dist)
        if np.array_equal(new, dist):
            break
        dist = new
    return dist


def preference_q(human: ScriptedHuman) -> np.ndarray:
    """(K, K, S, A) ``Q_pref`` of a deterministic preference human (see the module docstring).

    Invalid actions get ``-inf``; support states get 0 for the scripted action and -1 for
    the others, so :func:`rational_human` makes the grasp behaviour as noisy as a step in
    free space.
    """
    if not human.deterministic:
        raise ConfigError("preference_q needs a deterministic (preference) human; "
                          f"got {human.name!r}", field="human")
    g = human.graph
    table = human.preferred_action(np.arange(g.n_states)[None, None, :],
                                   np.arange(g.n_intentions)[:, None, None],
                                   np.arange(g.n_intentions)[None, :, None])  # (K, K, S)
    dist = _cost_to_go(g, table)
    nxt = g.next_state[:, WAIT, :]  # (S, A) where the human's action leads, robot waiting
    d_next = np.maximum(dist[:, :, nxt], dist[..., None] - 1)  # (K, K, S, A)
    off = np.arange(g.n_actions)[None, None, None, :] != table[..., None]
    q = -(1.0 + d_next) - off
    support = g.is_support_state[None, None, :, None]
    q = np.where(support, -off.astype(float), q)
    return np.where(g.valid[None, None], q, -np.inf)


def rational_human(human: ScriptedHuman, beta: float) -> ScriptedHuman:
    """A Boltzmann version of a deterministic preference human: ``π ∝ exp(β Q_pref)``.

    Args:
        human: A deterministic human from :func:`~hri_envs.humans.scripted.preference_human`.
        beta: Rationality β > 0; ``inf`` returns ``human`` itself.

    Returns:
        A human with the same name suffix ``@β``, passivity, turning back and halfway points.
    """
    beta = validate_rationality(beta)
    if math.isinf(beta):
        return human
    g = human.graph
    q = preference_q(human)
    valid = g.valid[None, None]
    policy = mdp.softmax(np.where(valid, q, 0.0), valid, beta)
    return ScriptedHuman(g, policy, f"{human.name}@{beta:g}", human.turn_state, human.passive,
                         human.turn_back)
