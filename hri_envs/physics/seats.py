"""Supports as seats: a unilateral force law in place of hook, peg and plate contacts.

Each support k has a seat pose (the object's resting pose) and an *exit direction*
``d_k``, from the seat towards its mounting point (the way the object is taken off). While
the object is captured (within ``seat_capture_m`` of the seat across ``d_k`` and along
it, within ``seat_capture_angle_rad`` of the seat's orientation) the seat applies a stiff
spring-damper towards its pose, except that along ``d_k`` it can push freely but pull back
by at most the detent force ``seat_hold``. So a seat carries the object's weight and keeps
it in place, and the object leaves it only by being pulled out along the exit direction,
as off a hook, a peg or a plate; it is captured again when brought back (put on).
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.design import PhysicsDesign
from hri_envs.physics.kinematics import rotation_error
from hri_envs.task.geometry import Scenario

__all__ = ["Seats"]


class Seats:
    """The seat force law for all supports of a scenario.

    Args:
        scenario: Geometry (supports and their orientations).
        design: Stiffness, damping, detent force, capture region.
        capture: Capture distance [m] (default: the design's ``seat_capture_m``).
    """

    def __init__(self, scenario: Scenario, design: PhysicsDesign,
                 capture: float | None = None) -> None:
        self.design = design
        self.capture = design.seat_capture_m if capture is None else capture
        self.max_angle = design.seat_capture_angle_rad
        self.set_scenario(scenario)

    def set_scenario(self, scenario: Scenario) -> None:
        """Seat poses and exit directions of ``scenario`` (the wheel's stands move)."""
        self.pos = np.array([s.position for s in scenario.supports])  # (K, 3)
        self.quat = scenario.orientations[[s.orientation for s in scenario.supports]]  # (K, 4)
        out = np.array([s.mounting - s.position for s in scenario.supports])
        self.exit = out / np.linalg.norm(out, axis=1, keepdims=True)  # (K, 3)
        self._seat_xyz = self.pos.tolist()  # plain floats for the quick distance test

    def near(self, pos: np.ndarray) -> bool:
        """Whether the object's origin ``pos`` (3,) is within twice the capture distance
        of some seat: a cheap necessary condition of :meth:`engaged`.

        Captured means ``|along| < capture`` and ``across² < capture²``, so the squared
        distance ``along² + across²`` is below ``2 capture²``; the test keeps a margin of
        2 (``4 capture²``) far beyond any rounding, so it never misses a capture.
        """
        x, y, z = pos.tolist()
        limit = 4.0 * self.capture * self.capture
        for sx, sy, sz in self._seat_xyz:
            dx, dy, dz = sx - x, sy - y, sz - z
            if dx * dx + dy * dy + dz * dz < limit:
                return True
        return False

    def engaged(self, pos: np.ndarray, quat: np.ndarray) -> int:
        """The support whose seat holds the object, or -1."""
        if not self.near(pos):
            return -1
        e = self.pos - pos  # (K, 3)
        along = -(e * self.exit).sum(axis=1)  # > 0: out of the seat
        across2 = (e * e).sum(axis=1) - along * along
        cap = self.capture
        for k in np.flatnonzero((np.abs(along) < cap) & (across2 < cap * cap)):
            r = rotation_error(self.quat[k], quat)
            if math.sqrt(r.dot(r)) < self.max_angle:  # = np.linalg.norm(r), bit for bit
                return int(k)
        return -1

    def wrench(self, k: int, pos: np.ndarray, quat: np.ndarray, vel: np.ndarray,
               angvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Force [N] and torque [N m] at the object's origin from seat ``k``."""
        design = self.design
        e = self.pos[k] - pos
        force = design.seat_stiffness * e - design.seat_damping * vel
        n = self.exit[k]
        f_out = float(force @ n)
        along = -float(e @ n)
        # Fade out over the last stretch (1 cm) of the capture region: no jump on leaving.
        fade = min(max((self.capture - along) / design.seat_fade_m, 0.0), 1.0)
        force = (force + (max(f_out, -design.seat_hold) - f_out) * n) * fade
        torque = (design.seat_rot_stiffness * rotation_error(self.quat[k], quat)
                  - design.seat_rot_damping * angvel) * fade
        return force, torque
