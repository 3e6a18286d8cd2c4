"""What the physical baselines make of an observation: the object's state, an estimate of
the human's wrench, and the action that moves the object with a given twist.

Every robot of :mod:`baselines.physical` reads the continuous envs' observation through
the episode's :class:`~hri_envs.physics.carry.robot_view.RobotTask` only (never the env):

* :func:`object_state`: the object's pose and velocity and the robot's grip pose;
* :class:`HumanWrench`: the wrist sensor's estimate of the external wrench on the object,
  minus the wrench of the support seat that holds the object (the seats' force law and
  places are public facts of the task: ``task.design`` and ``task.geometry``), low-pass
  filtered. Inside a seat the wrist feels the seat's spring as much as the human; a robot
  that followed it would pull the object out of the seat it was just put on;
* :func:`deadband`: a radial deadband (the magnitude shrinks by the band, the direction
  stays);
* :func:`twist_action`: the env's (7,) action that moves the object's origin with linear
  velocity ``v`` [m/s] and angular velocity ``omega`` [rad/s] for one step: the grip moves
  by ``(v + ω × r) dt`` (``r`` from the object's origin to the grip) and turns by
  ``ω dt``; a twist beyond the action's range is scaled down as a whole, so its direction
  is kept.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hri_envs.physics.carry.robot_view import RobotTask
from hri_envs.physics.scene.kinematics import Pose, quat_to_mat
from hri_envs.physics.scene.seats import Seats

__all__ = ["HumanWrench", "ObjectState", "clamp", "deadband", "lowpass_alpha", "object_state",
           "twist_action", "unit"]


class ObjectState(NamedTuple):
    """The object's state in one observation (world frame).

    Attributes:
        pose: The object's pose (origin: the point that rests on a support).
        vel: (3,) its linear velocity [m/s].
        angvel: (3,) its angular velocity [rad/s].
        grip: The robot's grip pose.
        handle: (3,) the human's handle (``task.design.handle_pos`` on the object) [m].
    """

    pose: Pose
    vel: np.ndarray
    angvel: np.ndarray
    grip: Pose
    handle: np.ndarray


def _unit_quat(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q)


def object_state(task: RobotTask, observation: np.ndarray) -> ObjectState:
    """The object's pose and velocity and the robot's grip pose in ``observation``."""
    part = task.part
    pose = Pose(part(observation, "object_pos").astype(float),
                _unit_quat(part(observation, "object_quat")))
    return ObjectState(
        pose, part(observation, "object_vel").astype(float),
        part(observation, "object_angvel").astype(float),
        Pose(part(observation, "grip_pos").astype(float),
             _unit_quat(part(observation, "grip_quat"))),
        pose.pos + quat_to_mat(pose.quat) @ task.design.handle_pos)


def deadband(x: np.ndarray, width: float) -> np.ndarray:
    """``x`` with its magnitude reduced by ``width`` (0 within the band), same direction."""
    norm = float(np.linalg.norm(x))
    if norm <= width or norm < 1e-12:
        return np.zeros_like(x)
    return x * ((norm - width) / norm)


class HumanWrench:
    """The robot's estimate of the human's wrench on the object, per step.

    The wrist sensor's estimate of the external wrench (force [N], torque [N m] about the
    object's origin) minus the seat's wrench when a seat holds the object (the seats'
    public force law, :class:`~hri_envs.physics.scene.seats.Seats`), with the torque moved to the
    human's handle (``τ_h = τ - r × F``, ``r`` from the origin to the handle: what the
    hand itself twists), through a first-order low-pass filter of time constant
    ``filter_s``.

    Args:
        task: The episode's public facts.
        filter_s: The low-pass filter's time constant [s] (0: unfiltered).
        seat_compensation: Subtract the engaged seat's wrench (else the raw estimate).

    Attributes:
        raw: (6,) the last unfiltered estimate; filtered: (6,) the filtered one.
        seat: The support whose seat holds the object, -1 if none.
        left_start: The object has left its start seat.
    """

    def __init__(self, task: RobotTask, filter_s: float, seat_compensation: bool = True
                 ) -> None:
        self.task = task
        self.seats = Seats(task.geometry, task.design) if seat_compensation else None
        self.alpha = lowpass_alpha(task.dt, filter_s)
        self.raw = np.zeros(6)
        self.filtered = np.zeros(6)
        self.seat = -1
        self.left_start = False
        self._started = False

    @property
    def settling(self) -> bool:
        """A seat holds the object after it left its start: it was put on (the seat pulls
        it home; a robot that still followed the wrist would ring against the seat's
        stiff spring, whose forces the uncompensated inertia makes it misread).
        """
        return self.seat >= 0 and self.left_start

    def update(self, observation: np.ndarray, state: ObjectState) -> np.ndarray:
        """The filtered (6,) human wrench after this observation."""
        w = self.task.part(observation, "wrench").astype(float)
        self.seat = -1
        if self.seats is not None:
            self.seat = self.seats.engaged(state.pose.pos, state.pose.quat)
            if self.seat >= 0:
                f, t = self.seats.wrench(self.seat, state.pose.pos, state.pose.quat,
                                         state.vel, state.angvel)
                # The seat's force acts at the object's centre of mass: its torque about
                # the origin has that lever's moment besides the seat's own torque.
                com = quat_to_mat(state.pose.quat) @ self.task.design.object_com
                w = w - np.concatenate([f, t + np.cross(com, f)])
        if self.seat < 0:
            self.left_start = True
        w[3:] -= np.cross(state.handle - state.pose.pos, w[:3])
        self.raw = w
        if not self._started:
            self.filtered, self._started = w.copy(), True
        else:
            self.filtered += self.alpha * (w - self.filtered)
        return self.filtered


def twist_action(task: RobotTask, state: ObjectState, v: np.ndarray, omega: np.ndarray,
                 stiffness: float = 1.0, centre: np.ndarray | None = None) -> np.ndarray:
    """The (7,) action that moves the object with twist (``v`` [m/s] of the point
    ``centre``, ``omega`` [rad/s]) over one step, with the impedance's stiffness scale
    ``stiffness`` (0-1).

    The grip target is offset by ``(v + ω × r) dt`` with ``r`` the grip's position
    relative to ``centre`` (default: the object's origin), and turned by ``ω dt``; when
    either part exceeds the action's range (``task.max_step_m``, ``task.max_step_rad``) the
    whole twist is scaled down by the same factor.
    """
    r = state.grip.pos - (state.pose.pos if centre is None else centre)
    dp = (np.asarray(v, float) + np.cross(omega, r)) * task.dt / task.max_step_m
    dr = np.asarray(omega, float) * task.dt / task.max_step_rad
    peak = max(float(np.max(np.abs(dp))), float(np.max(np.abs(dr))), 1.0)
    s = 2.0 * min(max(stiffness, 0.0), 1.0) - 1.0
    out = np.concatenate([dp / peak, dr / peak, [s]])
    if not np.all(np.isfinite(out)):
        out = np.array([0, 0, 0, 0, 0, 0, s], dtype=float)
    return out.astype(np.float32)


def unit(x: np.ndarray) -> np.ndarray:
    """``x`` / |x| (zeros for a zero vector)."""
    n = float(np.linalg.norm(x))
    return x / n if n > 1e-12 else np.zeros_like(x)


def clamp(x: float, lo: float, hi: float) -> float:
    """``x`` within [lo, hi]."""
    return lo if x < lo else hi if x > hi else x


def lowpass_alpha(dt: float, time_s: float) -> float:
    """The weight of a new sample in a first-order low-pass filter of time constant
    ``time_s`` [s] sampled every ``dt`` [s] (1 for ``time_s`` <= 0).
    """
    return 1.0 if time_s <= 0 else dt / (time_s + dt)

