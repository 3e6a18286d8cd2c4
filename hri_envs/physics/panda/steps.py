"""The abstract side of the discrete Panda backend's step: its plan, its result, its faults.

:func:`plan_step` says which toggles and motions of a joint action run (the same on every
physics backend); :class:`StepResult` is what :meth:`~hri_envs.physics.panda.sim.PandaSim.step`
returns. Faults end the step with ``fault`` set (``"<kind>: <detail>"``) instead of raising
(:class:`StepFault` carries one out of the physics loop). Physical failures
(:data:`PHYSICAL_FAULTS`): ``dropped`` (the object touched the floor, fell below every state,
or nobody and no support holds it), ``grasp_failed`` (the closed fingers do not both press on
the object's grip geometry), ``pulled_out`` (the external force on the held object exceeded
the grip's hold), ``off_support`` (the object ended far from every abstract state, or off every
support held by one agent alone). Faults of the simulation itself: ``unstable`` and
``ik_failure``. :class:`StepTotals` is what the physics loop sums over a step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from hri_envs.task.graph import TOGGLE, WAIT, TaskGraph

__all__ = ["PHYSICAL_FAULTS", "StepFault", "StepPlan", "StepResult", "StepTotals", "plan_step"]

#: Faults that are physical failures of the task (punished with r⁻ by the episode rules).
PHYSICAL_FAULTS = ("dropped", "grasp_failed", "pulled_out", "off_support")


class StepPlan(NamedTuple):
    """The abstract side of a physical step (:func:`plan_step`)."""

    human_toggle: bool  # the human grasps or lets go
    s1: int  # the state after the toggles, where the motions start
    robot_moves: bool  # the robot's motion runs
    human_moves: bool  # the human's motion runs


def plan_step(g: TaskGraph, s: int, a_r: int, a_h: int, attempt: bool) -> StepPlan:
    """Which toggles and motions of joint action (``a_r``, ``a_h``) in state ``s`` run, the
    same on every physics backend.

    The human toggles only where toggling is valid; the motions start from the state after
    the toggles. With ``attempt`` (``attempt_invalid``) the robot tries any motion and the
    human refuses an invalid one; otherwise an invalid motion of either aborts both.
    """
    toggle_ok = bool(g.valid[s, TOGGLE])
    human_toggle = a_h == TOGGLE and toggle_ok
    s1 = int(g.next_state[s, a_r if a_r == TOGGLE and toggle_ok else WAIT,
                          a_h if human_toggle else WAIT])
    if attempt:
        return StepPlan(human_toggle, s1, a_r > TOGGLE, a_h > TOGGLE and bool(g.valid[s1, a_h]))
    aborted = not (g.valid[s1, a_r] and g.valid[s1, a_h])
    return StepPlan(human_toggle, s1, a_r > TOGGLE and not aborted,
                    a_h > TOGGLE and not aborted)


class StepResult(NamedTuple):
    """The outcome of one physical abstract step.

    Attributes:
        state: The observed (closest) abstract state.
        human_action: The human's action as the robot infers it.
        graph_next: The state the graph predicts for the true joint action.
        graph_agrees: ``state == graph_next``.
        settled: The object came to rest at a state (else the time limit ended the step).
        duration: Simulated seconds.
        linear_impulse: ∫ |F| dt [N s] of the human's wrench as the wrist sensor sees it.
        angular_impulse: ∫ |τ| dt [N m s], likewise.
        robot_yielded: The robot gave up its action because the human disagreed.
        position_error, angle_error: Distance of the object from the observed state's pose.
        fault: None, or ``"<kind>: <detail>"`` (kinds: :data:`PHYSICAL_FAULTS`,
            "unstable", "ik_failure").
        linear_impulse_true, angular_impulse_true: The same from the human's true wrench.
        human_holds: The human holds the object as the step ends (their grasp bit).
        human_holds_sensed: What the robot reads off the handle's touch sensor (it observes
            this; :class:`~hri_envs.physics.panda.human_arm.HandleSensor`).
    """

    state: int
    human_action: int
    graph_next: int
    graph_agrees: bool
    settled: bool
    duration: float
    linear_impulse: float
    angular_impulse: float
    robot_yielded: bool
    position_error: float
    angle_error: float
    fault: str | None
    linear_impulse_true: float = 0.0
    angular_impulse_true: float = 0.0
    human_holds: bool = False
    human_holds_sensed: bool = False

    @property
    def fault_kind(self) -> str | None:
        """The fault's kind (``"dropped"``, ...) without the detail, or None."""
        return None if self.fault is None else self.fault.split(":", 1)[0]


class StepFault(Exception):
    """A fault that ends the step: its message is ``"<kind>: <detail>"``."""


@dataclass(slots=True)
class StepTotals:
    """What the physics loop accumulates over one abstract step (the human's wrench)."""

    linear_impulse: float = 0.0  # ∫ |F_sensed| dt [N s]
    angular_impulse: float = 0.0  # ∫ |τ_sensed| dt [N m s]
    human_work: float = 0.0  # ∫ (F_sensed · v + τ_sensed · ω) dt [J]
    linear_impulse_true: float = 0.0  # ∫ |F_human| dt [N s]
    angular_impulse_true: float = 0.0  # ∫ |τ_human| dt [N m s]

    def add(self, sensed: np.ndarray, human: np.ndarray, vel: np.ndarray,
            angvel: np.ndarray, dt: float) -> None:
        """One control period ``dt`` [s] of the ``sensed`` and the ``human``'s true wrench on
        the object moving at ``vel``, ``angvel``.
        """
        f_s, t_s, f_h, t_h = sensed[:3], sensed[3:], human[:3], human[3:]
        # ndarray.dot: the same BLAS routine as @ at half the call's cost.
        self.linear_impulse += math.sqrt(f_s.dot(f_s)) * dt
        self.angular_impulse += math.sqrt(t_s.dot(t_s)) * dt
        self.human_work += (f_s.dot(vel) + t_s.dot(angvel)) * dt
        self.linear_impulse_true += math.sqrt(f_h.dot(f_h)) * dt
        self.angular_impulse_true += math.sqrt(t_h.dot(t_h)) * dt
