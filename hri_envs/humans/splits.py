"""Frozen population splits: ``train``, ``validation`` and ``test`` per scenario, and mixtures.

A :class:`MixtureSpec` is a frozen, versioned list of humans: ``members`` humans made once,
with a generator seeded by the spec's ``generator_seed``, from a mixture of family
components (:mod:`hri_envs.humans.families`): each component gets its share of the list by
its weight (largest remainders), each member its parameters drawn uniformly from the
component's choices. A study's runs meet the members in balanced blocks (every member once
per block of ``size`` runs, in an order drawn from ``(seed, block, 7)``:
:meth:`MixtureSpec.draw`); an env draws a member at every reset from its ``np_random``.
The spec's :meth:`~MixtureSpec.content_hash` (SHA-256 of its generator's parameters, its
seeds and the members they give) is recorded in every ``summary.json`` and ``suite.json``:
two results with the same hash met the same humans.

Per scenario (:data:`MIXTURES`):

===================  =================================================================
name                 humans
===================  =================================================================
``train``            scripted families only: any preference, deterministic, passive
                     (0.1–0.3) or Boltzmann (β 5–20). Tune and train here.
``validation``       the train families, other members: pick models and defaults here.
``test``             **the evaluation set**: the train families (a fifth of it) and
                     families absent from train — misspecified (low, avoid, rotate-low,
                     impatient), adaptive (follower, trust, wary) and inconsistent
                     (fickle, moody). Report it; never tune a default on it.
``test-<group>``     the test split's members of one group: ``test-misspecified``,
                     ``test-adaptive``, ``test-inconsistent``, ``test-scripted`` (the same
                     draws, filtered; part of the evaluation set).
===================  =================================================================

A family's name is a population too (``--population low``): every run meets that family
with its default parameters, changed by ``--human-param NAME=VALUE``
(:func:`family_population`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.distance import TOLERANCE, same_behaviour
from hri_envs.humans.families import FAMILIES, GROUPS, check_params, family_params
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans, as_model
from hri_envs.humans.populations import (
    POPULATIONS,
    HumanDraw,
    PopulationHumans,
    PopulationSpec,
    build_human,
    population_spec,
)
from hri_envs.humans.protocol import BatchHuman, Rows, all_rows
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import NamedScenario, as_graph, spec_of

__all__ = [
    "ALL_PREFERENCES",
    "ALL_SUPPORTS",
    "FROZEN_PATH",
    "MIXTURES",
    "SPLITS",
    "Component",
    "MixtureHumans",
    "MixtureSpec",
    "SPLITS_V2",
    "SPLITS_V3",
    "family_population",
    "frozen_document",
    "member_fingerprint",
    "draw_human",
    "population",
    "population_hash",
    "population_names",
    "population_seat",
]

#: A choice that stands for every preference of the scenario.
ALL_PREFERENCES = "<preferences>"
#: A choice that stands for every support of the scenario (by name).
ALL_SUPPORTS = "<supports>"
#: The split names.
SPLITS: tuple[str, ...] = ("train", "validation", "test")
#: How a run's member is drawn (part of the content hash).
SEEDING = ("study: run r meets member default_rng([seed, r // size, 7]).permutation(size)"
           "[r % size]; env: default_rng(reset).integers(size)")


@dataclass(frozen=True)
class Component:
    """One family in a mixture.

    Attributes:
        family: A family of :data:`~hri_envs.humans.families.FAMILIES`.
        weight: Its share of the members (weights are normalised).
        choices: Per parameter, the values drawn uniformly (``ALL_PREFERENCES``,
            ``ALL_SUPPORTS`` expand to the scenario's); the others take their defaults.
    """

    family: str
    weight: float
    choices: tuple[tuple[str, tuple[Any, ...]], ...] = ()


@dataclass(frozen=True)
class MixtureSpec(NamedScenario):
    """A frozen, versioned population: a list of members drawn once from a mixture.

    Attributes:
        name: Registry key (with :attr:`scenario`).
        scenario: The scenario it is for.
        version: Bumped whenever anything below changes (the hash changes with it).
        description: One line for help texts and reports.
        members: How many humans the list holds.
        generator_seed: The seed the members are drawn with.
        components: The mixture.
        held_out: An evaluation set: never used to tune defaults.
        group: Keep only the members of this family group (a view of a split: the same
            draws, filtered), or None for all.
        distinct: Every member is a different human: a draw whose model
            (:func:`member_fingerprint`) equals an earlier member's, or a member's of a
            split named in ``exclude``, is drawn again (split version 2).
        exclude: Splits (names, same scenario) whose humans this one must not hold.
        tolerance: With ``distinct``: 0 compares models by fingerprint (split version 2);
            above 0, two humans are the same when their
            :func:`~hri_envs.humans.distance.behaviour_distance` is below it (split
            version 3).
    """

    name: str
    scenario: str
    version: str
    description: str
    members: int
    generator_seed: int
    components: tuple[Component, ...]
    held_out: bool = False
    group: str | None = None
    distinct: bool = False
    exclude: tuple[str, ...] = ()
    tolerance: float = 0.0

    @property
    def scenarios(self) -> tuple[str, ...]:
        """The scenarios it applies to (one)."""
        return (self.scenario,)


    @property
    def size(self) -> int:
        """How many humans the list holds (after the group's filter); a ``distinct`` split
        holds exactly its components' allotments, so its size needs no drawing.
        """
        if self.distinct:
            return sum(count for comp, count in zip(
                self.components, _allocate(self.components, self.members), strict=True)
                if self.group is None or FAMILIES[comp.family].group == self.group)
        return len(self.member_draws)

    @cached_property
    def member_draws(self) -> tuple[HumanDraw, ...]:
        """The members, as draws (a family and its parameters), in list order.

        Raises:
            ConfigError: A ``distinct`` split whose component cannot give as many different
                humans as it is allotted (its choices allow too few models).
        """
        frozen = _frozen().get(self.frozen_key()) if self.tolerance else None
        if frozen is not None and frozen["generator"] == self.generator_hash():
            out = [HumanDraw(None, family=f, params=tuple((k, v) for k, v in params))
                   for f, params in frozen["members"]]
            return tuple(d for d in out if self.group is None
                         or FAMILIES[str(d.family)].group == self.group)
        return self.draw_members()

    def draw_members(self) -> tuple[HumanDraw, ...]:
        """:attr:`member_draws`, drawn (not read from :data:`FROZEN_PATH`)."""
        graph = self.graph
        rng = np.random.default_rng(self.generator_seed)
        taken = self._excluded_fingerprints() if self.distinct else None
        kept = _Kept(graph, self._excluded_models(), self.tolerance) if self.tolerance else None
        out = []
        for comp, count in zip(self.components, _allocate(self.components, self.members),
                               strict=True):
            tries = 0
            got = 0
            while got < count:
                params = []
                for name, values in comp.choices:
                    options = _expand(graph, values)
                    params.append((name, options[int(rng.integers(len(options)))]))
                draw = HumanDraw(None, family=comp.family, params=tuple(params))
                if taken is not None:
                    tries += 1
                    if tries > _MAX_TRIES * count:
                        raise ConfigError(
                            f"split {self.name!r} ({self.scenario}): the {comp.family} "
                            f"component gave {got} different humans in {tries - 1} draws, "
                            f"it is allotted {count}: widen its choices", field="population")
                    if kept is not None:
                        if not kept.add(draw):
                            continue
                    else:
                        fingerprint = member_fingerprint(graph, draw)
                        if fingerprint in taken:
                            continue
                        taken.add(fingerprint)
                out.append(draw)
                got += 1
        if self.group is not None:
            out = [d for d in out if d.family is not None
                   and FAMILIES[d.family].group == self.group]
        return tuple(out)

    def frozen_key(self) -> str:
        """The key of the whole split's members in :data:`FROZEN_PATH`."""
        return f"{self.scenario}|{self.version}|{self.generator_seed}"

    def generator_hash(self) -> str:
        """SHA-256 of what draws the whole split (every field but the name, description and
        group): a frozen member list is used only when it matches.
        """
        spec = {k: v for k, v in dataclasses.asdict(self).items()
                if k not in ("name", "description", "group")}
        return _sha256(_jsonable(spec))

    def _excluded_models(self) -> list[Any]:
        """The models of the members of the splits in :attr:`exclude` (same scenario)."""
        graph = self.graph
        return [as_model(build_human(graph, d)) for name in self.exclude
                for d in MIXTURES[(name, self.scenario)].member_draws]

    def _excluded_fingerprints(self) -> set[str]:
        """The models of the members of the splits in :attr:`exclude` (same scenario)."""
        graph = self.graph
        out: set[str] = set()
        for name in self.exclude:
            out |= {member_fingerprint(graph, d)
                    for d in MIXTURES[(name, self.scenario)].member_draws}
        return out

    def fingerprints(self) -> tuple[str, ...]:
        """Each member's model fingerprint (:func:`member_fingerprint`), in list order: the
        content hash of the human itself (two members with one fingerprint act alike).
        """
        graph = self.graph
        return tuple(member_fingerprint(graph, d) for d in self.member_draws)

    def draw(self, graph: TaskGraph, seed: int, run: int) -> HumanDraw:
        """Run ``run``'s member (on ``graph``, its scenario's), balanced: runs
        ``b·size .. (b+1)·size - 1`` meet every member once, in the order of a permutation
        drawn from ``(seed, b, 7)`` (``b`` the run's block), so a study's runs depend on
        ``(seed, run)`` only and a whole number of blocks weighs every member alike (the
        estimate of the population's mean then carries no sampling error of its make-up).
        """
        self._check_scenario(graph)
        return self.member_draws[self.member_index(seed, run)]

    def member_index(self, seed: int, run: int) -> int:
        """The index in :attr:`member_draws` of run ``run``'s member (:meth:`draw`)."""
        block, slot = divmod(int(run), self.size)
        order = np.random.default_rng([int(seed), block, 7]).permutation(self.size)
        return int(order[slot])

    def sample(self, graph: TaskGraph, rng: np.random.Generator) -> HumanDraw:
        """A member (on ``graph``, its scenario's) drawn uniformly with ``rng`` (one integer;
        the envs, per reset).
        """
        self._check_scenario(graph)
        return self.member_draws[int(rng.integers(self.size))]

    def _check_scenario(self, graph: TaskGraph) -> None:
        if graph.name != self.scenario:
            raise ConfigError(f"population {self.name!r} is for the {self.scenario}, not "
                              f"{graph.name!r}", field="population")

    def content_hash(self) -> str:
        """SHA-256 of the generator's parameters, its seeds and the members they give (every
        field but the description, the seeding of the runs, and the member list).
        """
        spec = {k: v for k, v in dataclasses.asdict(self).items() if k != "description"}
        for k, default in (("distinct", False), ("exclude", ()),  # version 1: as it was
                           ("tolerance", 0.0)):  # version 2: as it was
            if spec[k] == default:
                del spec[k]
        doc = {"kind": "mixture", "spec": _jsonable(spec),
               "seeding": SEEDING,
               "members": [[d.family, _jsonable(list(d.params))] for d in self.member_draws]}
        return _sha256(doc)


#: A distinct split draws a component's members again at most this many times per member.
_MAX_TRIES = 200
#: Split version 3's members as drawn (comparing every candidate by behaviour takes about a
#: minute per split, so they are drawn once and frozen here, each with the hash of what drew
#: it: :meth:`MixtureSpec.generator_hash`; ``benchmarks/split_distances.py --write`` writes
#: it, and a test draws them again).
FROZEN_PATH = Path(__file__).with_name("splits_v3.json")


@lru_cache(maxsize=1)
def _frozen() -> dict[str, Any]:
    if not FROZEN_PATH.is_file():
        return {}
    doc: dict[str, Any] = json.loads(FROZEN_PATH.read_text())
    return doc


def frozen_document(specs: Sequence[MixtureSpec]) -> dict[str, Any]:
    """:data:`FROZEN_PATH`'s document for the whole splits ``specs``, drawn afresh."""
    return {s.frozen_key(): {"name": s.name, "generator": s.generator_hash(),
                             "members": [[d.family, [list(p) for p in d.params]]
                                         for d in s.draw_members()]}
            for s in specs}


class _Kept:
    """The humans a split version 3 holds so far (and those it excludes), by model: a draw
    is kept when no kept human is the same (:func:`~hri_envs.humans.distance.same_behaviour`
    at ``tolerance``).
    """

    def __init__(self, graph: TaskGraph, excluded: Sequence[Any], tolerance: float) -> None:
        self.graph, self.tolerance = graph, tolerance
        self.models = list(excluded)
        self.refused: set[HumanDraw] = set()  # the kept humans only grow: refused for good

    def add(self, draw: HumanDraw) -> bool:
        if draw in self.refused:
            return False
        model = as_model(build_human(self.graph, draw))
        if any(same_behaviour(model, m, self.tolerance) for m in reversed(self.models)):
            self.refused.add(draw)
            return False
        self.models.append(model)
        return True


def member_fingerprint(graph: TaskGraph, draw: HumanDraw) -> str:
    """The content hash of one human: its model's tables
    (:attr:`~hri_envs.humans.finite_state.FiniteStateHuman.fingerprint`), so two draws with
    different parameters that act alike have one fingerprint.
    """
    return as_model(build_human(graph, draw)).fingerprint


def _allocate(components: Sequence[Component], members: int) -> list[int]:
    """Members per component in proportion to the weights (largest remainders), so that a
    list's make-up is its mixture's, not a sample of it.
    """
    w = np.array([c.weight for c in components], dtype=float)
    share = members * w / w.sum()
    count = np.floor(share).astype(np.int64)
    rest = np.argsort(-(share - count), kind="stable")[:members - int(count.sum())]
    count[rest] += 1
    return count.tolist()


def _expand(graph: TaskGraph, values: tuple[Any, ...]) -> list[Any]:
    out: list[Any] = []
    for v in values:
        if v == ALL_PREFERENCES:
            out += list(spec_of(graph).preferences)
        elif v == ALL_SUPPORTS:
            out += list(graph.support_names)
        else:
            out.append(v)
    return out


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return value


def _sha256(doc: Any) -> str:
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


# --------------------------------------------------------------------------- the registry
_PREFS = ("preference", (ALL_PREFERENCES,))
_SCRIPTED = (
    Component("preference", 2.0, (_PREFS,)),
    Component("preference", 1.0, (_PREFS, ("passive", (0.1, 0.2, 0.3)))),
    Component("preference", 1.0, (_PREFS, ("rationality", (5.0, 10.0, 20.0)))),
)
_MISSPECIFIED = (
    Component("low", 1.0, (("w", (2.0, 4.0, 8.0)), _PREFS)),
    Component("avoid", 1.0, (("support", (ALL_SUPPORTS,)), ("w", (2.0, 4.0)),
                             ("sigma", (0.3, 0.6)), _PREFS)),
    Component("rotate-low", 0.5, (("w", (4.0, 8.0)), _PREFS)),
    Component("impatient", 1.0, (("k", (1, 2, 3)), _PREFS)),
)
_ADAPTIVE = (
    Component("follower", 1.0, (("k", (2, 3)), _PREFS)),
    Component("trust", 1.0, (("passive", (0.4, 0.7)), ("fall", (1, 2)), _PREFS)),
    Component("wary", 1.0, (("levels", (2, 3)), ("forgive", (0, 1)), _PREFS)),
)
_INCONSISTENT = (
    Component("fickle", 1.0, (("hazard", (0.1, 0.2)), ("changes", (1, 2)), _PREFS)),
    Component("moody", 1.0, (("p", (0.2, 0.4)),)),
)


def _grid(low: float, high: float, n: int, *, log: bool = False) -> tuple[float, ...]:
    """``n`` values from ``low`` to ``high`` (geometric with ``log``), rounded to 3 decimals."""
    values = np.geomspace(low, high, n) if log else np.linspace(low, high, n)
    return tuple(float(v) for v in np.round(values, 3))


def _counted(components: Sequence[tuple[str, int, tuple[tuple[str, tuple[Any, ...]], ...]]]
             ) -> tuple[Component, ...]:
    """Components whose weights are their member counts (the allocation is then exact)."""
    return tuple(Component(family, float(count), choices) for family, count, choices in components)


# Split version 2 (suite v3): every member a different human (by its model), none of them a
# train or validation member's, continuous parameters on fine grids so that the wheel's two
# preferences still give enough different humans; each group its own exact share.
_W = ("w", _grid(0.2, 40.0, 60, log=True))


def _v2_groups(scale: int) -> dict[str, tuple[Component, ...]]:
    """The components of a version-2 split per group: ``20 · scale`` members each."""
    def n(count: int) -> int:
        return count * scale

    return {
        "scripted": _counted((
            ("preference", n(10), (_PREFS, ("passive", _grid(0.05, 0.4, 36)))),
            ("preference", n(10), (_PREFS, ("rationality", _grid(3.0, 40.0, 40, log=True)))),
        )),
        "misspecified": _counted((
            ("low", n(2), (_W, _PREFS)),
            ("avoid", n(9), (("support", (ALL_SUPPORTS,)), ("w", _W[1][::4]),
                             ("sigma", (0.15, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0)), _PREFS)),
            ("rotate-low", n(3), (_W, _PREFS)),
            ("impatient", n(6), (("k", tuple(range(1, 16))), _PREFS)),
        )),
        "adaptive": _counted((
            ("follower", n(5), (("k", tuple(range(1, 11))), _PREFS)),
            ("trust", n(8), (("passive", _grid(0.3, 0.9, 25)), ("fall", (1, 2, 3)), _PREFS)),
            ("wary", n(7), (("levels", tuple(range(2, 11))), ("forgive", (0, 1)), _PREFS)),
        )),
        "inconsistent": _counted((
            ("fickle", n(10), (("hazard", _grid(0.05, 0.3, 26)), ("changes", (1, 2, 3)),
                               _PREFS)),
            ("moody", n(10), (("p", _grid(0.1, 0.5, 81)),)),
        )),
    }


def _scaled(components: Sequence[Component], share: float) -> tuple[Component, ...]:
    total = sum(c.weight for c in components)
    return tuple(dataclasses.replace(c, weight=share * c.weight / total) for c in components)


def _mixtures() -> dict[tuple[str, str], MixtureSpec]:
    out: dict[tuple[str, str], MixtureSpec] = {}
    for i, sc in enumerate(("hanger", "wheel")):  # by value: the frozen splits' scenarios
        specs = (
            MixtureSpec("train", sc, "1", "train split: scripted families (any preference; "
                        "deterministic, passive 0.1–0.3 or Boltzmann β 5–20)", 40,
                        1000 + i, _SCRIPTED),
            MixtureSpec("validation", sc, "1", "validation split: the train families, other "
                        "members", 20, 2000 + i, _SCRIPTED),
            MixtureSpec("test", sc, "1", "TEST split (the evaluation set): the train "
                        "families and misspecified, adaptive and inconsistent ones absent "
                        "from train", 64, 3000 + i,
                        _scaled(_SCRIPTED, 0.2) + _scaled(_MISSPECIFIED, 0.3)
                        + _scaled(_ADAPTIVE, 0.3) + _scaled(_INCONSISTENT, 0.2),
                        held_out=True),
        )
        test = specs[-1]
        views = tuple(dataclasses.replace(
            test, name=f"test-{group}", description=f"the test split's {group} members "
            f"({', '.join(f.name for f in FAMILIES.values() if f.group == group)})",
            group=group) for group in GROUPS)
        out.update({(m.name, sc): m for m in specs + views})
        out.update(_mixtures_v2(sc, i))
        out.update(_mixtures_v3(sc, i))
    return out


#: The version-2 splits (suite v3): ``validation-v2`` and ``test-v2`` and their groups.
SPLITS_V2: tuple[str, ...] = ("validation-v2", "test-v2")


def _mixtures_v2(sc: str, i: int) -> dict[tuple[str, str], MixtureSpec]:
    """Split version 2 of one scenario: a validation split with the test split's families
    (other humans: it is where suite v3's power pilot runs) and a test split of 40 different
    humans per group (160), each group a track of suite v3 of its own; neither holds a human
    of ``train`` or ``validation`` (nor the test one of ``validation-v2``).
    """
    out: dict[tuple[str, str], MixtureSpec] = {}
    previous: tuple[str, ...] = ("train", "validation")
    for name, scale, seed, held_out, text in (
            ("validation-v2", 1, 2100 + i, False, "validation split v2: the test split's "
             "families (scripted, misspecified, adaptive, inconsistent), 20 other humans each"),
            ("test-v2", 2, 3100 + i, True, "TEST split v2 (suite v3's evaluation set): 40 "
             "different humans of each group, none of them a train or validation human")):
        groups = _v2_groups(scale)
        whole = MixtureSpec(name, sc, "2", text, sum(int(c.weight) for g in groups.values()
                                                     for c in g),
                            seed, tuple(c for g in groups.values() for c in g),
                            held_out=held_out, distinct=True, exclude=previous)
        out[(name, sc)] = whole
        for group in GROUPS:
            out[(f"{name}-{group}", sc)] = dataclasses.replace(
                whole, name=f"{name}-{group}", group=group,
                description=f"the {name} split's {group} humans")
        previous = (*previous, name)
    return out


def _v3_groups(scale: int) -> dict[str, tuple[Component, ...]]:
    """The components of a version-3 split per group: ``20 · scale`` members each, on
    grids wide enough to give that many humans distinct by behaviour.
    """
    def n(count: int) -> int:
        return count * scale

    low_beta = ("rationality", _grid(0.3, 12.0, 40, log=True))
    return {
        "scripted": _counted((
            ("preference", n(4), (_PREFS, ("passive", _grid(0.02, 0.95, 94)))),
            ("preference", n(5), (_PREFS, ("rationality", _grid(0.3, 40.0, 80, log=True)))),
            ("preference", n(11), (_PREFS, ("passive", _grid(0.05, 0.9, 35)), low_beta)),
        )),
        "misspecified": _v2_groups(scale)["misspecified"],
        "adaptive": _counted((
            ("follower", n(5), (("k", tuple(range(1, 16))), _PREFS)),
            ("trust", n(8), (("passive", _grid(0.2, 0.95, 31)), ("fall", (1, 2, 3)), _PREFS)),
            ("wary", n(7), (("levels", tuple(range(2, 13))), ("forgive", (0, 1)), _PREFS)),
        )),
        "inconsistent": _counted((
            ("fickle", n(17), (("hazard", _grid(0.02, 0.8, 40)), ("changes", (1, 2, 3)),
                               _PREFS)),
            ("moody", n(3), (("p", _grid(0.05, 1.0, 96)),)),
        )),
    }


#: The version-3 splits (suite v4): ``validation-v3`` and ``test-v3`` and their groups.
SPLITS_V3: tuple[str, ...] = ("validation-v3", "test-v3")


def _mixtures_v3(sc: str, i: int) -> dict[tuple[str, str], MixtureSpec]:
    """Split version 3 of one scenario: v2's layout (a validation split of 20 humans per
    group for the pilot, a test split of 40 per group), each human distinct by behaviour
    (:data:`~hri_envs.humans.distance.TOLERANCE`) from every other and from every train and
    validation human (versions 1 to 3).
    """
    out: dict[tuple[str, str], MixtureSpec] = {}
    previous: tuple[str, ...] = ("train", "validation", "validation-v2")
    for name, scale, seed, held_out, text in (
            ("validation-v3", 1, 2200 + i, False, "validation split v3: the test split's "
             "families, 20 humans each, distinct by behaviour"),
            ("test-v3", 2, 3200 + i, True, "TEST split v3 (suite v4's evaluation set): 40 "
             "humans of each group, distinct by behaviour from each other and from every "
             "train and validation human")):
        groups = _v3_groups(scale)
        whole = MixtureSpec(name, sc, "3", text, sum(int(c.weight) for g in groups.values()
                                                     for c in g),
                            seed, tuple(c for g in groups.values() for c in g),
                            held_out=held_out, distinct=True, exclude=previous,
                            tolerance=TOLERANCE)
        out[(name, sc)] = whole
        for group in GROUPS:
            out[(f"{name}-{group}", sc)] = dataclasses.replace(
                whole, name=f"{name}-{group}", group=group,
                description=f"the {name} split's {group} humans")
        previous = (*previous, name)
    return out


#: The frozen mixtures, by (name, scenario).
MIXTURES: dict[tuple[str, str], MixtureSpec] = _mixtures()


def population_names(scenario: str | None = None) -> list[str]:
    """Every population name (for ``scenario`` only, if given): the scripted populations,
    the splits and mixtures, and the families.
    """
    v0 = [n for n, p in POPULATIONS.items() if scenario is None or scenario in p.scenarios]
    mixed = list(dict.fromkeys(n for (n, sc) in MIXTURES if scenario in (None, sc)))
    return [*v0, *mixed, *FAMILIES]


def family_population(graph: TaskGraph, family: str, params: Mapping[str, Any] | None = None
                      ) -> MixtureSpec:
    """The population of one family with fixed parameters (defaults changed by ``params``)
    on ``graph``'s scenario.

    Raises:
        ConfigError: (``field="human_params"``) An unknown parameter or an impossible value.
    """
    full = family_params(family, params)
    given = tuple(sorted((k, v) for k, v in full.items() if k in (params or {})))
    spec = MixtureSpec(family, graph.name, "1", f"the {family} family "
                       f"({FAMILIES[family].description})",
                       1, 0, (Component(family, 1.0, tuple((k, (v,)) for k, v in given)),),
                       held_out=FAMILIES[family].group != "scripted")
    check_params(graph, family, params)  # impossible values raise
    return spec


def population(name: str, scenario: TaskGraph | str, params: Mapping[str, Any] | None = None
               ) -> PopulationSpec | MixtureSpec:
    """A population by name for ``scenario`` (its task graph, or a registered scenario's
    name, resolved here): a scripted population, a split or mixture, or a family (with
    ``params``).

    Raises:
        ConfigError: (``field="population"``) An unknown name or one for another scenario,
            the message listing the allowed names; (``field="human_params"``) parameters
            given for a population that is not a family, or impossible ones;
            (``field="scenario"``) an unknown scenario's name.
    """
    graph = as_graph(scenario)
    key = graph.name  # the tables below are keyed by the scenario's name
    if not isinstance(name, str):
        raise ConfigError(f"population must be a name, got {name!r}", field="population")
    if params and name not in FAMILIES:
        raise ConfigError(f"human_params= sets a family's parameters; {name!r} is not a "
                          f"family (families: {', '.join(FAMILIES)}; a family of your own "
                          "once the module that registers it is imported)", field="human_params")
    if name in POPULATIONS:
        spec = POPULATIONS[name]
        if key not in spec.scenarios:
            raise ConfigError(f"population {name!r} is not for {key!r}; allowed for "
                              f"{key}: {', '.join(population_names(key))}",
                              field="population")
        return spec
    if (name, key) in MIXTURES:
        return MIXTURES[(name, key)]
    if name in FAMILIES:
        return family_population(graph, name, params)
    raise ConfigError(f"unknown population {name!r} for the {key}; allowed: "
                      f"{', '.join(population_names(key))} (or module:Class)",
                      field="population")


def population_hash(spec: PopulationSpec | MixtureSpec) -> str:
    """The content hash of a population (:meth:`MixtureSpec.content_hash`; for a scripted
    population the hash of its recipe and its seeding).
    """
    if isinstance(spec, MixtureSpec):
        return spec.content_hash()
    return _sha256({"kind": "recipe", "spec": _jsonable(dataclasses.asdict(spec)),
                    "seeding": "HumanDraw from numpy default_rng([seed, run, 7]): 4 uniforms "
                               "(preference, rationality, passive, turn back), then θ"})


class MixtureHumans(FiniteStateHumans):
    """A mixture population in an env's seat: every reset draws each row a new member.

    Args:
        graph: The task graph.
        spec: The mixture.
        n_runs: Rows (the vector env's envs; 1 for a single env).
    """

    def __init__(self, graph: TaskGraph, spec: MixtureSpec, n_runs: int = 1) -> None:
        self.spec = spec
        self._built: dict[HumanDraw, FiniteStateHuman] = {}
        first = self._member(graph, spec.member_draws[0])
        super().__init__([first] * n_runs)

    def _member(self, graph: TaskGraph, draw: HumanDraw) -> FiniteStateHuman:
        """The member's model, built once per seat: models are immutable (a row's own state
        is its ``z`` in the seat), so rows and draws that meet one member share its model.
        """
        model = self._built.get(draw)
        if model is None:
            model = self._built[draw] = as_model(build_human(graph, draw))
        return model

    def draw(self, rng: np.random.Generator, rows: Rows = None) -> None:
        """Draw a new member for each row of ``rows``, in order, from ``rng``."""
        idx = all_rows(rows, self.n_runs)
        graph, sample = self.graph, self.spec.sample
        self.assign(idx, [self._member(graph, sample(graph, rng)) for _ in idx])


def population_seat(graph: TaskGraph, name: str, n_runs: int = 1,
                    params: Mapping[str, Any] | None = None) -> BatchHuman:
    """The seat of a population that draws a member at every reset (the envs'
    ``population=``): :class:`~hri_envs.humans.populations.PopulationHumans` for a scripted
    population, :class:`MixtureHumans` for a split, mixture or family.
    """
    spec = population(name, graph, params)
    if isinstance(spec, PopulationSpec):
        return PopulationHumans(graph, name, n_runs)
    return MixtureHumans(graph, spec, n_runs)


#: :func:`population`, under a name :func:`draw_human`'s keyword does not hide.
_population = population


def draw_human(
    graph: TaskGraph,
    seed: int,
    run: int,
    *,
    population: str | None = None,
    preference: str | None = None,
    rationality: float = math.inf,
    passive: float = 0.0,
    turn_back: float = 0.0,
    params: Sequence[tuple[str, Any]] = (),
) -> HumanDraw:
    """Run ``run``'s human on ``graph``: from ``population`` if given, else the fixed settings.

    With a scripted population, ``rationality`` (if finite) overrides the population's β, and
    the passive and turning-back rates are added to the population's (clipped to [0, 1]). A
    split, mixture or family (:func:`population`, with the family's
    ``params``) gives its member as it is.
    """
    if population is None:
        pref = preference or spec_of(graph).default_preference
        return HumanDraw(pref, rationality, passive, turn_back)
    if population not in POPULATIONS:  # a split, mixture or family: its members as they are
        return _population(population, graph, dict(params)).draw(graph, seed, run)
    d = population_spec(population, graph.name).draw(graph, seed, run)
    beta = rationality if not math.isinf(rationality) else d.rationality
    return dataclasses.replace(d, rationality=beta,
                               passive=min(1.0, d.passive + passive),
                               turn_back=min(1.0, d.turn_back + turn_back))
