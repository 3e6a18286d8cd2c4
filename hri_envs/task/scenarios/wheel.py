"""The wheel (the paper's simulation study, Sects. 5.2 and 7): rack A, stands B and C.

36 abstract states. The wheel hangs vertically on the rack at 1.7 m and lies horizontally on
the stands (1.0 m and 1.2 m), which are placed at random each episode. Two preferences
(paper Fig. 9): *straight*, the shortest path rotating at the last moment, and *detour*,
rotating to horizontal at the first opportunity and moving over at carrying height.
"""

from __future__ import annotations

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.task.geometry import Scenario, Support
from hri_envs.task.scenarios.spec import Layout, Op, ScenarioSpec, natural_route

__all__ = ["APART_M", "FROM_RACK_M", "NOMINAL_STANDS", "PREFERENCES", "SPEC", "check_layout",
           "geometry", "sample_layout"]

_Q_HORIZONTAL = np.array([1.0, 0.0, 0.0, 0.0])
_Q_VERTICAL = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])

RACK_HEIGHT = 1.7
STAND_HEIGHTS = (1.0, 1.2)
COMFORT_HEIGHT = 0.95
RADIUS = 0.3
RACK_CLEARANCE = 0.3  # mounting point distance from the rack, in +y [m]
STAND_CLEARANCE = 0.1  # mounting point height above a stand's top [m]
#: Nominal stand positions (x, y) [m]: used for the graph's features, which do not depend on
#: the layout (see ``tests/test_task.py::test_wheel_features_do_not_depend_on_layout``).
NOMINAL_STANDS: Layout = ((0.0, 2.2), (1.6, 2.2))
#: The two preferences (paper Fig. 9).
PREFERENCES: tuple[str, ...] = ("straight", "detour")


#: Where the paper places the stands [m]: each this far from the rack, and this far apart.
FROM_RACK_M, APART_M = (1.6, 3.6), (1.0, 2.2)


def sample_layout(rng: np.random.Generator) -> Layout:
    """Draw stand positions (x, y) [m] as the paper does.

    Each stand is 1.6-3.6 m from the rack (at the origin) and the stands are 1.0-2.2 m apart
    (:data:`FROM_RACK_M`, :data:`APART_M`).
    """
    while True:
        dist = rng.uniform(*FROM_RACK_M, size=2)
        bearing = rng.uniform(-np.pi / 3, np.pi / 3, size=2)
        xy = np.stack([dist * np.sin(bearing), dist * np.cos(bearing)], axis=1)
        if APART_M[0] <= np.linalg.norm(xy[0] - xy[1]) <= APART_M[1]:
            return (float(xy[0, 0]), float(xy[0, 1])), (float(xy[1, 0]), float(xy[1, 1]))


def check_layout(stands: Layout) -> None:
    """Refuse stand positions the scenario's waypoints do not fit: each stand
    :data:`FROM_RACK_M` from the rack and the stands :data:`APART_M` apart (the ranges
    :func:`sample_layout` draws from; two stands at one point, or a stand at the rack,
    would make waypoints that collide).

    Raises:
        ConfigError: A stand outside them (``field="layout"``), the message naming it.
    """
    xy = np.asarray(stands, dtype=float)
    for name, d in zip(("B", "C"), np.linalg.norm(xy, axis=1), strict=True):
        if not FROM_RACK_M[0] - 1e-9 <= d <= FROM_RACK_M[1] + 1e-9:
            raise ConfigError(f"stand {name} is {d:.3g} m from the rack; the wheel's stands "
                              f"stand {FROM_RACK_M[0]}-{FROM_RACK_M[1]} m from it",
                              field="layout")
    apart = float(np.linalg.norm(xy[0] - xy[1]))
    if not APART_M[0] - 1e-9 <= apart <= APART_M[1] + 1e-9:
        raise ConfigError(f"the stands are {apart:.3g} m apart; the wheel's stand "
                          f"{APART_M[0]}-{APART_M[1]} m apart", field="layout")


def geometry(stands: Layout = NOMINAL_STANDS) -> Scenario:
    """The wheel scenario: rack A (vertical), stands B and C (horizontal), 36 abstract states.

    Args:
        stands: (x, y) in [m] of stands B and C; see :func:`sample_layout`.
    """
    if len(stands) != 2:
        raise ConfigError(f"stands must hold exactly two (x, y) positions (B and C) for the "
                          f"wheel scenario, got {len(stands)}", field="stands")
    rack = Support("A", np.array([0.0, 0.0, RACK_HEIGHT]), 1,
                   np.array([0.0, RACK_CLEARANCE, RACK_HEIGHT]))
    stand_supports = tuple(
        Support(name, np.array([x, y, h]), 0, np.array([x, y, h + STAND_CLEARANCE]),
                blocks_below=True)
        for name, (x, y), h in zip("BC", stands, STAND_HEIGHTS, strict=True)
    )
    return Scenario(
        name="wheel",
        object_name="wheel",
        supports=(rack, *stand_supports),
        orientations=np.stack([_Q_HORIZONTAL, _Q_VERTICAL]),
        orientation_names=("horizontal", "vertical"),
        comfort_height=COMFORT_HEIGHT,
        projection=RADIUS + 0.05,
        object_radius=RADIUS,
    )


_WORDS = {"straight": "take the shortest way, changing direction as little as possible, and "
                      "turn the wheel at the last moment",
          "detour": "turn the wheel horizontal at the first opportunity, then carry it over at "
                    "carrying height"}


def wording(preference: str) -> str | None:
    """How a preference reads to a participant (None for a name that is not one)."""
    return f"Carry it this way: {_WORDS[preference]}." if preference in _WORDS else None


def route(scenario: Scenario, preference: str, start: int, goal: int) -> list[Op]:
    """*straight*: the natural route; *detour*: lie the wheel down first, carry it low."""
    natural = natural_route(scenario, goal)
    if preference == "straight":
        return natural
    horizontal = scenario.orientation_names.index("horizontal")
    return [("rotate", horizontal), ("height", scenario.height_index(scenario.comfort_height)),
            *natural]


SPEC = ScenarioSpec(
    "wheel", geometry, r0=-0.25, gamma=0.6, episodes=20, preferences=PREFERENCES,
    default_preference="straight", route=route, n_actions=12, gym_id="hri_envs/Wheel-v0",
    panda_id="hri_envs/WheelPanda-v0", continuous_id="hri_envs/WheelPandaContinuous-v0",
    continuous_time_s=45.0,
    pettingzoo_module="hri_envs.wheel_v0",
    physics_design="hri_envs.physics.scene.design:wheel_design", layout=sample_layout,
    check_layout=check_layout, preference_wording=wording,
)
