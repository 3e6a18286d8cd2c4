"""Which humans a study can put in front of its agents, by population name.

``--population NAME`` names a registered population (a scripted one of
:data:`hri_envs.humans.populations.POPULATIONS`, a split such as ``test`` or a mixture of
:data:`hri_envs.humans.splits.MIXTURES`, or a family of
:data:`hri_envs.humans.families.FAMILIES`, whose parameters ``--human-param`` sets);
``recorded:DATASET`` or ``recorded-irl:DATASET``, a human model fitted to a recorded
dataset's training participants (:mod:`hri_bench.data.fit`; docs/people.md); or, in the form
``module:Class``, a human
of your own: a :class:`~hri_envs.humans.protocol.BatchHuman` subclass, made once per batch of
runs as ``Class(graph, n_runs)``, or a :class:`~hri_envs.humans.protocol.Human` subclass,
made once per run (with ``graph=`` if its constructor takes it). Each run's human draws
from the generator the study hands it (``(seed, run, 1)``), so results do not depend on
``--jobs``.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from typing import Any

from hri_bench.core.imports import import_class
from hri_bench.data.fit import is_recorded, recorded_human, validate_recorded
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchedHumans, BatchHuman, Human
from hri_envs.humans.splits import population
from hri_envs.humans.tables import TableHumans
from hri_envs.task.graph import TaskGraph

__all__ = ["custom_human", "is_custom", "validate_population"]


def is_custom(name: str | None) -> bool:
    """Whether a population name is a human of the protocol from outside
    :data:`~hri_envs.humans.populations.POPULATIONS`: a ``module:Class`` of the user's, or
    a model fitted to recordings (``recorded:DATASET``).
    """
    return isinstance(name, str) and ":" in name


def _load(spec: str) -> type[Human] | type[BatchHuman]:
    cls: type[Human] | type[BatchHuman] = import_class(spec, "human", "population",
                                                       (Human, BatchHuman))
    return cls


def validate_population(name: Any, scenario: str, params: Mapping[str, Any] | None = None
                        ) -> None:
    """Raise a :class:`ConfigError` (field ``population``, or ``human_params`` for a family's
    parameters) unless ``name`` is a population of ``scenario`` or an importable human class.
    """
    if not isinstance(name, str):
        raise ConfigError(f"population must be a name, got {name!r}", field="population")
    if is_recorded(name):
        if params:
            raise ConfigError("--human-param sets a family's parameters; a recorded population "
                              "takes none", field="human_params")
        validate_recorded(name, scenario)
    elif is_custom(name):
        if params:
            raise ConfigError("--human-param sets a family's parameters; a human of your own "
                              "takes none", field="human_params")
        _load(name)
    else:
        population(name, scenario, params)


def custom_human(spec: str, graph: TaskGraph, runs: Sequence[int]) -> BatchHuman:
    """The human ``module:Class`` (or ``recorded:DATASET``) for a batch of ``runs``."""
    if is_recorded(spec):
        return TableHumans(recorded_human(spec, graph.name), len(runs))
    cls = _load(spec)
    if issubclass(cls, BatchHuman):
        return cls(graph, len(runs))
    single: type[Human] = cls
    takes_graph = "graph" in inspect.signature(single).parameters
    return BatchedHumans(graph, [single(graph=graph) if takes_graph  # type: ignore[call-arg]
                                 else single() for _ in runs])
