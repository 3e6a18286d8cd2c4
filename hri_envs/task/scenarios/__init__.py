"""The scenario registry: every per-scenario constant of the suite, written once.

A scenario is one module holding a :class:`ScenarioSpec` (its geometry, the paper's
parameters r0 and γ, the benchmark's default number of episodes, the scripted humans'
preferences and routes, fixed schedules, the public ids and the physics design):
:mod:`~hri_envs.task.scenarios.hanger` and :mod:`~hri_envs.task.scenarios.wheel`. They are
registered here, in one place; :func:`register_scenario` adds one of your own
(docs/scenarios.md walks through it). The envs, the humans, the agents' configuration,
``hri-bench`` and its help texts read the specs from :data:`SCENARIOS`; none repeats a number.
"""

from __future__ import annotations

from hri_envs.errors import ConfigError
from hri_envs.registry import Registry
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph, build_graph
from hri_envs.task.scenarios import hanger, wheel
from hri_envs.task.scenarios.spec import Layout, Op, Route, ScenarioSpec, natural_route

__all__ = [
    "SCENARIOS",
    "Layout",
    "Op",
    "Route",
    "ScenarioSpec",
    "episode_scenario",
    "natural_route",
    "register_scenario",
    "scenario_graph",
    "scenario_spec",
    "spec_of",
]

def _check(spec: ScenarioSpec) -> None:
    """What :func:`register_scenario` checks (its docstring)."""
    if spec.default_preference not in spec.preferences:
        raise ConfigError(f"the default preference {spec.default_preference!r} of scenario "
                          f"{spec.name!r} is not one of its preferences "
                          f"{', '.join(spec.preferences)}", field="default_preference")
    graph = _build(spec)
    if graph.n_actions != spec.n_actions:
        raise ConfigError(f"scenario {spec.name!r}: its graph has {graph.n_actions} actions "
                          f"(the supports' moves, the heights and the fixed ones), the spec "
                          f"says n_actions={spec.n_actions}", field="n_actions")


#: The registry, by name (:class:`~hri_envs.registry.Registry`).
SCENARIOS: Registry[ScenarioSpec] = Registry("scenario", ScenarioSpec, field="scenario",
                                             check=_check)


def register_scenario(spec: ScenarioSpec, *, replace: bool = False) -> ScenarioSpec:
    """Make ``spec`` known to the envs, the humans, the learners and ``hri-bench``; returns
    it.

    Its graph is built here, so a spec whose geometry does not build, or whose
    ``n_actions`` is not its graph's, fails now rather than at first use. Its Gymnasium ids,
    if any, are registered by :func:`hri_envs.registration.register_envs`;
    :func:`hri_envs.conformance.check_scenario` checks the rest (its routes, an episode of
    every env).

    Args:
        spec: The scenario.
        replace: Replace the scenario registered under its name (otherwise refused).

    Raises:
        ConfigError: ``spec`` is not a :class:`ScenarioSpec`, its name is another
            scenario's (and ``replace`` is False), its default preference is not one of its
            preferences, or its graph does not build or has another number of actions than
            ``n_actions``.
    """
    SCENARIOS.register(spec, replace=replace)
    _GRAPHS[spec.name] = _build(spec)
    return spec


def scenario_spec(name: str) -> ScenarioSpec:
    """The registered scenario ``name``; a :class:`ConfigError` listing them otherwise."""
    return SCENARIOS.get(name)


#: The registered scenarios' graphs (built once, at registration).
_GRAPHS: dict[str, TaskGraph] = {}


def _build(spec: ScenarioSpec) -> TaskGraph:
    try:
        graph = build_graph(spec.geometry(), spec=spec)
    except ConfigError:
        raise
    except Exception as exc:  # a user's geometry: say whose and what
        raise ConfigError(f"scenario {spec.name!r}: its geometry does not build a task graph "
                          f"({type(exc).__name__}: {exc})", field="geometry") from exc
    return graph


def spec_of(graph: TaskGraph) -> ScenarioSpec:
    """The scenario a graph was built for (:attr:`TaskGraph.spec`; a graph built from a
    bare geometry: the registered scenario of its name).
    """
    return graph.spec if graph.spec is not None else scenario_spec(graph.name)


def scenario_graph(name: str) -> TaskGraph:
    """The (read-only, shared) task graph of a scenario, built once per process; it knows
    its spec (:attr:`TaskGraph.spec`).
    """
    return _GRAPHS[scenario_spec(name).name]


def episode_scenario(name: str, layout: Layout | None) -> Scenario:
    """The geometry of one episode: the scenario's supports moved to ``layout`` if it has
    random layouts (the wheel's stands), else its fixed geometry.
    """
    spec = scenario_spec(name)
    if layout is not None and spec.layout is not None:
        return spec.geometry(layout)
    return scenario_graph(name).scenario


# The suite's scenarios, in this order (the one place a scenario is registered).
for _spec in (hanger.SPEC, wheel.SPEC):
    register_scenario(_spec)
