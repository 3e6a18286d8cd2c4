"""One frozen description of the human partner, and the one factory that seats it.

A :class:`HumanSpec` says who the human is, whatever runs it: the robot envs, the parallel
and vector envs, the JAX env, a study, ``hri-bench serve``. It is one of

* **a scripted human**: a preference (the scenario's default when None), optionally passive,
  turning back halfway, Boltzmann (``rationality``);
* **a population**: a scripted population, a frozen split or mixture, or a family (with its
  ``params``), by name (:func:`hri_envs.humans.splits.population`): a new member per
  episode in an env, each run its own member in a study;
* **a human of your own**: ``module:Class``, a :class:`~hri_envs.humans.protocol.Human`
  (one per stream) or :class:`~hri_envs.humans.protocol.BatchHuman` subclass;
* **a prefixed kind** registered by a package above this one
  (:func:`register_population_kind`; ``hri_bench`` registers ``recorded:DATASET``, a model
  fitted to recorded people);

and, for the physical envs, its **body** (:class:`HumanBody`: a preset and parameters,
plain data that the physics layer checks and turns into its own human: the continuous
envs' :class:`~hri_envs.physics.carry.human.intention.HumanParams`, the Panda backend's ``human_*``
physics options). An env that cannot honour a field of a spec refuses it
(:meth:`HumanSpec.refuse`), never ignores it.

:meth:`HumanSpec.seat` builds an env's seat; :meth:`HumanSpec.run_draws` and
:meth:`HumanSpec.custom` a study's humans, through the maker of their kind that
:func:`hri_envs.humans.runs.study_humans` reads from the spec once. The envs' flat
keywords (``preference=``, ``human_passive=``, ...) are a shorthand for a spec
(:meth:`HumanSpec.from_kwargs`).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans
from hri_envs.humans.populations import (
    POPULATIONS,
    HumanDraw,
    human_sequence,
)
from hri_envs.humans.protocol import BatchedHumans, BatchHuman, Human
from hri_envs.humans.rational import rational_human, validate_rationality
from hri_envs.humans.scripted import ScriptedHuman, check_probability, preference_human
from hri_envs.humans.splits import draw_human, population, population_seat
from hri_envs.humans.tables import TableHumans
from hri_envs.imports import import_class
from hri_envs.registry import Registry
from hri_envs.task.graph import TaskGraph

__all__ = ["HUMAN_KEYWORDS", "POPULATION_KINDS", "HumanBody", "HumanSpec", "PopulationKind",
           "register_population_kind"]

#: The envs' flat keywords for the human, and the :class:`HumanSpec` field each sets.
HUMAN_KEYWORDS: dict[str, str] = {"preference": "preference", "human_passive": "passive",
                                  "turn_back": "turn_back", "human_rationality": "rationality",
                                  "population": "population", "human_params": "params"}


@dataclass(frozen=True)
class PopulationKind:
    """Humans named ``PREFIX...`` by a package above ``hri_envs`` (``recorded:DATASET``).

    Attributes:
        prefix: The names' prefix, e.g. ``"recorded:"``.
        description: One line for help texts.
        build: ``build(name, graph)`` -> the human model every run and row shares.
        check: ``check(name, graph)`` raises a :class:`ConfigError` for a bad name;
            None: ``build`` decides.
    """

    prefix: str
    description: str
    build: Callable[[str, TaskGraph], ScriptedHuman | FiniteStateHuman]
    check: Callable[[str, TaskGraph], None] | None = None


def _check_kind(kind: PopulationKind) -> None:
    if not kind.prefix.endswith(":"):
        raise ConfigError(f"a population kind's prefix ends with ':', got {kind.prefix!r}",
                          field="population")


#: The prefixed kinds, by prefix (:func:`register_population_kind`; a
#: :class:`~hri_envs.registry.Registry`).
POPULATION_KINDS: Registry[PopulationKind] = Registry(
    "population kind", PopulationKind, field="population", check=_check_kind, key="prefix")


def register_population_kind(kind: PopulationKind, *, replace: bool = False
                             ) -> PopulationKind:
    """Make humans named ``kind.prefix + ...`` known to every :class:`HumanSpec`; returns it.

    Args:
        kind: The kind.
        replace: Replace the kind registered under its prefix (otherwise refused).

    Raises:
        ConfigError: ``kind`` is not a :class:`PopulationKind`, its prefix does not end with
            ``:``, or it is another kind's and ``replace`` is False.
    """
    return POPULATION_KINDS.register(kind, replace=replace)


def _kind_of(name: str) -> PopulationKind | None:
    return next((k for p, k in POPULATION_KINDS.items() if name.startswith(p)), None)


@dataclass(frozen=True)
class HumanBody:
    """The physical human of a :class:`HumanSpec`, for the physical envs (plain data).

    What the names mean is the env's (the physics layer checks them and refuses what it
    does not know, with ``field="human"``):

    * the continuous envs (``*PandaContinuous-*``): ``preset`` one of
      :data:`~hri_envs.physics.carry.human.intention.HUMAN_PRESETS` ("default", "weak", "hesitant",
      "firm"), ``params`` the fields of :class:`~hri_envs.physics.carry.human.intention.HumanParams`
      (``strength``, ``stiffness``, ``hesitation_s``, ``reaction_s``, ``grip_force_n``,
      ``speed``, ``sex``, ``stature_m``, ``body_mass_kg``, ``drive``);
    * the Panda backends of the discrete ids (``backend="mujoco"``, ``"mjwarp"``):
      ``preset`` a human preset of the physics options ("weak-human"), ``params`` the
      human's physics options (``human_stiffness``, ``human_force``, ``human_noise``,
      ``human_delay_s``, ``human_mass``, ``human_grip_force``; docs/physics.md).

    Attributes:
        preset: A named body (None: the env's default).
        params: Values overriding the preset's, as (name, value) pairs (a mapping is
            accepted and sorted by name).
    """

    preset: str | None = None
    params: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.preset is not None and not (isinstance(self.preset, str) and self.preset):
            raise ConfigError(f"a human body's preset must be a name or None, got "
                              f"{self.preset!r}", field="human")
        if not isinstance(self.params, tuple):
            object.__setattr__(self, "params", _pairs(self.params, "a human body's params"))

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> HumanBody:
        """The body a mapping describes: its ``preset`` key and the other keys' values (the
        continuous envs' ``human={...}`` shorthand).
        """
        rest = {k: v for k, v in values.items() if k != "preset"}
        return cls(values.get("preset"), _pairs(rest, "a human body's params"))

    def values(self) -> dict[str, Any]:
        """The body as one mapping: ``preset`` (when set) and the params."""
        preset = {} if self.preset is None else {"preset": self.preset}
        return {**preset, **dict(self.params)}


@dataclass(frozen=True)
class HumanSpec:
    """Who the human partner is (module docstring).

    Attributes:
        preference: The scripted human's preference (None: the scenario's default).
        passive: Its probability of waiting in a step (a scripted population: added).
        turn_back: Its probability per episode of turning back halfway.
        rationality: β of a Boltzmann version (``inf``: deterministic).
        population: A population, split, mixture or family name, ``module:Class``, or a
            registered prefixed kind; None: the scripted human above.
        params: A family's parameters as (name, value) pairs.
        body: The physical human (:class:`HumanBody`, or a mapping of its ``preset`` and
            params) of the physical envs; None: the env's default body.
    """

    preference: str | None = None
    passive: float = 0.0
    turn_back: float = 0.0
    rationality: float = math.inf
    population: str | None = None
    params: tuple[tuple[str, Any], ...] = ()
    body: HumanBody | None = None

    def __post_init__(self) -> None:
        for name, field in (("population", "population"), ("preference", "preference")):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, str) and value):
                raise ConfigError(f"{name} must be a name (a non-empty string) or None, got "
                                  f"{value!r}", field=field)
        if not isinstance(self.params, tuple):
            object.__setattr__(self, "params", _pairs(self.params))
        if isinstance(self.body, Mapping):
            object.__setattr__(self, "body", HumanBody.of(self.body))
        elif self.body is not None and not isinstance(self.body, HumanBody):
            raise ConfigError(f"body must be a HumanBody, a mapping of its preset and params, "
                              f"or None, got {self.body!r}", field="human")

    @classmethod
    def from_kwargs(cls, **keywords: Any) -> HumanSpec:
        """The spec the envs' flat keywords (:data:`HUMAN_KEYWORDS`) describe.

        Raises:
            TypeError: A keyword that is not one of them (as a function would).
        """
        unknown = sorted(set(keywords) - set(HUMAN_KEYWORDS))
        if unknown:
            raise TypeError(f"unexpected keyword argument(s) {', '.join(map(repr, unknown))}; "
                            f"the human's are {', '.join(HUMAN_KEYWORDS)}")
        fields = {HUMAN_KEYWORDS[k]: v for k, v in keywords.items()}
        if "params" in fields:
            fields["params"] = _pairs(fields["params"])
        return cls(**fields)

    def refuse(self, env: str, takes: Sequence[str], why: str = "",
               field: str | None = None) -> HumanSpec:
        """``self`` if it sets no field but ``takes`` (the others at their defaults).

        Args:
            env: The env, for the message (e.g. "the continuous env").
            takes: The fields the env honours.
            why: Why the others cannot apply (appended to the message).
            field: The error's ``field`` (None: the field's flat keyword below).

        Raises:
            ConfigError: The first field set that ``env`` cannot honour, named (``field``:
                its flat keyword, e.g. ``"human_rationality"``, or ``"human"`` for
                ``body``).
        """
        keyword = {v: k for k, v in HUMAN_KEYWORDS.items()}
        for each in dataclasses.fields(self):
            value = getattr(self, each.name)
            if each.name not in takes and value != each.default:
                raise ConfigError(
                    f"{env} cannot honour HumanSpec.{each.name}={value!r}{why}; it takes "
                    f"{', '.join(takes) or 'no field'} of a HumanSpec",
                    field=field or keyword.get(each.name, "human"))
        return self

    def bodiless(self, env: str) -> HumanSpec:
        """``self`` if it has no :attr:`body` (an env of the abstract graph, or a seat whose
        env made its physics already).

        Raises:
            ConfigError: (``field="human"``) A body, naming ``env``.
        """
        return self.refuse(env, [f.name for f in dataclasses.fields(self) if f.name != "body"],
                           " (a body is the physical human of the Panda backends and the "
                           "continuous envs, set when such an env is made)")

    @property
    def kind(self) -> str:
        """"scripted", "population" (a name of :mod:`hri_envs.humans`), "prefixed" (a
        registered :class:`PopulationKind`) or "class" (``module:Class``).
        """
        if self.population is None:
            return "scripted"
        if _kind_of(self.population) is not None:
            return "prefixed"
        return "class" if ":" in self.population else "population"

    @property
    def per_run(self) -> bool:
        """Whether runs (or episodes) meet humans of their own: a population of members."""
        return self.kind == "population"

    def check(self, graph: TaskGraph) -> HumanSpec:
        """``self`` if it describes a human of ``graph``'s scenario.

        Raises:
            ConfigError: A value out of range (``human_passive``, ``turn_back``,
                ``human_rationality``), an unknown or another scenario's population or
                preference (``population``, ``preference``), parameters for what is not a
                family (``human_params``), a class that does not import or is not a human.
        """
        validate_rationality(self.rationality)
        check_probability(self.passive, "human_passive")
        check_probability(self.turn_back, "turn_back")
        kind = self.kind
        if kind == "scripted":
            if self.params:
                raise ConfigError("human_params sets a family's parameters; no population is "
                                  "given", field="human_params")
            preference_human(graph, self.preference)  # an unknown preference raises
            return self
        assert self.population is not None
        if self.params and kind != "population":
            raise ConfigError("human_params sets a family's parameters; "
                              f"{self.population!r} takes none", field="human_params")
        if kind == "prefixed":
            found = _kind_of(self.population)
            assert found is not None
            (found.check or found.build)(self.population, graph)
        elif kind == "class":
            self.human_class()
        else:
            population(self.population, graph, dict(self.params))
        return self

    def human_class(self) -> type[Human] | type[BatchHuman]:
        """The class a ``module:Class`` spec names.

        Raises:
            ConfigError: It does not import, or is neither a Human nor a BatchHuman.
        """
        assert self.population is not None
        cls: type[Human] | type[BatchHuman] = import_class(self.population, "human",
                                                           "population", (Human, BatchHuman))
        return cls

    # ----------------------------------------------------------------- an env's seat
    def seat(self, graph: TaskGraph, n_runs: int = 1) -> BatchHuman:
        """The seat of an env with ``n_runs`` rows: the scripted human in every row, a
        population drawing a new member every episode (:meth:`BatchHuman.draw`), or a
        human of your own (a ``Human`` class: one per row).
        """
        self.check(graph)
        kind = self.kind
        if kind == "scripted":
            return TableHumans(self.scripted(graph), n_runs)
        if kind == "population":
            assert self.population is not None
            return population_seat(graph, self.population, n_runs, dict(self.params))
        return self.custom(graph, n_runs)

    def scripted(self, graph: TaskGraph, preference: str | None = None) -> ScriptedHuman:
        """The scripted human of this spec (``preference`` overrides its own)."""
        human = preference_human(graph, preference or self.preference, passive=self.passive,
                                 turn_back=self.turn_back)
        return rational_human(human, self.rationality)

    def custom(self, graph: TaskGraph, n_rows: int) -> BatchHuman:
        """A prefixed kind's or ``module:Class``'s humans for ``n_rows`` rows (a batch of a
        study's runs, or an env's rows): a ``BatchHuman`` class made once as
        ``Class(graph, n_rows)``, a ``Human`` class once per row (with ``graph=`` if its
        constructor takes it), a prefixed kind's model shared by the rows.
        """
        assert self.population is not None
        found = _kind_of(self.population)
        if found is not None:
            model = found.build(self.population, graph)
            if isinstance(model, FiniteStateHuman):
                return FiniteStateHumans(model, n_rows)
            return TableHumans(model, n_rows)
        cls = self.human_class()
        if issubclass(cls, BatchHuman):
            return cls(graph, n_rows)
        single: type[Human] = cls
        takes_graph = "graph" in inspect.signature(single).parameters
        return BatchedHumans(graph, [single(graph=graph) if takes_graph  # type: ignore[call-arg]
                                     else single() for _ in range(n_rows)])

    # ----------------------------------------------------------------- a study's runs
    def run_draws(self, graph: TaskGraph, seed: int, run: int, episodes: int,
                  preference: str | None = None, drift: int | None = None) -> list[HumanDraw]:
        """Run ``run``'s human in each episode of a study, from ``(seed, run)`` alone: a
        population's member of the run (balanced blocks, :meth:`~hri_envs.humans.splits.
        MixtureSpec.draw`), else the scripted human (``preference`` overrides its own: a
        study cycling through preferences), drifted after ``drift`` episodes.
        """
        draw = draw_human(graph, seed, run, population=self.population,
                          preference=preference or self.preference,
                          rationality=self.rationality, passive=self.passive,
                          turn_back=self.turn_back, params=self.params)
        return human_sequence(graph, draw, seed, run, episodes, drift)

    def info(self) -> dict[str, Any]:
        """The spec as JSON-ready data (infinity as "inf")."""
        out = dataclasses.asdict(self)
        out["params"] = [list(p) for p in self.params]
        if self.body is None:
            del out["body"]  # as before bodies (the studies' records are unchanged)
        else:
            out["body"] = {"preset": self.body.preset,
                           "params": [list(p) for p in self.body.params]}
        if math.isinf(self.rationality):
            out["rationality"] = "inf"
        return out


def _pairs(params: Any, what: str = "human_params") -> tuple[tuple[str, Any], ...]:
    if isinstance(params, Mapping):  # by name (a key that is not a name is refused below)
        params = sorted(params.items(), key=lambda item: str(item[0]))
    if isinstance(params, Sequence) and not isinstance(params, str):
        pairs = [tuple(p) if isinstance(p, Sequence) and not isinstance(p, str) else (p,)
                 for p in params]
        if all(len(p) == 2 and isinstance(p[0], str) for p in pairs):
            return tuple((str(p[0]), p[1]) for p in pairs)
    raise ConfigError(f"{what} must be a mapping or (name, value) pairs, got {params!r}",
                      field="human_params" if what == "human_params" else "human")


#: Whether a name is a scripted population's (kept here so that callers ask the spec).
def is_scripted_population(name: str | None) -> bool:
    """Whether ``name`` is one of :data:`~hri_envs.humans.populations.POPULATIONS`."""
    return name in POPULATIONS
