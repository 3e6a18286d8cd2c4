"""Human populations: noisy (Boltzmann) preference humans, drifting humans and a registry.

Three ways to make the scripted partner of :mod:`hri_envs.humans.scripted` harder to cooperate
with, all opt-in (the defaults give today's deterministic human, bit for bit):

* **Rationality β** (:func:`~hri_envs.humans.rational.rational_human`): the human samples
  its free-space action from ``softmax(β · Q_pref)`` instead of the preference's action.
* **Populations** (:data:`POPULATIONS`): each run draws its human (preference, β, passive
  and turning-back rates, or random preference weights θ) from a frozen
  :class:`PopulationSpec`; the draw of run ``r`` uses a generator seeded by
  ``(seed, r, 7)`` only, so it does not depend on batching or workers.
* **Drift** (:func:`human_sequence`): after ``drift`` episodes the human switches to
  another preference (drawn from ``(seed, r, 8)``), so that a learner has to keep adapting.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hri_envs.checks import check_whole
from hri_envs.errors import ConfigError
from hri_envs.humans.families import build_family
from hri_envs.humans.protocol import Rows, all_rows
from hri_envs.humans.rational import rational_human
from hri_envs.humans.scripted import ScriptedHuman, boltzmann_human, preference_human
from hri_envs.humans.tables import TableHumans
from hri_envs.task.features import initial_theta
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = [
    "POPULATIONS",
    "HumanDraw",
    "PopulationHumans",
    "PopulationSpec",
    "build_human",
    "drifted",
    "human_sequence",
    "humans_of",
    "population_spec",
    "validate_drift",
]


@dataclass(frozen=True)
class HumanDraw:
    """One run's human, as drawn from a population (JSON-ready).

    Attributes:
        preference: A preference name, or None for a θ human.
        rationality: β (``inf``: deterministic).
        passive: Probability of waiting in a step.
        turn_back: Probability per episode of turning back halfway.
        theta: (F,) preference weights of a θ human (Boltzmann with temperature β), or None.
        family: A family of :data:`hri_envs.humans.families.FAMILIES` (then only ``params``
            count), or None for the fields above.
        params: The family's parameters as (name, value) pairs (the others: defaults).
    """

    preference: str | None
    rationality: float = math.inf
    passive: float = 0.0
    turn_back: float = 0.0
    theta: tuple[float, ...] | None = None
    family: str | None = None
    params: tuple[tuple[str, Any], ...] = ()

    def label(self) -> str:
        """A short readable description (the preference or "theta", with β if finite; a
        family's name and parameters, :mod:`hri_envs.humans.families`).
        """
        if self.family is not None:
            inner = ",".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                             for k, v in self.params)
            return f"{self.family}({inner})"
        base = self.preference if self.preference is not None else "theta"
        return base if math.isinf(self.rationality) else f"{base}@{self.rationality:.3g}"


@dataclass(frozen=True)
class PopulationSpec:
    """A frozen recipe for drawing one human per run.

    Attributes:
        name: Registry key.
        description: One line for help texts and docs.
        scenarios: The scenarios it applies to.
        preferences: Preference names to draw uniformly from; () = the scenario's default;
            ("*",) = all of the scenario's preferences.
        rationality: (low, high) β drawn log-uniformly, or None for the deterministic human.
        passive: (low, high) passive rate drawn uniformly.
        turn_back: (low, high) turning-back rate drawn uniformly.
        theta: Draw random preference weights θ (a Boltzmann θ human, :func:`boltzmann_human`)
            instead of a named preference.
        held_out: The evaluation set: never used to tune defaults or in tests that do.
    """

    name: str
    description: str
    scenarios: tuple[str, ...] = ("hanger", "wheel")  # by value: registering changes none
    preferences: tuple[str, ...] = ()
    rationality: tuple[float, float] | None = None
    passive: tuple[float, float] = (0.0, 0.0)
    turn_back: tuple[float, float] = (0.0, 0.0)
    theta: bool = False
    held_out: bool = False

    def draw(self, graph: TaskGraph, seed: int, run: int) -> HumanDraw:
        """The human of run ``run`` on ``graph``: every draw from a generator seeded by
        ``(seed, run, 7)``.
        """
        return self.sample(graph, np.random.default_rng([int(seed), int(run), 7]))

    def sample(self, graph: TaskGraph, rng: np.random.Generator) -> HumanDraw:
        """A human on ``graph`` drawn with ``rng`` (4 uniforms, then F more for a θ human)."""
        if graph.name not in self.scenarios:
            raise ConfigError(f"population {self.name!r} is for {', '.join(self.scenarios)}; "
                              f"not {graph.name!r}", field="population")
        spec = spec_of(graph)
        prefs = spec.preferences if self.preferences == ("*",) else (
            self.preferences or (spec.default_preference,))
        # Always consume the same draws in the same order, whatever the spec uses.
        u = rng.random(4)
        pref = prefs[min(int(u[0] * len(prefs)), len(prefs) - 1)]
        beta = math.inf
        if self.rationality is not None:
            lo, hi = np.log(self.rationality[0]), np.log(self.rationality[1])
            beta = float(np.exp(lo + u[1] * (hi - lo)))
        passive = self.passive[0] + u[2] * (self.passive[1] - self.passive[0])
        turn = self.turn_back[0] + u[3] * (self.turn_back[1] - self.turn_back[0])
        theta = None
        if self.theta:
            theta = tuple(float(x) for x in _random_theta(graph, rng))
            pref_out: str | None = None
        else:
            pref_out = pref
        return HumanDraw(pref_out, beta, float(passive), float(turn), theta)


def _random_theta(graph: TaskGraph, rng: np.random.Generator) -> np.ndarray:
    """θ over the graph's features: U(-0.5, 0.5) noise on the paper's θ⁰, goal weight 1."""
    n_f = graph.n_features
    theta = initial_theta(n_f) + rng.uniform(-0.5, 0.5, n_f)
    theta[0] = 1.0  # resting on the goal support pays: the human gets there
    return theta


_POPULATIONS = (
    PopulationSpec("hanger-all", "all 36 hanger preferences, one per run, deterministic",
                   scenarios=("hanger",), preferences=("*",)),
    PopulationSpec("preferences", "every preference of the scenario, one per run, "
                   "deterministic", preferences=("*",)),
    PopulationSpec("theta", "random preference weights θ over the features (θ⁰ plus "
                   "U(-0.5, 0.5), goal weight 1), Boltzmann with β in [5, 50]",
                   rationality=(5.0, 50.0), theta=True),
    PopulationSpec("mixed-rationality", "the default preference with β drawn log-uniformly "
                   "in [1, 20] per run", rationality=(1.0, 20.0)),
    PopulationSpec("passive-turnback", "the default preference; passive rate in [0, 0.3] and "
                   "turning-back rate in [0, 0.5] drawn per run",
                   passive=(0.0, 0.3), turn_back=(0.0, 0.5)),
    PopulationSpec("heldout", "HELD OUT evaluation set: any preference, β in [2, 30], "
                   "passive in [0, 0.2], turning back in [0, 0.3]", preferences=("*",),
                   rationality=(2.0, 30.0), passive=(0.0, 0.2), turn_back=(0.0, 0.3),
                   held_out=True),
)
#: The population registry, by name.
POPULATIONS: dict[str, PopulationSpec] = {p.name: p for p in _POPULATIONS}


def population_spec(name: str, scenario: str | None = None) -> PopulationSpec:
    """A scripted population (:data:`POPULATIONS`) by name; a :class:`ConfigError` lists the
    allowed names otherwise. Splits, mixtures and families are found by
    :func:`hri_envs.humans.splits.population`.
    """
    if not isinstance(name, str) or name not in POPULATIONS:
        raise ConfigError(f"unknown scripted population {name!r}; allowed: "
                          f"{', '.join(POPULATIONS)} (splits, mixtures and families: "
                          "hri_envs.humans.splits.population)", field="population")
    spec = POPULATIONS[name]
    if scenario is not None and scenario not in spec.scenarios:
        allowed = [n for n, p in POPULATIONS.items() if scenario in p.scenarios]
        raise ConfigError(f"population {name!r} is not for {scenario!r}; allowed for "
                          f"{scenario}: {', '.join(allowed)}", field="population")
    return spec


@functools.lru_cache(maxsize=256)
def _base_human(graph: TaskGraph, preference: str) -> ScriptedHuman:
    """:func:`preference_human`, once per graph (a graph hashes by identity) and preference."""
    return preference_human(graph, preference)


def build_human(graph: TaskGraph, draw: HumanDraw) -> Any:
    """The human model a :class:`HumanDraw` describes: a :class:`ScriptedHuman`, or a family's
    model (:func:`hri_envs.humans.families.build_family`, possibly a
    :class:`~hri_envs.humans.finite_state.FiniteStateHuman`).
    """
    if draw.family is not None:
        return build_family(graph, draw.family, dict(draw.params))
    if draw.theta is not None:
        beta = 25.0 if math.isinf(draw.rationality) else draw.rationality
        human = boltzmann_human(graph, np.asarray(draw.theta), temperature=beta,
                                passive=draw.passive)
        return dataclasses.replace(human, turn_back=draw.turn_back)
    assert draw.preference is not None
    human = rational_human(_base_human(graph, draw.preference), draw.rationality)
    if draw.passive == human.passive and draw.turn_back == human.turn_back:
        return human
    return dataclasses.replace(human, passive=draw.passive, turn_back=draw.turn_back)


def drifted(graph: TaskGraph, draw: HumanDraw, seed: int, run: int) -> HumanDraw:
    """The human on ``graph`` after drifting: another preference (or another θ), from
    ``(seed, run, 8)``.
    """
    rng = np.random.default_rng([int(seed), int(run), 8])
    if draw.theta is not None:
        return dataclasses.replace(draw, theta=tuple(float(x)
                                                     for x in _random_theta(graph, rng)))
    prefs = [p for p in spec_of(graph).preferences if p != draw.preference]
    return dataclasses.replace(draw, preference=prefs[int(rng.integers(len(prefs)))])


def human_sequence(graph: TaskGraph, draw: HumanDraw, seed: int, run: int, episodes: int,
                   drift: int | None = None) -> list[HumanDraw]:
    """The human of each episode of a run: ``draw`` throughout, or ``draw`` for the first
    ``drift`` episodes and :func:`drifted` after.
    """
    if drift is None or drift >= episodes:
        return [draw] * episodes
    after = drifted(graph, draw, seed, run)
    return [draw] * drift + [after] * (episodes - drift)


def validate_drift(drift: int | None, field: str = "human_drift") -> None:
    """Check a drift: None (no drift) or a whole number of episodes >= 1 (not ``True``)."""
    if drift is not None:
        check_whole(drift, field, minimum=1, label=f"{field} (None or episodes)")


def humans_of(graph: TaskGraph, draws: Sequence[HumanDraw]) -> list[ScriptedHuman]:
    """Build one human per draw, sharing identical ones."""
    cache: dict[HumanDraw, ScriptedHuman] = {}
    out = []
    for d in draws:
        if d not in cache:
            cache[d] = build_human(graph, d)
        out.append(cache[d])
    return out



class PopulationHumans(TableHumans):
    """A population in a seat: every episode each row gets a new member, drawn in :meth:`draw`.

    The envs' ``population=`` argument: each reset (each autoreset of the vector env) draws
    the episode's human from the env's ``np_random`` with :meth:`PopulationSpec.sample`,
    before the episode's start, intention and turning back are drawn.

    Args:
        graph: The task graph.
        population: A population's name (:data:`POPULATIONS`).
        n_runs: Rows (the vector env's envs; 1 for a single env).
    """

    def __init__(self, graph: TaskGraph, population: str, n_runs: int = 1) -> None:
        if isinstance(population, str) and population not in POPULATIONS:
            raise ConfigError(f"PopulationHumans seats the scripted populations "
                              f"({', '.join(POPULATIONS)}); seat {population!r} with "
                              "hri_envs.humans.splits.population_seat", field="population")
        self.spec = population_spec(population, graph.name)
        placeholder = preference_human(graph)  # until the first draw
        super().__init__(placeholder, n_runs)
        # Per-row tables from the start, never one shared table: the members differ per row
        # (and may be stochastic), so no seat may take the placeholder for every row's human
        # (the vector env acts by one table for a shared deterministic human).
        self.assign(None, [placeholder] * self.n_runs)

    def draw(self, rng: np.random.Generator, rows: Rows = None) -> None:
        """Draw a new member for each row of ``rows``, in order, from ``rng``."""
        idx = all_rows(rows, self.n_runs)
        self.assign(idx, [build_human(self.graph, self.spec.sample(self.graph, rng))
                          for _ in idx])
