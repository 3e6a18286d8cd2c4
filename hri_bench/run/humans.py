"""Which humans a study can put in front of its agents: its :class:`HumanSpec`.

A study's humans are described as every env's are, by one
:class:`~hri_envs.humans.spec.HumanSpec` (:attr:`~hri_bench.run.study.StudyConfig.human`):
a scripted human (``--preference``, ``--human-passive``, ``--turn-back``,
``--human-rationality``), a registered population (a scripted one of
:data:`hri_envs.humans.populations.POPULATIONS`, a split such as ``test`` or a mixture of
:data:`hri_envs.humans.splits.MIXTURES`, or a family of
:data:`hri_envs.humans.families.FAMILIES`, whose parameters ``--human-param`` sets), or, in
the form ``module:Class``, a human of your own: a
:class:`~hri_envs.humans.protocol.BatchHuman` subclass, made once per batch of runs as
``Class(graph, n_runs)``, or a :class:`~hri_envs.humans.protocol.Human` subclass, made once
per run (with ``graph=`` if its constructor takes it). Each run's human draws from the
generator the study hands it (``(seed, run, 1)``), so results do not depend on ``--jobs``.

This module adds the benchmark's own kind of human to every spec:
``recorded:DATASET`` or ``recorded-irl:DATASET``, a human model fitted to a recorded
dataset's training participants (:mod:`hri_bench.data.fit`; docs/people.md), registered as
a :class:`~hri_envs.humans.spec.PopulationKind`.
"""

from __future__ import annotations

from typing import Any

from hri_bench.data.fit import (
    PREFIXES,
    is_recorded,
    recorded_human,
    recorded_info,
    validate_recorded,
)
from hri_envs.humans.spec import HumanSpec, PopulationKind, register_population_kind
from hri_envs.task.graph import TaskGraph

__all__ = ["custom_population_info", "is_custom", "population_changes"]


for _prefix in PREFIXES:
    register_population_kind(PopulationKind(
        _prefix, "a human model fitted to a recorded dataset's training participants",
        recorded_human, validate_recorded))


def is_custom(name: str | None) -> bool:
    """Whether a population name is a human from outside the registered populations: a
    ``module:Class`` of the user's, or a model fitted to recordings (``recorded:DATASET``).
    """
    return name is not None and HumanSpec(population=name).kind in ("class", "prefixed")


def custom_population_info(name: str, graph: TaskGraph) -> dict[str, Any]:
    """The ``population_info`` of a human from outside the registered populations: a
    recorded dataset's has its content hash (:func:`hri_bench.data.fit.recorded_info`), so
    that a study replayed after the recordings changed says so (:func:`population_changes`);
    a ``module:Class`` has none.
    """
    if is_recorded(name):
        return recorded_info(name, graph)
    return {"name": name, "version": None, "hash": None, "held_out": None, "members": None}


def population_changes(recorded: Any, current: dict[str, Any] | None) -> list[str]:
    """What differs between the ``population_info`` a study recorded (its summary.json's,
    as read; anything but an object: nothing recorded) and the same population's now: a
    line when its content hash changed, or when a recorded dataset's was not recorded.
    """
    if current is None or current.get("hash") is None:
        return []
    name = current["name"]
    then = recorded.get("hash") if isinstance(recorded, dict) else None
    if then is None:
        return [f"population {name!r}: the replayed study recorded no content hash for it "
                f"(now {current['hash']}); if its data changed since, so do the results"]
    if then != current["hash"]:
        what = "recorded dataset's finished sessions" if is_recorded(name) else "population"
        return [f"population {name!r}: the {what} changed since the replayed study "
                f"(content {then} then, {current['hash']} now); its results will differ"]
    return []
