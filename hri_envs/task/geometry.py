"""Scenario geometry: supports, mounting points, heights and orientations.

Everything in this module is plain data in metres and unit quaternions ``(w, x, y, z)``.
The abstract task graph (:mod:`hri_envs.task.graph`), the preference features
(:mod:`hri_envs.task.features`), the renderer and the physics backend are all derived from
one :class:`Scenario`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hri_envs.errors import ConfigError

__all__ = ["Scenario", "Support", "quat_angle", "unit_quaternion"]


def quat_angle(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation angle in [rad] between unit quaternions (broadcasting over leading axes)."""
    dot = np.abs(np.sum(np.asarray(q0) * np.asarray(q1), axis=-1))
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def unit_quaternion(q: tuple[float, float, float, float]) -> np.ndarray:
    """``q`` (w, x, y, z) scaled to unit length."""
    v = np.asarray(q, dtype=float)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class Support:
    """A place where the object can rest without being held.

    Attributes:
        name: One-letter label ("A", "B", ...), also the intention's name.
        position: Object position when resting on the support, in [m], shape (3,).
        orientation: Index into :attr:`Scenario.orientations` of the resting orientation.
        mounting: The *mounting point* in [m], shape (3,): where the object is put on from
            and taken off to.
        blocks_below: Whether the support is a stand whose column is blocked below its top
            (waypoints there are projected away, see :attr:`Scenario.projection`).
    """

    name: str
    position: np.ndarray
    orientation: int
    mounting: np.ndarray
    blocks_below: bool = False


@dataclass(frozen=True)
class Scenario:
    """Geometry of one cooperative carrying task.

    Attributes:
        name: The scenario's name (its registry key, :mod:`hri_envs.task.scenarios`).
        object_name: What is carried, for rendering and logs.
        supports: The supports; the i-th is intention ``i``.
        orientations: Allowed object orientations as unit quaternions, shape (O, 4).
        orientation_names: A readable label per orientation.
        comfort_height: Comfortable carrying height in [m].
        projection: Distance in [m] a waypoint is moved in -x when it would collide with a
            stand (a bit over the object's radius); 0 disables projection.
        object_radius: Object radius in [m], used for collisions and drawing.
    """

    name: str
    object_name: str
    supports: tuple[Support, ...]
    orientations: np.ndarray
    orientation_names: tuple[str, ...]
    comfort_height: float
    projection: float = 0.0
    object_radius: float = 0.2
    heights: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        mounts = np.array([s.mounting[2] for s in self.supports] + [self.comfort_height])
        # Distinct heights (within 1 mm), sorted bottom-up.
        heights: list[float] = []
        for h in np.sort(mounts):
            if not heights or h - heights[-1] > 1e-3:
                heights.append(float(h))
        object.__setattr__(self, "heights", np.array(heights))
        if len(self.orientation_names) != len(self.orientations):
            raise ConfigError(f"orientation_names must have one entry per orientation "
                              f"({len(self.orientations)}), got {len(self.orientation_names)}",
                              field="orientation_names")

    @property
    def n_supports(self) -> int:
        """Number of supports K (= number of intentions)."""
        return len(self.supports)

    @property
    def support_names(self) -> tuple[str, ...]:
        """Support labels in intention order."""
        return tuple(s.name for s in self.supports)

    def height_index(self, z: float) -> int:
        """Index into :attr:`heights` of the height ``z`` (within 1 mm)."""
        idx = int(np.argmin(np.abs(self.heights - z)))
        if abs(self.heights[idx] - z) > 1e-3:
            raise ConfigError(f"z must be one of the waypoint heights {self.heights.tolist()} m "
                              f"(within 1 mm), got {z} m", field="z")
        return idx

    def waypoint_position(self, column: int, height: int) -> np.ndarray:
        """Physical position in [m] of the waypoint at support column ``column`` and height index.

        The nominal position is the column's mounting (x, y) at the given height; a waypoint
        that would collide with a stand (below the stand's top, within an object radius of
        its column) is projected in -x by :attr:`projection`.
        """
        xy = self.supports[column].mounting[:2]
        z = self.heights[height]
        pos = np.array([xy[0], xy[1], z])
        for s in self.supports:
            near = np.linalg.norm(s.position[:2] - xy) < self.object_radius
            if s.blocks_below and near and z < s.mounting[2] - 1e-3 and self.projection > 0:
                pos[0] -= self.projection
        return pos
