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

__all__ = [
    "Scenario",
    "Support",
    "hanger_scenario",
    "quat_angle",
    "sample_wheel_layout",
    "wheel_scenario",
]


def quat_angle(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Rotation angle in [rad] between unit quaternions (broadcasting over leading axes)."""
    dot = np.abs(np.sum(np.asarray(q0) * np.asarray(q1), axis=-1))
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


def _unit(q: tuple[float, float, float, float]) -> np.ndarray:
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
        name: "hanger" or "wheel".
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


# --------------------------------------------------------------------------------------
# Hanger (user study, paper Sect. 5.1)
# --------------------------------------------------------------------------------------
_Q_PEG = _unit((0.05, -0.7, -0.05, -0.7))
_Q_RAIL = _unit((0.5, -0.5, -0.5, -0.5))


def hanger_scenario() -> Scenario:
    """The clothes-hanger scenario: peg A, rail points B and C (24 abstract states)."""
    supports = (
        Support("A", np.array([0.71, -0.525, 0.535]), 0, np.array([0.6787, -0.3072, 0.585])),
        Support("B", np.array([0.46, 0.61, 0.82]), 1, np.array([0.46, 0.39, 0.87])),
        Support("C", np.array([0.20, 0.625, 0.82]), 1, np.array([0.20, 0.405, 0.87])),
    )
    return Scenario(
        name="hanger",
        object_name="clothes hanger",
        supports=supports,
        orientations=np.stack([_Q_PEG, _Q_RAIL]),
        orientation_names=("peg-facing", "rail-facing"),
        comfort_height=0.585,
        object_radius=0.2,
    )


# --------------------------------------------------------------------------------------
# Wheel (simulation study, paper Sects. 5.2 and 7)
# --------------------------------------------------------------------------------------
_Q_HORIZONTAL = np.array([1.0, 0.0, 0.0, 0.0])
_Q_VERTICAL = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])

WHEEL_RACK_HEIGHT = 1.7
WHEEL_STAND_HEIGHTS = (1.0, 1.2)
WHEEL_COMFORT_HEIGHT = 0.95
WHEEL_RADIUS = 0.3
WHEEL_RACK_CLEARANCE = 0.3  # mounting point distance from the rack, in +y [m]
WHEEL_STAND_CLEARANCE = 0.1  # mounting point height above a stand's top [m]
#: Nominal stand positions (x, y) [m]: used for the graph's features, which do not depend on
#: the layout (see ``tests/test_task.py::test_wheel_features_do_not_depend_on_layout``).
WHEEL_NOMINAL_STANDS = ((0.0, 2.2), (1.6, 2.2))


def sample_wheel_layout(rng: np.random.Generator) -> tuple[tuple[float, float], ...]:
    """Draw stand positions (x, y) [m] as the paper does.

    Each stand is 1.6-3.6 m from the rack (at the origin) and the stands are 1.0-2.2 m apart.
    """
    while True:
        dist = rng.uniform(1.6, 3.6, size=2)
        bearing = rng.uniform(-np.pi / 3, np.pi / 3, size=2)
        xy = np.stack([dist * np.sin(bearing), dist * np.cos(bearing)], axis=1)
        if 1.0 <= np.linalg.norm(xy[0] - xy[1]) <= 2.2:
            return (float(xy[0, 0]), float(xy[0, 1])), (float(xy[1, 0]), float(xy[1, 1]))


def wheel_scenario(
    stands: tuple[tuple[float, float], ...] = WHEEL_NOMINAL_STANDS,
) -> Scenario:
    """The wheel scenario: rack A (vertical), stands B and C (horizontal), 36 abstract states.

    Args:
        stands: (x, y) in [m] of stands B and C; see :func:`sample_wheel_layout`.
    """
    if len(stands) != 2:
        raise ConfigError(f"stands must hold exactly two (x, y) positions (B and C) for the "
                          f"wheel scenario, got {len(stands)}", field="stands")
    rack = Support(
        "A",
        np.array([0.0, 0.0, WHEEL_RACK_HEIGHT]),
        1,
        np.array([0.0, WHEEL_RACK_CLEARANCE, WHEEL_RACK_HEIGHT]),
    )
    stand_supports = tuple(
        Support(
            name,
            np.array([x, y, h]),
            0,
            np.array([x, y, h + WHEEL_STAND_CLEARANCE]),
            blocks_below=True,
        )
        for name, (x, y), h in zip("BC", stands, WHEEL_STAND_HEIGHTS, strict=True)
    )
    return Scenario(
        name="wheel",
        object_name="wheel",
        supports=(rack, *stand_supports),
        orientations=np.stack([_Q_HORIZONTAL, _Q_VERTICAL]),
        orientation_names=("horizontal", "vertical"),
        comfort_height=WHEEL_COMFORT_HEIGHT,
        projection=WHEEL_RADIUS + 0.05,
        object_radius=WHEEL_RADIUS,
    )
