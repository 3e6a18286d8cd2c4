"""The abstract transition graph of a cooperative carrying task, precomputed as numpy arrays.

States (paper Sect. 4.1) are ``s = (position, orientation, grasp μ)`` with μ a 2-bit code:
bit 0 = the human holds, bit 1 = the robot holds. They are numbered

* support states first: ``support_state(k, μ) = 4 k + μ`` for support ``k`` and μ in 0..3;
* then free-space waypoints (always μ = 3): column ``c`` (a support's mounting (x, y)),
  height index ``h``, orientation ``o``, at ``4 K + (c H + h) O + o``.

Actions (paper Table 1) share one global numbering for both agents::

    0 wait | 1 grasp/let go | 2 take off | 3 put on | 4 rotate
    5 .. 5+K-1     move over to column k
    5+K .. 5+K+H-1 move (up or down) to height h

The joint transition is deterministic (docs/task-model.md, "Transition"): grasp toggles
first, then the step is *aborted* if either action is invalid in the resulting state, else
the object moves by the human's motion or, when the human makes none, by the robot's.

Every array is built once per scenario; the envs, the scripted humans and the learners all
read the same :class:`TaskGraph`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from hri_envs.task.actions import (
    BOTH,
    GRASP_NAMES,
    HUMAN_BIT,
    N_FIXED_ACTIONS,
    PUT_ON,
    ROBOT_BIT,
    ROTATE,
    TAKE_OFF,
    TOGGLE,
    WAIT,
)
from hri_envs.task.episode import robot_correct, step_reward
from hri_envs.task.features import state_features
from hri_envs.task.geometry import Scenario

if TYPE_CHECKING:
    from hri_envs.task.scenarios.spec import ScenarioSpec

__all__ = [
    "BOTH",
    "GRASP_NAMES",
    "HUMAN_BIT",
    "N_FIXED_ACTIONS",
    "PUT_ON",
    "ROBOT_BIT",
    "ROTATE",
    "TAKE_OFF",
    "TOGGLE",
    "WAIT",
    "TaskGraph",
    "build_graph",
]



@dataclass(frozen=True, eq=False)
class TaskGraph:
    """Tabular model of one scenario. All arrays are read-only.

    Shapes use S states, A actions, K supports (= intentions), H heights, O orientations,
    F features.

    Attributes:
        scenario: The geometry this graph was built from.
        grasp: (S,) int, μ of each state.
        support: (S,) int, the support a state rests on, -1 in free space.
        column, height, orientation: (S,) int waypoint indices (support states: those of the
            support's resting pose; ``height`` is -1 there).
        position: (S, 3) nominal object position [m] (features use these).
        quaternion: (S, 4) object orientation.
        valid: (S, A) bool, the actions either agent may take in a state.
        next_state: (S, A, A) int, ``next_state[s, a_R, a_H]``.
        aborted: (S, A, A) bool, the joint action was aborted (no motion).
        terminal: (K,) int, the state "resting on support k, μ = 0".
        mounting_state: (K,) int, the waypoint from which support k is mounted.
        features: (K, S, F) float, φ(s, ι) for each intention ι.
        state_names, action_names: readable labels.
        spec: The registered scenario this graph was built for
            (:class:`~hri_envs.task.scenarios.ScenarioSpec`: its r0, γ, episodes,
            preferences, ids), so that whoever holds the graph holds the scenario; None for a
            graph built from a bare geometry.

    The rules of an episode on these transitions (:attr:`robot_effective`, :meth:`reward`)
    are evaluated from :mod:`hri_envs.task.episode`, where they are written once.
    """

    scenario: Scenario
    grasp: np.ndarray
    support: np.ndarray
    column: np.ndarray
    height: np.ndarray
    orientation: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    valid: np.ndarray
    next_state: np.ndarray
    aborted: np.ndarray
    terminal: np.ndarray
    mounting_state: np.ndarray
    features: np.ndarray
    state_names: tuple[str, ...]
    action_names: tuple[str, ...]
    spec: ScenarioSpec | None = None

    # ------------------------------------------------------------------ sizes
    @property
    def n_states(self) -> int:
        """Number of abstract states S."""
        return int(self.grasp.shape[0])

    @property
    def n_actions(self) -> int:
        """Size A of the global action set."""
        return int(self.valid.shape[1])

    @property
    def n_intentions(self) -> int:
        """Number of supports K, each a possible intention."""
        return self.scenario.n_supports

    @property
    def n_features(self) -> int:
        """Length F of the preference feature vector φ(s, ι)."""
        return int(self.features.shape[2])

    @property
    def support_names(self) -> tuple[str, ...]:
        """Support (= intention) labels."""
        return self.scenario.support_names

    @property
    def name(self) -> str:
        """Scenario name."""
        return self.scenario.name

    # ------------------------------------------------------------------ helpers
    def support_state(self, k: Any, grasp: Any = 0) -> Any:
        """Index of the state "resting on support ``k`` with grasp code ``grasp``" (ints, or
        int arrays that broadcast).
        """
        return 4 * k + grasp

    def move_over(self, k: int) -> int:
        """Action index of "move over to column k"."""
        return N_FIXED_ACTIONS + k

    def move_to_height(self, h: int) -> int:
        """Action index of "move to height index h"."""
        return N_FIXED_ACTIONS + self.n_intentions + h

    def waypoint_state(self, column: int, height: int, orientation: int) -> int:
        """Index of the free-space state at the given waypoint indices."""
        n_h, n_o = len(self.scenario.heights), len(self.scenario.orientations)
        return 4 * self.n_intentions + (column * n_h + height) * n_o + orientation

    def reward(self, r0: float) -> np.ndarray:
        """Robot cooperation reward R_R(s, a_R, a_H) in {-1, r0, 0}, shape (S, A, A).

        :func:`~hri_envs.task.episode.step_reward` of the graph's own transitions.
        """
        s, a_r, a_h = self._joint
        return step_reward(self, s, a_r, a_h, self.next_state, r0)

    @cached_property
    def _joint(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s, a_R, a_H) index grids that broadcast to (S, A, A)."""
        n_s, n_a = self.n_states, self.n_actions
        return (np.arange(n_s)[:, None, None], np.arange(n_a)[None, :, None],
                np.arange(n_a)[None, None, :])

    @cached_property
    def robot_effective(self) -> np.ndarray:
        """(S, A, A) bool, a *correct* decision (paper Sect. 6.3) on the graph's transitions.

        See :func:`~hri_envs.task.episode.robot_correct`; acting otherwise is *wrong*.
        """
        s, a_r, a_h = self._joint
        return _frozen(robot_correct(self, s, a_r, a_h, self.next_state))

    def action_label(self, state: int, action: int) -> str:
        """Readable name of ``action`` as taken in ``state`` ("grasp" vs "let go", up vs down)."""
        name = self.action_names[action]
        if action == TOGGLE:
            return "grasp/let go"
        h = action - N_FIXED_ACTIONS - self.n_intentions
        if 0 <= h and self.height[state] >= 0:
            return ("move up" if h > self.height[state] else "move down") + name[len("move") :]
        return name

    def agent_action_label(self, state: int, action: int, robot: bool) -> str:
        """Like :meth:`action_label`, resolving the grasp toggle for one agent."""
        if action == TOGGLE:
            bit = ROBOT_BIT if robot else HUMAN_BIT
            return "let go" if self.grasp[state] & bit else "grasp"
        return self.action_label(state, action)

    @cached_property
    def is_support_state(self) -> np.ndarray:
        """(S,) bool, the object rests on a support."""
        return self.support >= 0

    def step(self, s: int, a_r: int, a_h: int) -> tuple[int, bool]:
        """The joint transition for one step: ``(next state, aborted)``."""
        return int(self.next_state[s, a_r, a_h]), bool(self.aborted[s, a_r, a_h])


def _freeze(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


def _frozen(a: np.ndarray) -> np.ndarray:
    out = np.ascontiguousarray(a)
    out.setflags(write=False)
    return out


def build_graph(scenario: Scenario, spec: ScenarioSpec | None = None) -> TaskGraph:
    """Build the :class:`TaskGraph` of a scenario (states, actions, transitions, features);
    ``spec``: the registered scenario it is for (:attr:`TaskGraph.spec`).
    """
    sc = scenario
    st = _states(sc)
    valid, motion_target = _single_agent_moves(sc, st)
    next_state, aborted = _joint_transition(st, valid, motion_target)
    quaternion = np.ascontiguousarray(sc.orientations[st.orientation])
    terminal = np.array([4 * k for k in range(sc.n_supports)])
    features = state_features(sc, st.position, quaternion, st.grasp)
    arrays = (st.grasp, st.support, st.column, st.height, st.orientation, st.position,
              quaternion, valid, next_state, aborted, terminal, st.mounting_state, features)
    _freeze(*arrays)
    return TaskGraph(sc, *arrays, state_names=tuple(st.names),
                     action_names=tuple(_action_names(sc)), spec=spec)


class _States(NamedTuple):
    """The states of a scenario's graph, as :func:`build_graph` numbers them.

    Attributes:
        grasp, support, column, height, orientation, position, mounting_state: As the
            attributes of :class:`TaskGraph`.
        names: Each state's readable label.
    """

    grasp: np.ndarray
    support: np.ndarray
    column: np.ndarray
    height: np.ndarray
    orientation: np.ndarray
    position: np.ndarray
    mounting_state: np.ndarray
    names: list[str]


def _free_state(sc: Scenario, c: Any, h: Any, o: Any) -> Any:
    """Index of the free-space waypoint at column ``c``, height ``h``, orientation ``o``."""
    return 4 * sc.n_supports + (c * len(sc.heights) + h) * len(sc.orientations) + o


def _states(sc: Scenario) -> _States:
    """The support states ``4 k + μ`` first, then the free-space waypoints."""
    n_k, n_h, n_o = sc.n_supports, len(sc.heights), len(sc.orientations)
    n_s = 4 * n_k + n_k * n_h * n_o
    grasp = np.full(n_s, BOTH, dtype=np.int64)
    support = np.full(n_s, -1, dtype=np.int64)
    column = np.zeros(n_s, dtype=np.int64)
    height = np.full(n_s, -1, dtype=np.int64)
    orientation = np.zeros(n_s, dtype=np.int64)
    position = np.zeros((n_s, 3))
    names: list[str] = []
    mount_h = np.array([sc.height_index(s.mounting[2]) for s in sc.supports])
    for k, sup in enumerate(sc.supports):
        for mu in range(4):
            s = 4 * k + mu
            grasp[s], support[s], column[s] = mu, k, k
            orientation[s], position[s] = sup.orientation, sup.position
            names.append(f"on {sup.name}, {GRASP_NAMES[mu]}")
    for c in range(n_k):
        for h in range(n_h):
            for o in range(n_o):
                s = _free_state(sc, c, h, o)
                column[s], height[s], orientation[s] = c, h, o
                position[s] = [*sc.supports[c].mounting[:2], sc.heights[h]]
                prime = "′" if h == mount_h[c] else ""
                names.append(
                    f"held at {sc.supports[c].name}{prime} column, {sc.heights[h]:.3g} m, "
                    f"{sc.orientation_names[o]}"
                )
    mounting_state = np.array([_free_state(sc, k, mount_h[k], sc.supports[k].orientation)
                               for k in range(n_k)])
    return _States(grasp, support, column, height, orientation, position, mounting_state,
                   names)


def _single_agent_moves(sc: Scenario, st: _States) -> tuple[np.ndarray, np.ndarray]:
    """Single-agent validity and the effect of each motion action (paper Table 1).

    Returns:
        ``(valid, motion_target)``: (S, A) bool, and (S, A) int the state a valid motion
        action leads to (-1 for the other actions).
    """
    n_k, n_h, n_o = sc.n_supports, len(sc.heights), len(sc.orientations)
    n_s, n_a = len(st.grasp), N_FIXED_ACTIONS + n_k + n_h
    valid = np.zeros((n_s, n_a), dtype=bool)
    motion_target = np.full((n_s, n_a), -1, dtype=np.int64)
    valid[:, WAIT] = True
    for s in range(n_s):
        if st.support[s] >= 0:
            valid[s, TOGGLE] = True
            if st.grasp[s] == BOTH:
                valid[s, TAKE_OFF] = True
                motion_target[s, TAKE_OFF] = st.mounting_state[st.support[s]]
            continue
        c, h, o = st.column[s], st.height[s], st.orientation[s]
        if s == st.mounting_state[c]:
            valid[s, PUT_ON] = True
            motion_target[s, PUT_ON] = 4 * c + BOTH
        if n_o > 1:
            valid[s, ROTATE] = True
            motion_target[s, ROTATE] = _free_state(sc, c, h, (o + 1) % n_o)
        for k in range(n_k):
            if k != c:
                a = N_FIXED_ACTIONS + k
                valid[s, a], motion_target[s, a] = True, _free_state(sc, k, h, o)
        for hh in range(n_h):
            if hh != h:
                a = N_FIXED_ACTIONS + n_k + hh
                valid[s, a], motion_target[s, a] = True, _free_state(sc, c, hh, o)
    return valid, motion_target


def _joint_transition(st: _States, valid: np.ndarray, motion_target: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The joint transition, vectorised over (s, a_R, a_H): ``(next_state, aborted)``.

    Grasp toggles first; the step is aborted if either action is invalid in the resulting
    state; else the object moves by the human's motion or, when the human makes none, by
    the robot's.
    """
    n_s, n_a = valid.shape
    s_idx = np.arange(n_s)[:, None, None]
    a_r = np.arange(n_a)[None, :, None]
    a_h = np.arange(n_a)[None, None, :]
    toggle_r = (a_r == TOGGLE) & valid[s_idx, TOGGLE]
    toggle_h = (a_h == TOGGLE) & valid[s_idx, TOGGLE]
    new_grasp = st.grasp[s_idx] ^ (ROBOT_BIT * toggle_r) ^ (HUMAN_BIT * toggle_h)
    # After the toggles only support states change their μ: 4k + μ'.
    s1 = np.where(st.support[s_idx] >= 0, 4 * st.support[s_idx] + new_grasp, s_idx)
    s1 = np.broadcast_to(s1, (n_s, n_a, n_a))
    aborted = ~(valid[s1, np.broadcast_to(a_r, s1.shape)]
                & valid[s1, np.broadcast_to(a_h, s1.shape)])
    is_motion_h = a_h >= TAKE_OFF
    is_motion_r = a_r >= TAKE_OFF
    mover = np.where(is_motion_h, a_h, np.where(is_motion_r, a_r, -1))
    mover = np.broadcast_to(mover, s1.shape)
    moved = motion_target[s1, np.maximum(mover, 0)]
    next_state = np.where(aborted | (mover < 0), s1, moved)
    return np.ascontiguousarray(next_state), np.ascontiguousarray(aborted)


def _action_names(sc: Scenario) -> list[str]:
    """The actions' labels in their global numbering (see the module docstring)."""
    names = ["wait", "grasp/let go", "take off", "put on", "rotate"]
    names += [f"move over to {s.name}" for s in sc.supports]
    names += [f"move to {h:.3g} m" for h in sc.heights]
    return names
