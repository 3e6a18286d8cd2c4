"""Scripted humans: preference-following and Boltzmann-rational partners.

A scripted human is a policy table ``policy[start, goal, s, a]`` (probabilities over the
human's actions, given the episode's start support, the current intention and the state)
plus two behaviours layered on top of it:

* ``passive``: the probability of waiting in any step instead of acting (paper Fig. 10c
  uses 0.2);
* ``turn_back``: the probability that, in an episode, the human changes their mind halfway
  and returns the object to the start support (paper Table 2, episode 8).

Preference-following humans are deterministic; they are built from a *preference*: the
order in which the human changes column ("over"), height and orientation on the way from
one support to another. Off the preferred route (for example after the robot moved the
object while the human was passive) the human re-plans with the same order from where the
object is. All sampling takes an explicit :class:`numpy.random.Generator` and works on
arrays of episodes at once.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.task import mdp
from hri_envs.task.graph import (
    BOTH,
    HUMAN_BIT,
    PUT_ON,
    ROTATE,
    TAKE_OFF,
    TOGGLE,
    WAIT,
    TaskGraph,
)
from hri_envs.task.scenarios import Op, ScenarioSpec, as_spec, spec_of

__all__ = [
    "PreferredActions",
    "ScriptedHuman",
    "boltzmann_human",
    "check_probability",
    "preference_human",
    "preferences_for",
    "support_actions",
]



def preferences_for(scenario: TaskGraph | ScenarioSpec | str) -> tuple[str, ...]:
    """The preference names a scenario accepts: its graph's or spec's, or (a user's public
    edge) the registered scenario's of that name, resolved here.
    """
    return as_spec(scenario).preferences


def _apply(graph: TaskGraph, s: int, op: Op) -> tuple[int, int] | None:
    """(action, next state) that makes progress on ``op`` from free state ``s``; None if done."""
    kind, target = op
    c, h, o = int(graph.column[s]), int(graph.height[s]), int(graph.orientation[s])
    if kind == "over" and c != target:
        a = graph.move_over(target)
    elif kind == "height" and h != target:
        a = graph.move_to_height(target)
    elif kind == "rotate" and o != target:
        a = ROTATE
    else:
        return None
    return a, int(graph.next_state[s, WAIT, a])


def _plan(graph: TaskGraph, s: int, ops: Sequence[Op]) -> list[tuple[int, int]]:
    """The (action, next state) sequence the ops prescribe from free state ``s``."""
    path = []
    for op in ops:
        while (step := _apply(graph, s, op)) is not None:
            path.append(step)
            s = step[1]
    return path


@runtime_checkable
class PreferredActions(Protocol):
    """Anything that names the human's most likely action per episode (the Oracle's model):
    a :class:`ScriptedHuman`, or the benchmark's human per run.
    """

    def preferred_action(
        self, state: np.ndarray, start: np.ndarray, goal: np.ndarray
    ) -> np.ndarray:
        """The most likely action in ``state`` (int arrays of equal shape)."""
        ...


def check_probability(value: object, field: str) -> float:
    """``value`` as a float if it is a probability in [0, 1], else a :class:`ConfigError`
    naming ``field``.
    """
    if (isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating)
            or not 0.0 <= value <= 1.0):
        raise ConfigError(f"{field} must be a probability in [0, 1], got {value!r}",
                          field=field)
    return float(value)


@dataclass(frozen=True, eq=False)
class ScriptedHuman:
    """A scripted human partner.

    Attributes:
        graph: The task graph the human acts on.
        policy: (K, K, S, A) probabilities ``π_H(a | s; start, goal)``; zero on invalid actions.
        name: Readable description (the preference or "boltzmann").
        passive: Probability of waiting in a step instead of acting.
        turn_back: Probability per episode of returning to the start halfway.
        turn_state: (K, K) int, the state at which a turning-back human changes their
            intention to the start support, -1 where the route is too short.
    """

    graph: TaskGraph
    policy: np.ndarray
    name: str
    turn_state: np.ndarray
    passive: float = 0.0
    turn_back: float = 0.0
    _greedy: np.ndarray = field(init=False, repr=False)  # (K, K, S) the likeliest action
    _deterministic: bool = field(init=False, repr=False)
    _cumulative: np.ndarray = field(init=False, repr=False)  # (K, K, S, A) the policy's CDF

    def __post_init__(self) -> None:
        k, s, a = self.graph.n_intentions, self.graph.n_states, self.graph.n_actions
        if self.policy.shape != (k, k, s, a):
            raise ConfigError(f"policy must have shape {(k, k, s, a)}, got {self.policy.shape}",
                              field="policy")
        check_probability(self.passive, "passive")
        check_probability(self.turn_back, "turn_back")
        if np.any(self.policy[..., ~self.graph.valid.astype(bool)] > 0):
            raise ConfigError("policy puts probability on actions that are invalid in the state; "
                              "only the graph's valid actions are allowed", field="policy")
        table = np.argmax(self.policy, axis=-1)
        object.__setattr__(self, "_greedy", table)
        object.__setattr__(self, "_deterministic", bool(np.all(self.policy.max(-1) == 1.0)))
        object.__setattr__(self, "_cumulative", np.cumsum(self.policy, axis=-1))
        if self.turn_state.shape != (k, k):
            raise ConfigError(f"turn_state must have shape {(k, k)}, got {self.turn_state.shape}",
                              field="turn_state")

    @property
    def deterministic(self) -> bool:
        """Whether the policy table is deterministic (passivity aside)."""
        return self._deterministic

    @property
    def route_table(self) -> np.ndarray:
        """(K, K, S) int, the likeliest action ``table[start, goal, s]`` (read-only)."""
        table = self._greedy.view()
        table.setflags(write=False)
        return table

    def preferred_action(
        self, state: np.ndarray, start: np.ndarray, goal: np.ndarray
    ) -> np.ndarray:
        """The most likely action of the policy table, ignoring passivity (arrays broadcast)."""
        return self._greedy[start, goal, state]

    def act(
        self,
        rng: np.random.Generator,
        state: np.ndarray,
        start: np.ndarray,
        goal: np.ndarray,
    ) -> np.ndarray:
        """Sample the human's actions for a batch of episodes (int arrays of equal shape)."""
        state = np.asarray(state)
        u = rng.random((2, *state.shape))
        return self.act_from_uniforms(state, start, goal, u[0], u[1])

    def act_from_uniforms(
        self,
        state: np.ndarray,
        start: np.ndarray,
        goal: np.ndarray,
        u_passive: np.ndarray,
        u_choice: np.ndarray,
    ) -> np.ndarray:
        """The human's actions given uniform draws in [0, 1) per episode.

        ``u_passive < passive`` makes the human wait; ``u_choice`` samples the policy
        (inverse CDF). Supplying the draws lets callers keep one random stream per run.
        """
        state, start, goal = np.broadcast_arrays(state, start, goal)
        if self.deterministic:
            actions = self._greedy[start, goal, state].copy()
        else:
            cum = self._cumulative[start, goal, state]
            actions = np.minimum((u_choice[..., None] >= cum).sum(axis=-1),
                                 self.graph.n_actions - 1)
        if self.passive > 0.0:
            actions = np.where(u_passive < self.passive, WAIT, actions)
        return actions


def support_actions(graph: TaskGraph, table: np.ndarray) -> None:
    """Fill the human's grasp behaviour at supports into ``table[start, goal, s]``."""
    for s in np.flatnonzero(graph.is_support_state):
        k, mu = int(graph.support[s]), int(graph.grasp[s])
        holds = bool(mu & HUMAN_BIT)
        for goal in range(graph.n_intentions):
            if k == goal:  # arrived (the start only counts once lifted: see the envs)
                table[:, goal, s] = TOGGLE if holds else WAIT
            elif not holds:
                table[:, goal, s] = TOGGLE
            else:
                table[:, goal, s] = TAKE_OFF if mu == BOTH else WAIT


def preference_human(
    graph: TaskGraph,
    preference: str | None = None,
    *,
    passive: float = 0.0,
    turn_back: float = 0.0,
) -> ScriptedHuman:
    """A deterministic human following a named preference.

    Args:
        graph: The task graph.
        preference: One of :func:`preferences_for` (default: the hanger study's most frequent
            preference, or the wheel's "straight").
        passive: Probability of waiting in a step (0.2 in paper Fig. 10c).
        turn_back: Probability per episode of turning back halfway to the start support.
    """
    allowed = spec_of(graph).preferences
    if preference is None:
        preference = spec_of(graph).default_preference
    if not isinstance(preference, str) or preference not in allowed:
        raise ConfigError(
            f"unknown {graph.name} preference {preference!r}; allowed: {', '.join(allowed)}",
            field="preference",
        )
    route_of = spec_of(graph).route
    n_k, n_s = graph.n_intentions, graph.n_states
    table = np.zeros((n_k, n_k, n_s), dtype=np.int64)
    support_actions(graph, table)
    turn_state = np.full((n_k, n_k), -1, dtype=np.int64)
    free = np.flatnonzero(~graph.is_support_state)
    for start, goal in itertools.product(range(n_k), repeat=2):
        ops = route_of(graph.scenario, preference, start, goal)
        route = _plan(graph, int(graph.mounting_state[start]), ops)
        on_route = {int(graph.mounting_state[start]): route[0][0]} if route else {}
        for (_, s_prev), (a, _) in zip(route, route[1:], strict=False):
            on_route[s_prev] = a
        if start != goal and len(route) >= 2:
            turn_state[start, goal] = route[(len(route) - 1) // 2][1]
        for s in free:
            if int(s) in on_route:
                table[start, goal, s] = on_route[int(s)]
            else:
                plan = _plan(graph, int(s), ops)
                table[start, goal, s] = plan[0][0] if plan else PUT_ON
            if s == graph.mounting_state[goal]:
                table[start, goal, s] = PUT_ON
    policy = np.zeros((n_k, n_k, n_s, graph.n_actions))
    np.put_along_axis(policy, table[..., None], 1.0, axis=-1)
    return ScriptedHuman(graph, policy, preference, turn_state, passive, turn_back)


def boltzmann_human(
    graph: TaskGraph,
    theta: np.ndarray,
    *,
    temperature: float = 25.0,
    gamma: float = 0.9,
    passive: float = 0.0,
) -> ScriptedHuman:
    """A Boltzmann-rational human: ``π_H ∝ exp(τ Q_H)`` for the reward ``θᵀφ(s, ι)``.

    Q_H comes from Q-iteration with the robot following the passive baseline (grasp at the
    start, let go elsewhere), so the human's model of the robot is the nominal one.

    Args:
        graph: The task graph.
        theta: (F,) feature weights.
        temperature: τ of the soft-max; larger is more deterministic.
        gamma: Discount of the human's Q-iteration.
        passive: Probability of waiting in a step.

    It has no preferred route, hence no halfway point, and does not turn back by itself.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (graph.n_features,):
        raise ConfigError(f"theta must have shape ({graph.n_features},), got {theta.shape}",
                          field="theta")
    if temperature <= 0:
        raise ConfigError(f"temperature must be > 0, got {temperature}", field="temperature")
    n_k = graph.n_intentions
    policy = np.zeros((n_k, n_k, graph.n_states, graph.n_actions))
    reward = graph.features @ theta  # (K, S)
    for start in range(n_k):
        robot = mdp.passive_policy(graph, start)  # (S, A)
        t_h = mdp.human_transition(graph.next_state, robot[None].repeat(n_k, 0))  # (K, S, A, S)
        q = mdp.q_iteration(t_h, reward, graph.valid, graph.terminal, gamma)
        policy[start] = mdp.softmax(q, graph.valid, temperature)
    # A Boltzmann human has no route, so no halfway point: it never turns back by itself.
    no_turn = np.full((n_k, n_k), -1, dtype=np.int64)
    return ScriptedHuman(graph, policy, "boltzmann", no_turn, passive)
