"""What the continuous envs' simulation takes and reports per step, and the helpers the
C backend and MuJoCo Warp share: :class:`RobotCommand`, :class:`CarryStep`,
:func:`grip_reference` (:mod:`~hri_envs.physics.carry.sim` re-exports them).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hri_envs.physics.carry.human.intention import IntentionHuman
from hri_envs.physics.scene.kinematics import Pose, compose, quat_mul

__all__ = ["CarryStep", "RobotCommand", "grip_reference", "rotate"]


class RobotCommand(NamedTuple):
    """The robot's command for one step: the grip target and the stiffness scale (0-1)."""

    target: Pose
    stiffness: float


class CarryStep(NamedTuple):
    """What one 40 ms step did.

    Attributes:
        progress: The object's progress along the human's route (0 start, 1 goal).
        effort: ∫ (|F| + |τ| / lever) dt [N s] of the wrench the human's hand puts on the
            handle (torque about the handle).
        linear_impulse, angular_impulse: ∫ |F| dt [N s] and ∫ |τ| dt [N m s] of it.
        disagreement: ∫ max(0, -(F·v + τ·ω)) dt [J]: the work the human does against
            the object's motion.
        sensed: (6,) the robot's last wrist reading of the external wrench [N, N m].
        placed: The support the object rests on after leaving its start (-1: none yet).
        fault: None, or ``"<kind>: <detail>"`` (kinds ``dropped``, ``slipped``,
            ``too_weak``, ``ik_failure``).
        saturated: The arm's joints whose torque was at the human's strength limit for
            most of the step (names).
        peak_force: The largest force [N] of the hand on the handle at a control
            period's end (:class:`~hri_envs.physics.carry.interaction.InteractionMeter`).
        force_sq: ∫ |F|² dt [N² s] of it.
        jerk_sq: ∫ |jerk|² dt [m² s⁻⁵] of the object's origin.
    """

    progress: float
    effort: float
    linear_impulse: float
    angular_impulse: float
    disagreement: float
    sensed: np.ndarray
    placed: int
    fault: str | None
    saturated: tuple[str, ...]
    peak_force: float = 0.0
    force_sq: float = 0.0
    jerk_sq: float = 0.0

    @property
    def fault_kind(self) -> str | None:
        """The fault's kind without its detail, or None."""
        return None if self.fault is None else self.fault.split(":", 1)[0]


def grip_reference(human: IntentionHuman, grip_in_object: Pose) -> Pose:
    """Where the robot's grip would be with the object at ``human``'s reference now (the
    start of its current line until it starts moving, the route's end once it is done).
    """
    ref = human.lines[human.index].sample(max(human.t, 0.0)) if not human.done \
        else human.lines[-1].sample(math.inf)
    return compose(Pose(ref.pos, ref.quat), *grip_in_object)


def rotate(quat: np.ndarray, rotvec: np.ndarray, copy: bool = False) -> np.ndarray:
    """``quat`` turned by the world-frame rotation vector ``rotvec`` (a new array if
    ``copy``, else ``quat`` itself for no rotation).
    """
    angle = math.sqrt(float(rotvec.dot(rotvec)))  # = np.linalg.norm(rotvec), bit for bit
    if angle < 1e-12:
        return quat_mul(np.array([1.0, 0.0, 0.0, 0.0]), quat) if copy else quat
    s = math.sin(angle / 2)
    return quat_mul(np.array([math.cos(angle / 2), *(s * rotvec / angle)]), quat)
