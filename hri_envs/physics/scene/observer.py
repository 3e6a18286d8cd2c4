"""From physics back to the abstract model: closest state, human action, step reward.

The robot observes the *closest abstract state* (paper Sect. 4.4): the support whose seat
holds the object (with the grasp bits μ), or else the free-space waypoint nearest in
position plus ``lever`` × angle. From the transition it *infers* the human's abstract
action; this inference, not the simulated human's true action, is what the robot's
observation carries.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hri_envs.physics.scene.kinematics import rotation_error
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import HUMAN_BIT, TOGGLE, WAIT, TaskGraph

__all__ = ["Observation", "StateObserver", "infer_human_action"]


class Observation(NamedTuple):
    """The closest abstract state and how far the object is from its pose."""

    state: int
    position_error: float
    angle_error: float


class StateObserver:
    """Maps an object pose to the closest abstract state of a graph.

    Args:
        graph: The task graph (state numbering).
        scenario: The episode's geometry (the wheel's stands move).
        lever: Metres per radian when comparing angles with distances.
    """

    def __init__(self, graph: TaskGraph, scenario: Scenario, lever: float) -> None:
        self.graph = graph
        self.lever = lever
        self.free = np.flatnonzero(~graph.is_support_state)
        self.set_scenario(scenario)

    def set_scenario(self, scenario: Scenario) -> None:
        """Physical poses of every state in ``scenario``."""
        g = self.graph
        self.scenario = scenario
        pos = np.zeros((g.n_states, 3))
        for s in range(g.n_states):
            k = int(g.support[s])
            pos[s] = (scenario.supports[k].position if k >= 0 else
                      scenario.waypoint_position(int(g.column[s]), int(g.height[s])))
        self.pos = pos  # (S, 3)
        self.quat = scenario.orientations[g.orientation]  # (S, 4)

    def pose(self, state: int) -> tuple[np.ndarray, np.ndarray]:
        """Physical position and orientation of an abstract state."""
        return self.pos[state], self.quat[state]

    def observe(self, pos: np.ndarray, quat: np.ndarray, seat: int, grasp: int) -> Observation:
        """Closest state given the object pose, the engaged seat (-1: none) and μ."""
        if seat >= 0:
            s = self.graph.support_state(seat, grasp)
        else:
            dist = np.linalg.norm(self.pos[self.free] - pos, axis=1)
            dots = np.abs(self.quat[self.free] @ quat)
            ang = 2.0 * np.arccos(np.clip(dots, 0.0, 1.0))
            s = int(self.free[np.argmin(dist + self.lever * ang)])
        return Observation(s, float(np.linalg.norm(self.pos[s] - pos)),
                           float(np.linalg.norm(rotation_error(self.quat[s], quat))))


def infer_human_action(graph: TaskGraph, s: int, a_r: int, s_next: int,
                       human_work: float, work_threshold: float) -> int:
    """The human's abstract action inferred from a transition (paper Sect. 4.4).

    * the human's grasp bit changed: grasp/let go;
    * the object did not move: wait;
    * it moved where the robot's action leads: the same action as the robot if the human
      did positive work along the motion (measured with the wrist force sensor:
      ``human_work`` [J]), else wait (the human followed);
    * it moved elsewhere: the motion that leads there (the human overrode the robot);
      wait if no single action explains the move.

    ``work_threshold`` [J] is the least work that counts as the human joining the robot's
    motion (the simulator passes :attr:`PhysicsDesign.human_work_min_j`).
    """
    if (graph.grasp[s] ^ graph.grasp[s_next]) & HUMAN_BIT:
        return TOGGLE
    same_pose = (graph.support[s] == graph.support[s_next]
                 and (graph.support[s] >= 0 or s == s_next))
    if same_pose:
        return WAIT
    if a_r > TOGGLE and graph.next_state[s, a_r, WAIT] == s_next:
        return a_r if human_work > work_threshold else WAIT
    # After the robot's own grasp toggle (if any), which human motion leads to s_next?
    s1 = graph.next_state[s, a_r, WAIT] if a_r == TOGGLE else s
    hits = np.flatnonzero(graph.next_state[s1, WAIT, :] == s_next)
    hits = hits[hits > TOGGLE]
    return int(hits[0]) if len(hits) else WAIT
