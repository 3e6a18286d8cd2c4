"""The scenario registry: every per-scenario constant of the suite, written once.

A frozen :class:`ScenarioSpec` per scenario holds its geometry, the paper's parameters
(r0, γ), the benchmark's default number of episodes, the scripted humans' preferences, the
public ids and the physics design. The envs, the agents' configuration, ``hri-bench``, its
help texts and the SB3 helpers read them from :data:`SCENARIOS`; none repeats a number.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from dataclasses import dataclass

from hri_envs.errors import ConfigError
from hri_envs.task.geometry import Scenario, hanger_scenario, sample_wheel_layout, wheel_scenario
from hri_envs.task.graph import TaskGraph, build_graph

__all__ = [
    "HANGER_DEFAULT_PREFERENCE",
    "HANGER_PREFERENCES",
    "SCENARIOS",
    "WHEEL_PREFERENCES",
    "ScenarioSpec",
    "episode_scenario",
    "scenario_graph",
    "scenario_spec",
]

_PEG_STEPS = ("down", "over", "rotate")
_RAIL_STEPS = ("over", "up", "rotate")
#: The 36 hanger preferences, "to-peg order/to-rail order", e.g. "down-over-rotate/over-rotate-up".
HANGER_PREFERENCES: tuple[str, ...] = tuple(
    "-".join(p) + "/" + "-".join(r)
    for p in itertools.permutations(_PEG_STEPS)
    for r in itertools.permutations(_RAIL_STEPS)
)
#: The user study's most frequent preference (paper Sect. 6.3, Fig. 8).
HANGER_DEFAULT_PREFERENCE = "down-over-rotate/over-rotate-up"
#: The wheel's two preferences (paper Fig. 9).
WHEEL_PREFERENCES: tuple[str, ...] = ("straight", "detour")


@dataclass(frozen=True)
class ScenarioSpec:
    """One scenario of the suite.

    Attributes:
        name: "hanger" or "wheel".
        geometry: Builds the :class:`~hri_envs.task.geometry.Scenario` (nominal without
            arguments; with a layout from ``layout`` where the scenario has one).
        r0: The paper's robot reward for waiting while the human acts (the default).
        gamma: The paper's discount γ of every Q-iteration.
        episodes: Episodes per run of a benchmark study with a random schedule.
        preferences: The scripted humans' preference names.
        default_preference: The preference used when none is given.
        n_actions: Size A of the action set (checked against the graph).
        gym_id: Gymnasium id of the robot env on the graph.
        panda_id: Gymnasium id of the robot env on the simulated Panda.
        pettingzoo_module: Module of the PettingZoo entry points.
        physics_design: ``"module:function"`` returning its ``PhysicsDesign``.
        layout: Draws a random support layout per episode (None: the supports are fixed).
    """

    name: str
    geometry: Callable[..., Scenario]
    r0: float
    gamma: float
    episodes: int
    preferences: tuple[str, ...]
    default_preference: str
    n_actions: int
    gym_id: str
    panda_id: str
    pettingzoo_module: str
    physics_design: str
    layout: Callable[..., tuple[tuple[float, float], ...]] | None = None


#: The registry, by name.
SCENARIOS: dict[str, ScenarioSpec] = {
    spec.name: spec
    for spec in (
        ScenarioSpec("hanger", hanger_scenario, r0=-0.33, gamma=0.9, episodes=8,
                     preferences=HANGER_PREFERENCES,
                     default_preference=HANGER_DEFAULT_PREFERENCE, n_actions=10,
                     gym_id="hri_envs/Hanger-v0", panda_id="hri_envs/HangerPanda-v0",
                     pettingzoo_module="hri_envs.hanger_v0",
                     physics_design="hri_envs.physics.design:hanger_design"),
        ScenarioSpec("wheel", wheel_scenario, r0=-0.25, gamma=0.6, episodes=20,
                     preferences=WHEEL_PREFERENCES, default_preference="straight",
                     n_actions=12, gym_id="hri_envs/Wheel-v0",
                     panda_id="hri_envs/WheelPanda-v0", pettingzoo_module="hri_envs.wheel_v0",
                     physics_design="hri_envs.physics.design:wheel_design",
                     layout=sample_wheel_layout),
    )
}


def scenario_spec(name: str) -> ScenarioSpec:
    """The registered scenario ``name``; a :class:`ConfigError` listing them otherwise."""
    spec = SCENARIOS.get(name) if isinstance(name, str) else None
    if spec is None:
        raise ConfigError(f"unknown scenario {name!r}; allowed: {', '.join(SCENARIOS)}",
                          field="scenario")
    return spec


@functools.cache
def _graph(name: str) -> TaskGraph:
    spec = SCENARIOS[name]
    graph = build_graph(spec.geometry())
    if graph.n_actions != spec.n_actions:
        raise AssertionError(f"{name}: the graph has {graph.n_actions} actions, the registry "
                             f"says {spec.n_actions}")
    return graph


def scenario_graph(name: str) -> TaskGraph:
    """The (read-only, shared) task graph of a scenario, built once per process."""
    return _graph(scenario_spec(name).name)


def episode_scenario(name: str, layout: tuple[tuple[float, float], ...] | None) -> Scenario:
    """The geometry of one episode: the scenario's supports moved to ``layout`` if it has
    random layouts (the wheel's stands), else its fixed geometry.
    """
    spec = scenario_spec(name)
    if layout is not None and spec.layout is not None:
        return spec.geometry(layout)
    return scenario_graph(name).scenario
