"""What a scenario is: :class:`ScenarioSpec`, plain data plus a few pure functions.

A scenario module (``hanger.py``, ``wheel.py``, or one of your own, docs/scenarios.md)
defines one :class:`ScenarioSpec`; :func:`hri_envs.task.scenarios.register_scenario` makes
it known to the envs, the scripted humans, the learners and ``hri-bench``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from hri_envs.task.geometry import Scenario

__all__ = ["Layout", "Op", "Route", "ScenarioSpec", "ScheduleRow", "natural_route"]

#: One waypoint change of a scripted human's route: ("over", column), ("height", height
#: index) or ("rotate", orientation index), applied until the object is there.
Op = tuple[str, int]
#: ``route(scenario, preference, start, goal)``: a preference's ordered waypoint changes
#: from support ``start`` to support ``goal`` (see :func:`natural_route`).
Route = Callable[[Scenario, str, int, int], list[Op]]
#: Support positions (x, y) [m] of an episode, for scenarios whose supports move.
Layout = tuple[tuple[float, float], ...]
#: A fixed schedule's episode: (start support name, goal support name, turns back halfway).
ScheduleRow = tuple[str, str, bool]


def natural_route(scenario: Scenario, goal: int) -> list[Op]:
    """Over to the goal's column, to its mounting height, then to its resting orientation."""
    sup = scenario.supports[goal]
    return [("over", goal), ("height", scenario.height_index(sup.mounting[2])),
            ("rotate", sup.orientation)]


@dataclass(frozen=True)
class ScenarioSpec:
    """One scenario of the suite: every per-scenario constant, written once.

    Attributes:
        name: The scenario's name (``scenario=`` of the envs, ``hri-bench study NAME``).
        geometry: Builds the :class:`~hri_envs.task.geometry.Scenario` (nominal without
            arguments; with a layout from ``layout`` where the scenario has one).
        r0: The paper's robot reward for waiting while the human acts (the default).
        gamma: The paper's discount γ of every Q-iteration.
        episodes: Episodes per run of a benchmark study with a random schedule.
        preferences: The scripted humans' preference names.
        default_preference: The preference used when none is given.
        route: A preference's route between two supports (:data:`Route`).
        n_actions: Size A of the action set (checked against the graph).
        gym_id: Gymnasium id of the robot env on the graph (None: not registered).
        panda_id: Gymnasium id of the robot env on the simulated Panda (None: none).
        continuous_id: Gymnasium id of the continuous-control env on the simulated Panda
            with the whole human arm (None: none; :mod:`hri_envs.physics.carry.env`).
        continuous_time_s: The continuous env's default episode length [s] (its
            ``max_time_s``).
        pettingzoo_module: Module of the PettingZoo entry points (None: none; the envs are
            still made with ``scenario=name``).
        physics_design: ``"module:function"`` returning its ``PhysicsDesign`` (None: the
            scenario has no physics backend).
        layout: Draws a random support layout per episode (None: the supports are fixed).
        check_layout: Raises a ``ConfigError`` for a layout (a reset's ``layout`` option)
            the scenario's waypoints do not fit (None: any of the right shape).
        schedules: Fixed episode schedules by name (the hanger's user study: "table2").
        preference_wording: How a preference reads to a participant of ``hri-bench serve``
            (one or two sentences; None for a preference it has no words for). None: every
            preference reads "Carry it the way called '<preference>'."
            (:func:`hri_bench.people.serve.design.describe_preference`).
    """

    name: str
    geometry: Callable[..., Scenario]
    r0: float
    gamma: float
    episodes: int
    preferences: tuple[str, ...]
    default_preference: str
    route: Route
    n_actions: int
    gym_id: str | None = None
    panda_id: str | None = None
    continuous_id: str | None = None
    continuous_time_s: float = 30.0
    pettingzoo_module: str | None = None
    physics_design: str | None = None
    layout: Callable[..., Layout] | None = None
    check_layout: Callable[[Layout], None] | None = None
    schedules: Mapping[str, tuple[ScheduleRow, ...]] = field(default_factory=dict)
    preference_wording: Callable[[str], str | None] | None = None
