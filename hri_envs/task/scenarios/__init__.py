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

import re
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from hri_envs.checks import check_real, check_whole
from hri_envs.errors import ConfigError
from hri_envs.registry import Registry
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph, build_graph
from hri_envs.task.scenarios import hanger, wheel
from hri_envs.task.scenarios.spec import Layout, Op, Route, ScenarioSpec, natural_route

__all__ = [
    "SCENARIOS",
    "Layout",
    "NamedScenario",
    "Op",
    "Route",
    "ScenarioSpec",
    "as_graph",
    "as_spec",
    "check_spec",
    "episode_geometry",
    "episode_scenario",
    "graph_of",
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
    if isinstance(spec, ScenarioSpec):
        check_spec(spec)  # the plain fields first: each error names its field
    SCENARIOS.register(spec, replace=replace)
    _GRAPHS[spec.name] = _build(spec)
    return spec


def scenario_spec(name: str) -> ScenarioSpec:
    """The registered scenario ``name``; a :class:`ConfigError` listing them otherwise."""
    return SCENARIOS.get(name)


#: The registered scenarios' graphs (built once, at registration).
_GRAPHS: dict[str, TaskGraph] = {}


#: What a scenario's name may hold: it names files, folders and Gymnasium ids.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")


def check_spec(spec: ScenarioSpec) -> None:
    """Check a spec's plain fields (its graph is checked by building it).

    ``name`` letters, digits, ``-`` and ``_`` (it names files and ids); ``r0`` in (-1, 0);
    ``gamma`` in [0, 1); ``episodes`` and ``n_actions`` whole numbers >= 1; ``preferences``
    one or more names, ``default_preference`` one of them.

    Raises:
        ConfigError: The first field that is not allowed (``field`` its name).
    """
    if not (isinstance(spec.name, str) and NAME_PATTERN.fullmatch(spec.name)):
        raise ConfigError(f"a scenario's name must be letters, digits, '-' and '_' (it names "
                          f"files and Gymnasium ids), starting with a letter or digit, got "
                          f"{spec.name!r}", field="name")
    label = f"scenario {spec.name!r}: "
    check_real(spec.r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True,
               label=label + "r0", allowed="a number in the open interval (-1, 0)")
    check_real(spec.gamma, "gamma", low=0.0, high=1.0, high_open=True, label=label + "gamma",
               allowed="a number in [0, 1)")
    check_whole(spec.episodes, "episodes", minimum=1, label=label + "episodes")
    check_whole(spec.n_actions, "n_actions", minimum=1, label=label + "n_actions")
    prefs = spec.preferences
    if not (isinstance(prefs, tuple) and prefs and all(isinstance(p, str) for p in prefs)):
        raise ConfigError(f"{label}preferences must be a tuple of one or more names, got "
                          f"{prefs!r}", field="preferences")
    if spec.default_preference not in prefs:
        raise ConfigError(f"the default preference {spec.default_preference!r} of scenario "
                          f"{spec.name!r} is not one of its preferences "
                          f"{', '.join(prefs)}", field="default_preference")


def _check_geometry(scenario: Scenario, name: str) -> None:
    """Every support's position and mounting point: 3 finite numbers [m]."""
    for support in scenario.supports:
        for what in ("position", "mounting"):
            xyz = np.asarray(getattr(support, what), dtype=float)
            if xyz.shape != (3,) or not np.all(np.isfinite(xyz)):
                raise ConfigError(f"scenario {name!r}: support {support.name!r}'s {what} must "
                                  f"be 3 finite numbers [m], got {getattr(support, what)!r}",
                                  field="geometry")


def _build(spec: ScenarioSpec) -> TaskGraph:
    check_spec(spec)
    try:
        scenario = spec.geometry()
        _check_geometry(scenario, spec.name)
        graph = build_graph(scenario, spec=spec)
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


def graph_of(spec: ScenarioSpec) -> TaskGraph:
    """The task graph of ``spec``: the registered scenario's (built once, at registration),
    or built now for a spec that is not registered (one checked before registering it).

    Raises:
        ConfigError: An unregistered spec's geometry does not build a graph.
    """
    graph = _GRAPHS.get(spec.name)
    return graph if graph is not None and graph.spec is spec else _build(spec)


def scenario_graph(name: str) -> TaskGraph:
    """The (read-only, shared) task graph of a scenario, built once per process; it knows
    its spec (:attr:`TaskGraph.spec`).
    """
    return _GRAPHS[scenario_spec(name).name]


def as_graph(scenario: TaskGraph | ScenarioSpec | str) -> TaskGraph:
    """The task graph of ``scenario`` at the top of a public function a user may call with
    a scenario's name (``FixedAdmittance("hanger")``, ``physical_population("test",
    "wheel")``): a graph as it is, a spec's (:func:`graph_of`), a registered scenario's name
    resolved here, once; what the function calls below takes the graph.

    Raises:
        ConfigError: An unknown name (the message lists the registered scenarios).
    """
    if isinstance(scenario, TaskGraph):
        return scenario
    if isinstance(scenario, ScenarioSpec):
        return graph_of(scenario)
    return scenario_graph(scenario)


def as_spec(scenario: ScenarioSpec | TaskGraph | str) -> ScenarioSpec:
    """The spec of ``scenario`` at the top of a public function a user may call with a
    scenario's name (:func:`as_graph`'s twin for what needs the spec): a spec as it is (a
    registered one or one being checked), a graph's (:func:`spec_of`), a registered
    scenario's name resolved here, once.

    Raises:
        ConfigError: An unknown name (the message lists the registered scenarios).
    """
    return scenario if isinstance(scenario, ScenarioSpec) else spec_of(as_graph(scenario))


class NamedScenario:
    """A mixin of what names its scenario (``scenario``, as a file or a frozen definition
    stores it: a study's, a dataset's, a split's): the name is resolved here, once, and
    the rest is given :attr:`graph` and :attr:`spec`, never the name.

    Pickled without the graph: a process that unpickles it resolves the name again (after
    importing the modules that register its scenario).
    """

    if TYPE_CHECKING:  # a field, or a property (a dataset's is read from its file)
        @property
        def scenario(self) -> str:
            """The scenario's name."""

    @cached_property
    def graph(self) -> TaskGraph:
        """The registered scenario's task graph (it knows its :attr:`spec`)."""
        return scenario_graph(self.scenario)

    @property
    def spec(self) -> ScenarioSpec:
        """The registered scenario (:attr:`graph`'s :class:`ScenarioSpec`)."""
        return spec_of(self.graph)

    def __getstate__(self) -> dict[str, Any]:
        """The instance's state without the resolved graph."""
        return {k: v for k, v in self.__dict__.items() if k != "graph"}


def episode_scenario(name: str, layout: Layout | None) -> Scenario:
    """The geometry of one episode of the scenario ``name`` (:func:`episode_geometry`)."""
    return episode_geometry(scenario_graph(name), layout)


def episode_geometry(graph: TaskGraph, layout: Layout | None) -> Scenario:
    """The geometry of one episode on ``graph``: its scenario's supports moved to ``layout``
    if it has random layouts (the wheel's stands), else the graph's fixed geometry.
    """
    spec = spec_of(graph)
    if layout is not None and spec.layout is not None:
        return spec.geometry(layout)
    return graph.scenario


# The suite's scenarios, in this order (the one place a scenario is registered).
for _spec in (hanger.SPEC, wheel.SPEC):
    register_scenario(_spec)
