"""What the robot of the continuous envs may know: its task, its observation's layout, and
what an episode reveals once it has ended.

A robot that feels the human has its wrist sensor, its own joints and grip, the object's
pose and velocity, and the task's public facts: the scenario's supports (where they stand
this episode), the start support, the task graph of the abstract states, its action's
scale and its controller's design. It never has the human's goal (the hidden intention ι),
the human's route or reference, or the human's parameters. :class:`RobotTask` is exactly
the public part, handed to a robot agent at every episode's start
(:meth:`~hri_envs.physics.carry.env.CarryEnv.robot_task`); :class:`EpisodeOutcome` is what
the episode reveals in hindsight, after its end (the support where the object came to
rest is the intention, as in the paper's protocol).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph

__all__ = ["EpisodeOutcome", "RobotTask", "observation_layout"]


def observation_layout(n_joints: int, n_supports: int) -> dict[str, slice]:
    """The continuous envs' observation, by name: a slice of the flat vector per part.

    ``object_pos`` (3) [m], ``object_quat`` (4, w >= 0), ``object_vel`` (3) [m/s],
    ``object_angvel`` (3) [rad/s], ``grip_pos`` (3), ``grip_quat`` (4), ``joints``
    (n) [rad, m], ``joint_vel`` (n), ``wrench`` (6) [N, N m] (the wrist sensor's estimate of
    the external wrench on the object: force, then torque about the object's origin),
    ``start`` (K, one-hot), ``supports`` (3 K) [m], ``time`` (1: the elapsed fraction of the
    time limit).
    """
    sizes = (("object_pos", 3), ("object_quat", 4), ("object_vel", 3), ("object_angvel", 3),
             ("grip_pos", 3), ("grip_quat", 4), ("joints", n_joints),
             ("joint_vel", n_joints), ("wrench", 6), ("start", n_supports),
             ("supports", 3 * n_supports), ("time", 1))
    out, at = {}, 0
    for name, n in sizes:
        out[name] = slice(at, at + n)
        at += n
    return out


@dataclass(frozen=True)
class RobotTask:
    """The public facts of one episode of a continuous env: what a robot may know.

    Attributes:
        scenario: The scenario's name ("hanger", "wheel").
        graph: The task graph (abstract states, actions, the supports' nominal places).
        geometry: This episode's supports (the wheel's stands move per episode).
        start: The support the object rests on at the start.
        seats: (K, 3) the supports' seats this episode [m].
        layout: The wheel's stand layout, None for the hanger.
        dt: The env's step [s] (25 Hz).
        time_limit_s: The episode's time limit [s].
        max_step_m, max_step_rad: The action's scale: an action of ±1 moves the grip target
            this far per step [m], [rad].
        design: The scenario's physical design (the robot's grip on the object, its
            controller, the nominal human's impedance): public numbers of the task.
        layout_names: The observation's parts (:func:`observation_layout`).
        robot_holds: The robot holds the object at the start.
    """

    scenario: str
    graph: TaskGraph
    geometry: Scenario
    start: int
    seats: np.ndarray
    layout: tuple[tuple[float, float], ...] | None
    dt: float
    time_limit_s: float
    max_step_m: float
    max_step_rad: float
    design: PhysicsDesign
    layout_names: Mapping[str, slice] = field(default_factory=dict)
    robot_holds: bool = True

    @property
    def n_supports(self) -> int:
        """K, the number of supports (and of possible intentions)."""
        return int(self.graph.n_intentions)

    def part(self, observation: np.ndarray, name: str) -> np.ndarray:
        """The part ``name`` of an observation (a view), e.g. ``task.part(obs, "wrench")``.

        Raises:
            KeyError: An unknown part (the message lists the parts).
        """
        try:
            return np.asarray(observation)[..., self.layout_names[name]]
        except KeyError:
            raise KeyError(f"no observation part {name!r}; parts: "
                           f"{', '.join(self.layout_names)}") from None


@dataclass(frozen=True)
class EpisodeOutcome:
    """What an ended episode reveals to the robot (its agent's ``end_episode``).

    Attributes:
        placed: The support the object came to rest on after leaving its start (-1: none).
        intention: The human's goal revealed in hindsight: ``placed`` when the object came to
            rest on a support other than the start, else -1 (nothing revealed).
        fault: None, or the episode's fault kind (``dropped``, ``slipped``, ``too_weak``,
            ``ik_failure``).
        truncated: The episode hit its time limit (or could not start).
        metrics: The episode's figures (``info["episode"]`` of the last step).
    """

    placed: int
    intention: int
    fault: str | None
    truncated: bool
    metrics: Mapping[str, Any] = field(default_factory=dict)
