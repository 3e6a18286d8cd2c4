"""Configuration shared by the environments: scenarios, defaults and input validation.

Every check raises :class:`~hri_envs.errors.ConfigError` (a ``ValueError``) with a
message that lists what is allowed.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from gymnasium.vector import AutoresetMode

from hri_envs.checks import check_real, check_whole
from hri_envs.envs.backends import BACKENDS, body_options, check_backend, options_checker
from hri_envs.errors import ConfigError
from hri_envs.humans.spec import HumanBody
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import (
    ScenarioSpec,
    episode_scenario,
    scenario_graph,
    scenario_spec,
    spec_of,
)

__all__ = [
    "BACKENDS",
    "MAX_CYCLES",
    "RESET_OPTION_KEYS",
    "EnvSettings",
    "ResetOptions",
    "check_autoreset_mode",
    "check_backend",
    "check_env_settings",
    "check_layout",
    "check_max_cycles",
    "check_options_mapping",
    "check_physics_options",
    "check_r0",
    "check_render_mode",
    "check_scenario",
    "check_seed",
    "episode_scenario",
    "parse_reset_options",
    "scenario_graph",
    "support_index",
]

#: The largest step limit per episode (``max_cycles``) an env takes.
MAX_CYCLES = 1_000_000_000

#: Keys ``reset(options=...)`` understands ("layout" only for the wheel).
RESET_OPTION_KEYS: tuple[str, ...] = ("start", "intention", "turn_back", "layout")
# pettingzoo.test's api tests probe ``reset(options={"options": 1})``; that key is ignored.
_IGNORED_OPTION_KEYS = frozenset({"options"})


def check_scenario(name: str) -> str:
    """Return ``name`` if it is a registered scenario (``hri_envs.task.scenarios``)."""
    return scenario_spec(name).name


def check_r0(r0: float | None, spec: ScenarioSpec) -> float:
    """Validate the robot's passive reward r0 ∈ (-1, 0); None gives the scenario's default."""
    paper = spec.r0
    if r0 is None:
        return paper
    return check_real(r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True,
                      allowed=f"a number in the open interval (-1, 0) (the paper uses {paper} "
                              f"for the {spec.name})")


def check_seed(seed: Any, what: str = "this env") -> int | None:
    """A reset's ``seed``: None, or a whole number >= 0 (numpy's generators take no other).

    Raises:
        ConfigError: Anything else (``field="seed"``), before Gymnasium's own error.
    """
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ConfigError(f"seed must be a whole number >= 0 or None for {what}, got {seed!r}",
                          field="seed")
    return int(seed)


def check_max_cycles(max_cycles: int) -> int:
    """Validate the step limit per episode: a whole number in [1, :data:`MAX_CYCLES`]."""
    return check_whole(max_cycles, "max_cycles", minimum=1, maximum=MAX_CYCLES,
                       allowed=f"a positive integer, at most {MAX_CYCLES:,}")


def check_render_mode(render_mode: str | None, allowed: list[str]) -> str | None:
    """Validate ``render_mode`` against an env's ``metadata["render_modes"]``."""
    if render_mode is not None and (not isinstance(render_mode, str)
                                    or render_mode not in allowed):
        modes = ", ".join([repr(m) for m in allowed] + ["None"])
        raise ConfigError(f"unsupported render_mode {render_mode!r}; allowed: {modes}",
                          field="render_mode")
    return render_mode


class EnvSettings(NamedTuple):
    """The arguments every environment takes, validated (see :func:`check_env_settings`)."""

    scenario: str
    r0: float
    max_cycles: int
    render_mode: str | None
    backend: str


def check_env_settings(
    scenario: str,
    r0: float | None,
    max_cycles: int,
    render_mode: str | None,
    render_modes: list[str],
    backend: str,
) -> EnvSettings:
    """Validate the arguments shared by all envs (the env constructors' edge: ``scenario``,
    a name, is resolved here); r0 None becomes the scenario's default.
    """
    spec = scenario_spec(scenario)
    return EnvSettings(spec.name, check_r0(r0, spec), check_max_cycles(max_cycles),
                       check_render_mode(render_mode, render_modes), check_backend(backend))


def check_physics_options(physics: Mapping[str, Any] | None, backend: str,
                          body: HumanBody | None = None) -> dict[str, Any]:
    """Validate the ``physics`` options against what ``backend`` accepts.

    The backend's own checker does it (:attr:`~hri_envs.envs.backends.BackendSpec.options`;
    the mujoco backend's keys are in :mod:`hri_envs.physics.panda.options` and docs/physics.md);
    a backend without options refuses any. ``body`` (a :class:`~hri_envs.humans.spec.
    HumanBody`, a ``HumanSpec``'s) adds the options it stands for
    (:func:`~hri_envs.envs.backends.body_options`; a backend without a physical human
    refuses it); a key set both ways is refused (``field="human"``).
    """
    if physics is not None and not isinstance(physics, Mapping):
        raise ConfigError(f"physics must be a mapping of option names to values, got "
                          f"{physics!r}", field="physics")
    if body is not None:
        extra = body_options(backend, body)
        both = sorted(set(extra) & set(physics or {}))
        if both:
            raise ConfigError(f"{', '.join(map(repr, both))} given both by the human's body and "
                              "in physics=; give each once", field="human")
        physics = {**(physics or {}), **extra}
    if not physics:
        return {}
    check = options_checker(backend)
    if check is None:
        takes = [name for name, spec in BACKENDS.items() if spec.options]
        raise ConfigError(f"backend={backend!r} takes no physics options; backends that do: "
                          f"{', '.join(takes)}", field="physics")
    return check(physics)


def support_index(value: Any, scenario: Scenario, key: str) -> int:
    """A support given by index or name ("A", "B", ...) as an index."""
    names = scenario.support_names
    if isinstance(value, str):
        if value in names:
            return names.index(value)
    elif isinstance(value, int | np.integer) and not isinstance(value, bool):
        if 0 <= value < len(names):
            return int(value)
    allowed = ", ".join(f"{i} or {n!r}" for i, n in enumerate(names))
    raise ConfigError(f"reset option {key!r} must name a support ({allowed}), got {value!r}",
                      field=key)


class ResetOptions(NamedTuple):
    """Validated ``reset(options=...)`` of a single-episode env (None = draw at random)."""

    start: int | None = None
    intention: int | None = None
    turn_back: bool | None = None
    layout: tuple[tuple[float, float], tuple[float, float]] | None = None


_NO_OPTIONS = ResetOptions()  # immutable, so one serves every reset without options


def _check_option_keys(options: Mapping[str, Any], spec: ScenarioSpec) -> None:
    allowed = RESET_OPTION_KEYS if spec.layout is not None else RESET_OPTION_KEYS[:3]
    unknown = sorted(map(repr, set(options) - set(allowed) - _IGNORED_OPTION_KEYS))
    if unknown:
        raise ConfigError(
            f"unknown reset option(s) {', '.join(unknown)} for the {spec.name}; "
            f"allowed: {', '.join(allowed)}", field="options"
        )


def _check_layout(value: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    try:
        xy = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        xy = np.zeros(0)
    if xy.shape != (2, 2) or not np.all(np.isfinite(xy)):
        raise ConfigError(
            f"reset option 'layout' must be ((xB, yB), (xC, yC)) in [m], got {value!r}",
            field="layout"
        )
    return (float(xy[0, 0]), float(xy[0, 1])), (float(xy[1, 0]), float(xy[1, 1]))


def check_options_mapping(options: Any) -> Mapping[str, Any]:
    """``reset(options=...)`` must be None or a mapping of option names to values."""
    if not isinstance(options, Mapping):
        raise ConfigError(f"reset options must be None or a dict of option names to values "
                          f"(e.g. {{'start': 'A'}}), got {options!r}", field="options")
    return options


def parse_reset_options(options: Mapping[str, Any] | None, graph: TaskGraph) -> ResetOptions:
    """Validate the reset options of a single-episode env on ``graph``.

    Allowed keys: ``start`` and ``intention`` (a support index or name; they must differ),
    ``turn_back`` (bool) and, for the wheel, ``layout`` (stand positions, see
    :func:`~hri_envs.task.geometry.sample_wheel_layout`).
    """
    if options is None:
        return _NO_OPTIONS
    check_options_mapping(options)
    if not options:
        return _NO_OPTIONS
    spec, scenario = spec_of(graph), graph.scenario
    _check_option_keys(options, spec)
    start = intention = turn_back = layout = None
    if options.get("start") is not None:
        start = support_index(options["start"], scenario, "start")
    if options.get("intention") is not None:
        intention = support_index(options["intention"], scenario, "intention")
    if start is not None and start == intention:
        raise ConfigError(
            f"the intention must differ from the start support, both are "
            f"{scenario.support_names[start]!r}", field="intention"
        )
    if options.get("turn_back") is not None:
        value = options["turn_back"]
        if not isinstance(value, bool | np.bool_):
            raise ConfigError(f"reset option 'turn_back' must be a bool, got {value!r}",
                              field="turn_back")
        turn_back = bool(value)
    if options.get("layout") is not None:
        layout = _spec_layout(options["layout"], spec)
    return ResetOptions(start, intention, turn_back, layout)


def check_layout(value: Any, graph: TaskGraph
                 ) -> tuple[tuple[float, float], tuple[float, float]]:
    """A reset's ``layout`` option of ``graph``'s scenario (the wheel's stands ``((xB, yB), (xC,
    yC))`` [m], finite and where the scenario's waypoints fit) as a tuple of floats.

    Raises:
        ConfigError: (``field="layout"``) Anything else.
    """
    return _spec_layout(value, spec_of(graph))


def _spec_layout(value: Any, spec: ScenarioSpec
                 ) -> tuple[tuple[float, float], tuple[float, float]]:
    """:func:`check_layout` for the scenario ``spec``."""
    layout = _check_layout(value)
    if spec.check_layout is not None:
        spec.check_layout(layout)
    return layout


def check_autoreset_mode(value: Any) -> AutoresetMode:
    """A vector env's ``autoreset_mode`` (an :class:`~gymnasium.vector.AutoresetMode` or its
    value): next-step or same-step; disabled autoreset is not supported.

    Raises:
        ConfigError: Anything else (``field="autoreset_mode"``).
    """
    allowed = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
    try:
        mode = AutoresetMode(value)
    except ValueError:
        mode = None
    if mode not in allowed:
        raise ConfigError(f"autoreset_mode must be {allowed[0].value!r} or {allowed[1].value!r}, "
                          f"got {value!r}", field="autoreset_mode")
    return mode
