"""The registry of human families: every kind of human a population can draw, by name.

=================  ===============  ==========================================================
family             group            model (parameters; module)
=================  ===============  ==========================================================
``preference``     scripted         a scripted preference, optionally passive or Boltzmann
                                    (preference, passive, rationality; :mod:`.scripted`,
                                    :mod:`.populations`)
``low``            misspecified     keeps the object low (w, preference; :mod:`.misspecified`)
``avoid``          misspecified     avoids passing near a support (support, w, sigma,
                                    preference)
``rotate-low``     misspecified     rotates as low as it can (w, preference)
``impatient``      misspecified     takes over after the robot waited k times (k, preference)
``follower``       adaptive         adopts the robot's route after k proposals (k, preference,
                                    other; :mod:`.adaptive`)
``trust``          adaptive         a trust level that rises and falls; lets a trusted robot
                                    lead (levels, start, rise, fall, passive, preference)
``wary``           adaptive         resists more after wrong robot motions (levels, forgive,
                                    preference)
``fickle``         inconsistent     changes its intention mid-episode at random times (hazard,
                                    changes, preference; :mod:`.inconsistent`)
``moody``          inconsistent     changes its preference at random episodes (p, preferences)
=================  ===============  ==========================================================

:func:`build_family` builds one (cached per graph and parameters); parameters not given
take the defaults of the model's function. Every parameter is checked: an unknown name or
an impossible value raises a :class:`~hri_envs.errors.ConfigError` whose ``field`` is
``human_params`` (``--human-param`` of ``hri-bench study``).
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from typing import Any

from hri_envs.errors import ConfigError
from hri_envs.humans import adaptive, inconsistent, misspecified
from hri_envs.humans.finite_state import FiniteStateHuman
from hri_envs.humans.rational import rational_human, validate_rationality
from hri_envs.humans.scripted import ScriptedHuman, check_probability, preference_human
from hri_envs.registry import Registry
from hri_envs.task.graph import TaskGraph

__all__ = ["FAMILIES", "GROUPS", "Family", "HumanModel", "build_family", "check_params",
           "family_params", "register_family"]

#: What a family builds.
HumanModel = ScriptedHuman | FiniteStateHuman


def _preference(graph: TaskGraph, *, preference: str | None = None, passive: float = 0.0,
                rationality: float = math.inf) -> ScriptedHuman:
    """A scripted preference human, passive with probability ``passive``, Boltzmann with
    rationality β = ``rationality`` (``inf``: deterministic).
    """
    passive = check_probability(passive, "passive")
    beta = validate_rationality(rationality, "rationality")
    return rational_human(preference_human(graph, preference, passive=passive), beta)


@dataclass(frozen=True)
class Family:
    """One family of humans.

    Attributes:
        name: Registry key.
        group: "scripted", "misspecified", "adaptive" or "inconsistent".
        build: ``build(graph, **params)`` -> the human model.
        description: One line for docs and reports.
    """

    name: str
    group: str
    build: Callable[..., HumanModel]
    description: str

    @property
    def defaults(self) -> dict[str, Any]:
        """The parameters and their defaults (from the model's function; a new dict)."""
        return dict(self._defaults)

    @cached_property
    def _defaults(self) -> tuple[tuple[str, Any], ...]:
        # The signature once per family: inspecting it was most of a population's draw.
        sig = inspect.signature(self.build)
        return tuple((n, p.default) for n, p in sig.parameters.items()
                     if p.kind == p.KEYWORD_ONLY)


#: The family groups, in order: the Learner's own model family, then the kinds of human it
#: does not assume (docs/humans.md, "Families").
GROUPS: tuple[str, ...] = ("scripted", "misspecified", "adaptive", "inconsistent")
def _check(family: Family) -> None:
    """What :func:`register_family` checks (its docstring)."""
    if family.group not in GROUPS:
        raise ConfigError(f"family {family.name!r}: group {family.group!r} is not one of "
                          f"{', '.join(GROUPS)}", field="family")
    if not callable(family.build):
        raise ConfigError(f"family {family.name!r}: build must be a function "
                          "build(graph, *, params...)", field="family")
    params = list(inspect.signature(family.build).parameters.values())[1:]
    loose = [p.name for p in params if p.kind is not p.KEYWORD_ONLY or p.default is p.empty]
    if loose:
        raise ConfigError(f"family {family.name!r}: build's parameters after the graph must be "
                          f"keyword-only with defaults; not so: {', '.join(loose)}",
                          field="family")


#: The families, by name (:func:`register_family` adds one; a
#: :class:`~hri_envs.registry.Registry`).
FAMILIES: Registry[Family] = Registry("human family", Family, field="family", check=_check)


def register_family(family: Family, *, replace: bool = False) -> Family:
    """Make a human family known to populations, ``--population NAME`` and the envs'
    ``population=``; returns it. docs/extending.md, "A human family", walks through it.

    Args:
        family: The family.
        replace: Replace the family registered under its name (otherwise refused).

    Raises:
        ConfigError: ``family`` is not a :class:`Family`, its group is not one of
            :data:`GROUPS`, its builder takes a parameter that is not keyword-only with a
            default, or its name is another family's and ``replace`` is False
            (``field="family"``).
    """
    return FAMILIES.register(family, replace=replace)


for _family in (
    Family("preference", "scripted", _preference,
           "a scripted preference human, optionally passive or Boltzmann"),
    Family("low", "misspecified", misspecified.low_human, "keeps the object low"),
    Family("avoid", "misspecified", misspecified.avoid_human,
           "avoids passing near a support"),
    Family("rotate-low", "misspecified", misspecified.rotate_low_human,
           "rotates the object as low as it can"),
    Family("impatient", "misspecified", misspecified.impatient_human,
           "takes over after the robot waited k times in an episode"),
    Family("follower", "adaptive", adaptive.follower_human,
           "adopts the robot's route after k proposals in a row"),
    Family("trust", "adaptive", adaptive.trust_human,
           "trust rises and falls with the robot's motions; lets a trusted robot lead"),
    Family("wary", "adaptive", adaptive.wary_human,
           "yields to the robot at first, resists more after each wrong motion"),
    Family("fickle", "inconsistent", inconsistent.fickle_human,
           "changes its intention mid-episode at random times"),
    Family("moody", "inconsistent", inconsistent.moody_human,
           "changes its preference at random episodes"),
):
    register_family(_family)


def family_params(family: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The family's parameters: its defaults updated with ``params`` (strings from the command
    line are converted to the default's type).

    Raises:
        ConfigError: (``field="human_params"``) An unknown family or parameter, or a value
            that is not of the parameter's kind.
    """
    if not isinstance(family, str) or family not in FAMILIES:
        raise ConfigError(f"unknown human family {family!r}; allowed: {', '.join(FAMILIES)}",
                          field="human_params")
    defaults = FAMILIES[family].defaults
    out = dict(defaults)
    for name, value in (params or {}).items():
        if name not in defaults:
            raise ConfigError(f"family {family!r} has no parameter {name!r}; its parameters: "
                              f"{', '.join(defaults)}", field="human_params")
        out[name] = _convert(family, name, value, defaults[name])
    return out


def _convert(family: str, name: str, value: Any, default: Any) -> Any:
    if not isinstance(value, str) or isinstance(default, str) or default is None:
        return value
    kind = type(default)
    try:
        return int(value) if kind is int else float(value) if kind is float else value
    except ValueError:
        raise ConfigError(f"family {family!r}: {name} must be a {kind.__name__}, got "
                          f"{value!r}", field="human_params") from None


def check_params(graph: TaskGraph, family: str, params: Mapping[str, Any] | None = None) -> None:
    """Build the family's human once: raises the :class:`ConfigError` of an impossible value
    (``field="human_params"``, the message naming the parameter).
    """
    build_family(graph, family, params)


def build_family(graph: TaskGraph, family: str, params: Mapping[str, Any] | None = None
                 ) -> HumanModel:
    """The human model of ``family`` with ``params`` on ``graph`` (cached for the registered
    scenarios' graphs).

    Raises:
        ConfigError: (``field="human_params"``) See :func:`family_params`; a value the model
            refuses (the message names the parameter).
    """
    full = family_params(family, params)
    return _cached(graph, family, tuple(sorted(full.items())))


@functools.lru_cache(maxsize=512)
def _cached(graph: TaskGraph, family: str, key: tuple[tuple[str, Any], ...]) -> HumanModel:
    """:func:`_build`, once per graph (a graph hashes by identity), family and parameters."""
    return _build(graph, family, dict(key))


def _build(graph: TaskGraph, family: str, params: dict[str, Any]) -> HumanModel:
    try:
        return FAMILIES[family].build(graph, **params)
    except ConfigError as exc:
        raise ConfigError(f"family {family!r}: {exc}", field="human_params") from None
