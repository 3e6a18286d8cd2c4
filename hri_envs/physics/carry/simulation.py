"""What the continuous envs use of a simulation, and the check of a box action.

:class:`CarrySimulation` is the protocol both backends' carry simulations implement (one
world: :class:`~hri_envs.physics.carry.sim.CarrySim` in C, or
:class:`~hri_envs.physics.carry.warp.sim.WarpCarrySim` on MuJoCo Warp);
:func:`check_box_action` checks an agent's continuous action.
"""

from __future__ import annotations

from typing import Any, Protocol

import mujoco
import numpy as np

from hri_envs.errors import ActionError
from hri_envs.physics.carry.human.intention import HumanParams, IntentionHuman
from hri_envs.physics.carry.sim import CarryStep, RobotCommand
from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import Pose
from hri_envs.task.geometry import Scenario

__all__ = ["ACTION_SIZE", "CarrySimulation", "check_box_action"]

#: The robot's action: grip offset (3), rotation (3), stiffness (1), each in [-1, 1].
ACTION_SIZE = 7


class CarrySimulation(Protocol):
    """What the continuous envs use of their simulation: a
    :class:`~hri_envs.physics.carry.sim.CarrySim` (``backend="mujoco"``) or one world on MuJoCo
    Warp (:class:`~hri_envs.physics.carry.warp.sim.WarpCarrySim`, ``backend="mjwarp"``).
    """

    design: PhysicsDesign
    scene: Scene
    dt_step: float
    max_step_m: float
    max_step_rad: float

    @property
    def model(self) -> mujoco.MjModel:
        """The C model (for pictures)."""

    @property
    def data(self) -> mujoco.MjData:
        """A C ``MjData`` holding the current state (for pictures)."""

    @property
    def sensed(self) -> np.ndarray:
        """(6,) the robot's last wrist reading."""

    @property
    def human(self) -> IntentionHuman:
        """The human's intention and reference."""

    def reset(self, start: int, goal: int, rng: np.random.Generator,
              scenario: Scenario | None = None, human: HumanParams | None = None,
              robot_holds: bool = True) -> None:
        """Place an episode's start (:meth:`CarrySim.reset`)."""

    def command(self, action: np.ndarray) -> RobotCommand:
        """The robot's command for an action."""

    def human_command(self, action: np.ndarray) -> RobotCommand:
        """The human agent's command for an action."""

    def step(self, cmd: RobotCommand, human_cmd: RobotCommand | None = None) -> CarryStep:
        """Simulate 40 ms."""

    def object_pose(self) -> Pose:
        """The object's pose."""

    def grip_pose(self) -> Pose:
        """The robot's grip frame."""

    def object_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """The object's linear and angular velocity."""

    def robot_joints(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's joint positions and velocities."""

    def seat_positions(self) -> np.ndarray:
        """(K, 3) the supports' seats."""

    def progress(self) -> float:
        """The object's progress along the human's route."""

    def human_grip_reference(self) -> Pose:
        """The robot's grip pose at the human's reference now."""

    def max_lift_n(self) -> float:
        """The arm's greatest upward force at the hand [N]."""


def check_box_action(agent: str, action: Any, size: int = ACTION_SIZE) -> np.ndarray:
    """``action`` as a float (size,) array in [-1, 1]; an :class:`ActionError` (a
    ``ValueError``) naming the agent, the action and the valid range otherwise (also for
    strings, complex numbers and bools: no action is parsed or cut to its real part).
    """
    try:  # numbers only: a str or complex action is refused, not parsed or cut to its real part
        given = np.asarray(action)
        a = given.astype(np.float64) if given.dtype.kind in "iuf" else None
    except (TypeError, ValueError):
        a = None
    # One comparison for both: NaN and ±inf fail it.
    if a is None or a.shape != (size,) or not (np.abs(a) <= 1.0 + 1e-6).all():
        raise ActionError(f"the {agent}'s action must be {size} finite numbers in [-1, 1] "
                          f"(Box(-1, 1, ({size},))), got {action!r}")
    return np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip, without its dispatch
