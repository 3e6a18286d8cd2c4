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

from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import rotation_error
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
        # Plain floats for engaged(), which runs every control period.
        self._seats = list(zip(self.pos.tolist(), self.exit.tolist(), strict=True))

    def engaged(self, pos: np.ndarray, quat: np.ndarray) -> int:
        """The support whose seat holds the object, or -1."""
        # Per seat: e = seat - pos, along = -e·d (> 0: out of the seat), across² = |e|² -
        # along². Plain floats, summed left to right as numpy's row sums of three are.
        x, y, z = pos.tolist()
        cap = self.capture
        cap2 = cap * cap
        for k, ((sx, sy, sz), (nx, ny, nz)) in enumerate(self._seats):
            ex, ey, ez = sx - x, sy - y, sz - z
            along = -(ex * nx + ey * ny + ez * nz)
            if abs(along) < cap and (ex * ex + ey * ey + ez * ez) - along * along < cap2:
                r = rotation_error(self.quat[k], quat)
                if math.sqrt(r.dot(r)) < self.max_angle:  # = np.linalg.norm(r), bit for bit
                    return k
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
