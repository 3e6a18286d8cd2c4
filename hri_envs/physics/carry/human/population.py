"""Frozen populations of physical humans: ``train``, ``validation`` and ``test`` per scenario.

The continuous envs' human is a :class:`~hri_envs.physics.carry.human.intention.HumanParams` (the
whole
arm's strength, stiffness, reaction, hesitation, grip, speed, preference and body size).
A :class:`PhysicalPopulation` is a frozen list of them, drawn once from the families of
:mod:`~hri_envs.physics.carry.human.families` with fixed seeds and kept **by value** in
``hri_envs/physics/carry/human/data/physical_populations.json`` (every member's parameters), with
their
behavioural signatures (:mod:`~hri_envs.physics.carry.human.probe`) in ``physical_signatures.npz``
beside it; ``benchmarks/physical_populations.py`` made both and checks them again.
Members are **distinct by behaviour**: a candidate whose signature came within the
tolerance of a member already drawn (in any split of the scenario) was drawn again.

Per scenario ("hanger", "wheel"):

=================  ==============================================================
name               humans
=================  ==============================================================
``train``          256: nominal 96, firm 32, loose 32, weak 48, hesitant 48. Tune and
                   train here.
``validation``     64, the train families (24, 8, 8, 12, 12), other members: pick
                   models and defaults here.
``test``           **the evaluation set**, 128: four tracks of 32, ``nominal``
                   (nominal 16, firm 8, loose 8), ``weak``, ``hesitant`` and
                   ``heldout`` (the ``extremes`` family of body sizes, absent from
                   train and validation). Report it; never tune on it.
``test-<group>``   one track of the test split: ``test-nominal``, ``test-weak``,
                   ``test-hesitant``, ``test-heldout`` (the same members, filtered).
``fitted:<path>``  humans fitted to recorded sessions (family ``fitted``), from a
                   population file (:func:`save_population`; made by
                   ``hri-bench dataset fit`` of a physical dataset, docs/people.md).
=================  ==============================================================

A study's runs meet the members in balanced blocks (every member once per block of
``len(members)`` runs, in an order drawn from ``(seed, block, 7)``, as the graph humans'
:class:`~hri_envs.humans.splits.MixtureSpec`); an env that draws a human at every reset
takes one uniformly (:meth:`PhysicalPopulation.draw`). :meth:`PhysicalPopulation.
content_hash` (SHA-256 of the scenario, the name, the seeding rule and every member's
family and parameters) says which humans a result met.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.families import FAMILIES
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["DATA_FILE", "FILE_SCHEMA", "FITTED_PREFIX", "SCENARIOS", "SEEDING",
           "SIGNATURE_FILE", "SPLITS", "PhysicalMember", "PhysicalPopulation",
           "fitted_population", "params_dict", "physical_population", "population_names",
           "save_population"]

SCENARIOS: tuple[str, ...] = ("hanger", "wheel")
#: Each split's make-up: {split: {family: members}}.
SPLITS: dict[str, dict[str, int]] = {
    "train": {"nominal": 96, "firm": 32, "loose": 32, "weak": 48, "hesitant": 48},
    "validation": {"nominal": 24, "firm": 8, "loose": 8, "weak": 12, "hesitant": 12},
    "test": {"nominal": 16, "firm": 8, "loose": 8, "weak": 32, "hesitant": 32,
             "extremes": 32},
}
SEEDING = ("study: run r meets member default_rng([seed, r // size, 7]).permutation(size)"
           "[r % size]; env: rng.integers(size)")
DATA_FILE = "physical_populations.json"
#: A population file's schema, and the prefix of the names that load one.
FILE_SCHEMA = "hri-envs/physical-population/1"
FITTED_PREFIX = "fitted:"
SIGNATURE_FILE = "physical_signatures.npz"
_DEFAULTS = dataclasses.asdict(HumanParams())


@dataclass(frozen=True)
class PhysicalMember:
    """One human of a population.

    Attributes:
        params: The human (what ``CarrySim.reset(..., human=params)`` takes).
        family: Its family (:data:`~hri_envs.physics.carry.human.families.FAMILIES`); group: its
            track.
        label: A short readable name: ``split/family-k (sex, stature, mass)``.
        fingerprint: The first 16 hex digits of the SHA-256 of its parameters.
        row: Its row in the scenario's signature array.
    """

    params: HumanParams
    family: str
    group: str
    label: str
    fingerprint: str
    row: int


def params_dict(params: HumanParams) -> dict[str, Any]:
    """The parameters that differ from :class:`HumanParams`'s defaults (JSON-ready)."""
    return {k: v for k, v in dataclasses.asdict(params).items() if v != _DEFAULTS[k]}


def _sha256(doc: Any) -> str:
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


class PhysicalPopulation:
    """A frozen list of physical humans of one scenario.

    Args:
        name: The population's name.
        graph: The scenario's task graph.
        entries: The members with their family, label, fingerprint.

    Attributes:
        name: The population's name; graph: the scenario's task graph; scenario: its name,
            "hanger" or "wheel" (what the hash and the files record).
        entries: The members with their family, label, fingerprint.
        members: (N,) their :class:`HumanParams`; families, labels, fingerprints: (N,) each
            member's.
    """

    def __init__(self, name: str, graph: TaskGraph, entries: tuple[PhysicalMember, ...]
                 ) -> None:
        self.name, self.graph, self.entries = name, graph, entries
        self.scenario = graph.name
        self.members = tuple(e.params for e in entries)
        self.families = tuple(e.family for e in entries)
        self.labels = tuple(e.label for e in entries)
        self.fingerprints = tuple(e.fingerprint for e in entries)

    def __len__(self) -> int:
        return len(self.entries)

    def __repr__(self) -> str:
        return (f"PhysicalPopulation({self.name!r}, {self.scenario!r}, {len(self)} members, "
                f"{self.content_hash()[:12]})")

    def content_hash(self) -> str:
        """SHA-256 of the scenario, the name, the seeding and every member's family and
        parameters, in order.
        """
        return _sha256({"kind": "physical", "scenario": self.scenario, "name": self.name,
                        "seeding": SEEDING,
                        "members": [[e.family, params_dict(e.params)] for e in self.entries]})

    def member_index(self, seed: int, run: int) -> int:
        """Run ``run``'s member: every member once per block of ``len(members)`` runs, in
        the order of a permutation drawn from ``(seed, block, 7)``.
        """
        block, slot = divmod(int(run), len(self.entries))
        order = np.random.default_rng([int(seed), block, 7]).permutation(len(self.entries))
        return int(order[slot])

    def draw(self, rng: np.random.Generator) -> HumanParams:
        """A member drawn uniformly with ``rng`` (one integer; for an env, per reset)."""
        return self.members[int(rng.integers(len(self.entries)))]

    def groups(self) -> dict[str, tuple[int, ...]]:
        """{family group (a test track): the indices of its members}, in the families'
        order.
        """
        out: dict[str, list[int]] = {}
        for i, e in enumerate(self.entries):
            out.setdefault(e.group, []).append(i)
        return {g: tuple(v) for g, v in out.items()}

    def signatures(self) -> np.ndarray:
        """(N, P, W, 9) the members' behavioural signatures as committed
        (:func:`~hri_envs.physics.carry.human.probe.signature`).
        """
        if any(e.row < 0 for e in self.entries):
            raise ConfigError(f"{self.name} has no committed signatures (fitted humans)",
                              field="population")
        return _signatures()[self.scenario][[e.row for e in self.entries]]


def population_names() -> tuple[str, ...]:
    """Every population name a scenario has."""
    groups = dict.fromkeys(FAMILIES[f].group for f in SPLITS["test"])
    return (*SPLITS, *(f"test-{g}" for g in groups))


def physical_population(name: str, scenario: TaskGraph | str) -> PhysicalPopulation:
    """The frozen population ``name`` of ``scenario`` (module docstring): its task graph, or
    a registered scenario's name (resolved here).

    Raises:
        ConfigError: An unknown scenario (``field="scenario"``), one without physical
            populations or an unknown name (``field="population"``), listing the allowed
            ones.
    """
    graph = as_graph(scenario)
    if graph.name not in SCENARIOS:
        raise ConfigError(f"no physical populations for scenario {graph.name!r}; allowed: "
                          f"{', '.join(SCENARIOS)}", field="population")
    if isinstance(name, str) and name.startswith(FITTED_PREFIX):
        return _load(name, graph)
    names = population_names()
    if name not in names:
        raise ConfigError(f"unknown physical population {name!r}; allowed: "
                          f"{', '.join(names)}", field="population")
    split, _, group = name.partition("-")
    entries = _entries(graph, split)
    if group:
        entries = tuple(e for e in entries if e.group == group)
    return PhysicalPopulation(name, graph, entries)


def fitted_population(name: str, graph: TaskGraph, members: Sequence[HumanParams],
                      labels: Sequence[str]) -> PhysicalPopulation:
    """A population of fitted humans (family and group ``fitted``) of ``graph``'s scenario,
    in the given order.
    """
    entries = tuple(
        PhysicalMember(p, "fitted", "fitted", label,
                       _sha256(params_dict(p))[:16], -1)
        for p, label in zip(members, labels, strict=True))
    if not entries:
        raise ConfigError(f"population {name} has no members", field="population")
    return PhysicalPopulation(name, graph, entries)


def save_population(path: str | os.PathLike[str], scenario: TaskGraph | str,
                    members: Sequence[HumanParams], labels: Sequence[str], *,
                    source: Mapping[str, Any] | None = None) -> Path:
    """Write fitted humans of ``scenario`` (its task graph, or a registered scenario's
    name, resolved here) as a population file (:data:`FILE_SCHEMA`, JSON: the scenario's
    name, each member's label and parameters by value, and where they came from); the name
    ``fitted:<path>`` loads it. Returns the path.
    """
    graph = as_graph(scenario)
    if graph.name not in SCENARIOS:
        raise ConfigError(f"no physical populations for scenario {graph.name!r}; allowed: "
                          f"{', '.join(SCENARIOS)}", field="population")
    fitted_population("fitted", graph, members, labels)  # checks: not empty, paired
    doc = {"schema": FILE_SCHEMA, "scenario": graph.name, "source": dict(source or {}),
           "members": [{"label": label, "params": params_dict(p)}
                       for p, label in zip(members, labels, strict=True)]}
    out = Path(path)
    out.write_text(json.dumps(doc, indent=1, sort_keys=True, allow_nan=False) + "\n")
    return out


def _load(name: str, graph: TaskGraph) -> PhysicalPopulation:
    """The population file ``name`` points at (``fitted:<path>``), of ``graph``'s scenario."""
    path = Path(name[len(FITTED_PREFIX):])
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise ConfigError(f"population {name}: cannot read {path} as a population file "
                          f"({exc})", field="population") from None
    if not isinstance(doc, dict) or doc.get("schema") != FILE_SCHEMA:
        raise ConfigError(f"population {name}: {path} is not a {FILE_SCHEMA} file",
                          field="population")
    if doc.get("scenario") != graph.name:
        raise ConfigError(f"population {name} holds {doc.get('scenario')!r} humans, not "
                          f"{graph.name!r}", field="population")
    members = doc.get("members") or []
    return fitted_population(name, graph, [HumanParams.of(m["params"]) for m in members],
                             [str(m["label"]) for m in members])


@functools.cache
def _document() -> dict[str, Any]:
    text = resources.files(__package__).joinpath("data", DATA_FILE).read_text()
    doc: dict[str, Any] = json.loads(text)
    return doc


@functools.cache
def _signatures() -> dict[str, np.ndarray]:
    path = resources.files(__package__).joinpath("data", SIGNATURE_FILE)
    with resources.as_file(path) as p, np.load(p, allow_pickle=False) as npz:
        return {k: npz[k].astype(float) for k in npz.files}


@functools.cache
def _entries(graph: TaskGraph, split: str) -> tuple[PhysicalMember, ...]:
    doc = _document()["scenarios"][graph.name]  # the data file is keyed by name
    row = sum(len(doc[s]) for s in list(SPLITS)[:list(SPLITS).index(split)])
    out = []
    for i, m in enumerate(doc[split]):
        params = HumanParams.of(m["params"])
        out.append(PhysicalMember(params, m["family"], FAMILIES[m["family"]].group,
                                  m["label"], m["fingerprint"], row + i))
    return tuple(out)
