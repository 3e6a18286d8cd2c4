"""A study: several agents, many runs, one scenario and human; results as arrays and files.

:func:`run_study` splits the work into units of (agent, human preference, chunk of runs),
runs them serially, in a process pool or on Ray, and stitches the results together in run
order. Since every run draws only from ``(seed, run)``, the numbers are identical whatever
the executor, the number of jobs and the size of the chunks (:data:`UNIT_EPISODES`).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import json
import math
import multiprocessing
import os
import pickle
import signal
import sys
import tempfile
import threading
import time
import traceback
from collections.abc import Callable, Generator, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as mp_wait
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from agents.config import default_config
from hri_bench.core import stats
from hri_bench.core.atomic import atomic_writer, move_into_place
from hri_bench.core.results import StudyResult  # re-exported; shared with the plots
from hri_bench.data.fit import is_recorded
from hri_bench.run.agents import (
    AGENTS,
    BUILTIN_AGENTS,
    REFERENCE_AGENTS,
    agent_settings,
    make_agent,
    validate_agent_name,
)
from hri_bench.run.humans import custom_population_info, is_custom
from hri_bench.run.regret import (
    ALL_REFERENCES,
    blind_values,
    reference_summary,
    refuse_references,
    what_ran,
)
from hri_bench.run.runner import TASK_METRICS, make_schedule, simulate
from hri_envs import __version__
from hri_envs.checks import check_flag, check_real, check_whole
from hri_envs.envs.backends import BACKENDS, DEFAULT_UNIT_TIME_LIMIT, batch_backend
from hri_envs.envs.config import check_physics_options
from hri_envs.errors import ActionError, ConfigError, MissingExtraError
from hri_envs.humans.populations import (
    POPULATIONS,
    HumanDraw,
    validate_drift,
)
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.rational import validate_rationality
from hri_envs.humans.runs import RunHumans, study_humans
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.spec import HumanSpec
from hri_envs.humans.splits import population, population_hash
from hri_envs.imports import import_modules
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import SCENARIOS, NamedScenario, as_graph

__all__ = [
    "EXECUTION_FIELDS",
    "MAX_EPISODES",
    "MAX_RUNS",
    "MAX_RUN_EPISODES",
    "MAX_RUN_STEPS",
    "MAX_STEPS",
    "METRICS",
    "Probe",
    "StudyConfig",
    "StudyResult",
    "UNIT_TIME_LIMIT",
    "StudyStopped",
    "UnitFailure",
    "UnitLostError",
    "UnitResult",
    "graph_for",
    "regret_reference",
    "run_study",
    "simulate_runs",
    "summarize",
    "write_outputs",
]

#: The most runs per agent, episodes per run and steps per episode a study takes, and the
#: most runs x episodes (each agent's result arrays) and runs x steps (the episode buffers):
#: bounds that keep a study's memory within a few hundred MB (docs/benchmark.md).
MAX_RUNS = 100_000
MAX_EPISODES = 10_000
MAX_STEPS = 10_000
MAX_RUN_EPISODES = 1_000_000
MAX_RUN_STEPS = 10_000_000

#: Metrics of every backend; a backend adds its own ``extras`` (the physics: impulses, ...).
METRICS = ("reward", "correct", "passive", "wrong", "steps", "truncated")
EXECUTORS = ("serial", "process", "ray")
#: The default most wall seconds one unit of work may take (:attr:`StudyConfig.
#: unit_time_limit`) on the graph and MuJoCo backends (``BackendSpec.unit_time_limit``; none
#: on MuJoCo Warp, whose speed is its device's).
UNIT_TIME_LIMIT = DEFAULT_UNIT_TIME_LIMIT


def _backend_extras(metrics: Mapping[str, Any]) -> list[str]:
    """The backend's own metrics among an agent's ``metrics`` of a :class:`StudyResult`
    (its keys besides :data:`METRICS` and the task's :data:`~hri_bench.run.runner.TASK_METRICS`),
    in their order.
    """
    return [k for k in metrics if k not in METRICS and k not in TASK_METRICS]


def graph_for(scenario: TaskGraph | str) -> TaskGraph:
    """The task graph of a scenario: a registered scenario's name (a script's or a figure's,
    resolved here, once) or the graph itself (:func:`~hri_envs.task.scenarios.as_graph`).
    """
    return as_graph(scenario)


@dataclass(frozen=True)
class Probe:
    """A policy entry to record after every episode: π(action | state, intention).

    ``kind`` is "human" (the agent's estimate π̂_H) or "robot" (its π_R); agents without the
    matching ``human_policy``/``robot_policy`` method record NaN.
    """

    label: str
    kind: str
    state: int
    intention: int
    action: int
    relative_to_wait: bool = False

    def check(self, graph: TaskGraph) -> None:
        """Raise a :class:`ConfigError` (``field="probes"``) unless this probe fits ``graph``:
        ``kind`` "human" or "robot", indices within its states, intentions and actions.
        """
        try:
            if not isinstance(self.label, str) or self.kind not in ("human", "robot"):
                raise ConfigError("", field="probes")
            for name, n in (("state", graph.n_states), ("intention", graph.n_intentions),
                            ("action", graph.n_actions)):
                check_whole(getattr(self, name), "probes", minimum=0, maximum=n - 1)
            check_flag(self.relative_to_wait, "probes")
        except ConfigError:
            raise ConfigError(
                f"probe {self!r} does not fit the {graph.name}: a probe has a label (str), "
                "kind 'human' or 'robot', state, intention and action indices of the task "
                f"graph (< {graph.n_states}, {graph.n_intentions}, {graph.n_actions}) and "
                "relative_to_wait (bool)", field="probes") from None


@dataclass(frozen=True)
class StudyConfig(NamedScenario):
    """What to simulate. ``None`` fields take the scenario's defaults.

    The scenario is named here and resolved once: the study passes :attr:`graph` and
    :attr:`spec` down (:class:`~hri_envs.task.scenarios.NamedScenario`), never the name.

    Attributes:
        scenario: "hanger" or "wheel".
        agents: Agent names (see :mod:`hri_bench.run.agents`).
        runs: Independent runs per agent (each learns from scratch).
        episodes: Episodes per run (default: the scenario's, or a fixed schedule's length:
            8 hanger, 20 wheel, 9 for "table2").
        schedule: "random" start and goal per episode, or one of the scenario's fixed
            schedules (the hanger's user study, "table2").
        preference: The scripted human's preference, or "all" to cycle runs over all of them.
        r0: Robot reward for waiting while the human acts, in (-1, 0).
        human_passive: Probability that the human waits in a step.
        turn_back: Probability per episode that the human turns back halfway.
        seed: Base seed; run r depends on (seed, r) only.
        jobs: Worker processes (or Ray tasks in flight).
        executor: "serial", "process" or "ray".
        backend: "graph" (the abstract task graph, batched), "mjwarp" (the simulated Panda on
            MuJoCo Warp, a unit's runs as worlds of one batch) or "mujoco" (the simulated
            Panda, one run at a time; adds interaction impulse, duration and graph agreement
            to the metrics).
        max_steps: Step limit per episode.
        ray_address: Address of a Ray cluster (default: start Ray locally).
        probes: Policy entries to record per episode (for Figs. 8, 11, 12).
        human_rationality: β of a Boltzmann human following its preference
            (:func:`hri_envs.humans.rational.rational_human`); ``inf``: deterministic.
        population: Draw each run's human from this population
            (:data:`hri_envs.humans.populations.POPULATIONS`), or ``module:Class``: a human
            class of your own (:mod:`hri_bench.run.humans`); None: the fixed human above.
        human_drift: The human switches to another preference after this many episodes
            (:func:`hri_envs.humans.populations.human_sequence`); None: never.
        learner: Changes to the Learner's :class:`~agents.config.LearnerConfig` as
            (name, value) pairs, e.g. ``(("beta", 0.9),)``.
        reward: The reward variant, "paper" (v0) or "no-free-toggle" (a robot grasp toggle
            that the object's next motion does not need costs r0; see
            :func:`hri_envs.task.episode.step_reward`).
        physics_preset: A named set of physics options of the backend (mujoco:
            "weak-human", "noisy-sensor"; docs/physics.md); None for its defaults.
        human_params: The parameters of a family named as ``population`` (e.g.
            ``(("k", 3),)`` for ``population="impatient"``; :mod:`hri_envs.humans.families`),
            as (name, value) pairs; the others take the family's defaults.
        unit_time_limit: The most wall seconds one unit of work (an agent's chunk of runs,
            :data:`UNIT_EPISODES`) may take (``inf``: no limit; None: the backend's
            default, :data:`UNIT_TIME_LIMIT` on the graph and MuJoCo backends, none on
            MuJoCo Warp; :meth:`time_limit`); a unit over it ends the study with a
            :class:`UnitLostError` naming it, as a worker that dies does
            (docs/benchmark.md, "Interrupted studies").
        imports: Modules whose import registers what the study names (a scenario, a
            family, a reward rule, an agent of your own by name): imported first, here and
            in every process that runs its units (:func:`hri_envs.imports.import_modules`;
            ``hri-bench --import MODULE`` and the installed plugins give
            :func:`hri_envs.imports.imported_modules`), and recorded in the settings, so that
            a replay (``--config``) imports them again.
    """

    scenario: str
    agents: tuple[str, ...] = BUILTIN_AGENTS
    runs: int = 100
    episodes: int | None = None
    schedule: str = "random"
    preference: str | None = None
    r0: float | None = None
    human_passive: float = 0.0
    turn_back: float = 0.0
    seed: int = 0
    jobs: int = 1
    executor: str = "serial"
    backend: str = "graph"
    max_steps: int = 100
    ray_address: str | None = None
    probes: tuple[Probe, ...] = field(default_factory=tuple)
    human_rationality: float = math.inf
    population: str | None = None
    human_drift: int | None = None
    learner: tuple[tuple[str, Any], ...] = ()
    reward: str = "paper"
    physics_preset: str | None = None
    human_params: tuple[tuple[str, Any], ...] = ()
    unit_time_limit: float | None = None
    imports: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Import :attr:`imports`, then validate every field, in the fields' order (a
        :class:`ConfigError` names the field in its ``field`` attribute).
        """
        import_modules(self.imports, field="imports")
        self._check_task()
        self._check_execution()
        self._check_humans()
        self._check_learning()

    def _check_task(self) -> None:
        """The scenario, agents, runs, episodes, schedule, preference, r0, the scripted
        human's probabilities.
        """
        self._choice("scenario", tuple(SCENARIOS))
        if not isinstance(self.agents, tuple | list) or not self.agents or not all(
                isinstance(a, str) for a in self.agents):
            raise ConfigError(f"agents must be a non-empty list of agent names (e.g. "
                              f"['learner', 'passive']), got {self.agents!r}", field="agents")
        twice = sorted({a for a in self.agents if self.agents.count(a) > 1})
        if twice:
            raise ConfigError(f"agents must name each agent once; {', '.join(twice)} is given "
                              "more than once", field="agents")
        for name in self.agents:
            validate_agent_name(name)
        check_whole(self.runs, "runs", minimum=1, maximum=MAX_RUNS)
        if self.episodes is not None:
            check_whole(self.episodes, "episodes", minimum=1, maximum=MAX_EPISODES,
                        label="episodes (None or a number)")
        self._choice("schedule", ("random", *self.spec.schedules))
        prefs = self.spec.preferences
        if self.preference is not None and (not isinstance(self.preference, str)
                                            or self.preference not in (*prefs, "all")):
            raise ConfigError(f"preference must be 'all' or one of {', '.join(prefs)}, got "
                              f"{self.preference!r}", field="preference")
        if self.r0 is not None:
            check_real(self.r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True,
                       allowed="None or a number in (-1, 0)")
        for name in ("human_passive", "turn_back"):
            check_real(getattr(self, name), name, low=0.0, high=1.0,
                       allowed="a probability in [0, 1]")

    def _check_execution(self) -> None:
        """The seed, jobs, executor, backend, step limit, the sizes of the result arrays, the
        probes.
        """
        check_whole(self.seed, "seed", minimum=0)
        check_whole(self.jobs, "jobs", minimum=1)
        self._choice("executor", EXECUTORS)
        if self.unit_time_limit is not None:
            check_real(self.unit_time_limit, "unit_time_limit", low=0.0, low_open=True,
                       allow_inf=True, allowed="a number of seconds > 0, inf (no limit) or "
                       "None (the backend's default)")
        self._text("ray_address", "a Ray cluster's address")
        self._choice("backend", tuple(BACKENDS))
        max_steps = check_whole(self.max_steps, "max_steps", minimum=1, maximum=MAX_STEPS)
        runs, n_episodes = int(self.runs), self.n_episodes  # runs: checked by _check_task
        if runs * n_episodes > MAX_RUN_EPISODES:
            raise ConfigError(f"runs x episodes must be at most {MAX_RUN_EPISODES:,} (the "
                              f"study's result arrays), got {runs:,} x {n_episodes:,}",
                              field="runs")
        if runs * max_steps > MAX_RUN_STEPS:
            raise ConfigError(f"runs x max_steps must be at most {MAX_RUN_STEPS:,} (the "
                              f"episode buffers), got {runs:,} x {max_steps:,}", field="runs")
        if not isinstance(self.probes, tuple) or not all(isinstance(p, Probe)
                                                         for p in self.probes):
            raise ConfigError(f"probes must be a tuple of Probe, got {self.probes!r}",
                              field="probes")
        for probe in self.probes:
            probe.check(self.graph)

    def _check_humans(self) -> None:
        """Rationality, population and its parameters, drift, and what each allows."""
        validate_rationality(self.human_rationality)
        self._text("population", "a population's name or 'module:Class'")
        self._pairs("human_params", "a family's parameters, e.g. (('k', 3),)")
        if self.human_params and self.population is None:
            raise ConfigError("human_params= sets the parameters of the family that "
                              "population= names; no population is given",
                              field="human_params")
        if self.population is not None:
            self.human.check(self.graph)
            if self.preference is not None:
                raise ConfigError("give either a population or a preference, not both",
                                  field="preference")
        validate_drift(self.human_drift)
        if self.mixture_population:
            for name, bad in (("human_rationality", not math.isinf(self.human_rationality)),
                              ("human_passive", self.human_passive > 0),
                              ("turn_back", self.turn_back > 0),
                              ("human_drift", self.human_drift is not None)):
                if bad:
                    raise ConfigError(f"population {self.population!r} gives each run a "
                                      f"frozen member as it is; {name} cannot change it "
                                      "(leave it at its default)", field=name)
            # Its members are drawn here, once: a split that cannot give them all is
            # refused before anything is simulated, and a study's forked workers inherit them.
            assert self.population is not None
            getattr(population(self.population, self.graph, dict(self.human_params)),
                    "member_draws", None)
        if is_custom(self.population):
            if self.human_drift is not None:
                raise ConfigError("a human of your own (a population named module:Class) does "
                                  "not drift; leave out human_drift=", field="human_drift")
            if "oracle" in self.agents and not is_recorded(self.population):
                # a fitted human is a policy table: the oracle copies its likeliest action
                raise ConfigError("the oracle copies a scripted human's preferred actions; "
                                  "leave it out of agents= with a population named "
                                  "module:Class", field="agents")

    def _check_learning(self) -> None:
        """The references the humans allow, the Learner's changes, the reward rule, the
        physics preset.
        """
        refuse_references(self)
        self._pairs("learner", "LearnerConfig fields, e.g. (('beta', 0.9),)")
        if self.learner:
            default_config(self.spec, **dict(self.learner))
        self._choice("reward", tuple(REWARD_RULES))
        self._text("physics_preset", "a preset's name")
        if self.physics_preset is not None:
            try:
                check_physics_options(self.physics, self.backend)
            except ConfigError as exc:
                raise ConfigError(str(exc), field="physics_preset") from None

    def time_limit(self) -> float:
        """The most wall seconds one unit of work may take: :attr:`unit_time_limit`, or
        the backend's default when it is None (``inf``: no limit).
        """
        if self.unit_time_limit is None:
            return float(BACKENDS[self.backend].unit_time_limit)
        return float(self.unit_time_limit)

    def _choice(self, name: str, allowed: Sequence[str]) -> None:
        """Field ``name`` is one of ``allowed``."""
        value = getattr(self, name)
        if not isinstance(value, str) or value not in allowed:
            raise ConfigError(f"{name} must be one of {', '.join(allowed)}, got {value!r}",
                              field=name)

    def _text(self, name: str, what: str) -> None:
        """Field ``name`` is None or a string (``what`` it names)."""
        value = getattr(self, name)
        if value is not None and not isinstance(value, str):
            raise ConfigError(f"{name} must be None or {what}, got {value!r}", field=name)

    def _pairs(self, name: str, what: str) -> None:
        """Field ``name`` is a tuple of (name, value) pairs of ``what``."""
        value = getattr(self, name)
        if not isinstance(value, tuple) or not all(
                isinstance(pair, tuple | list) and len(pair) == 2 and isinstance(pair[0], str)
                for pair in value):
            raise ConfigError(f"{name} must be (name, value) pairs of {what}, got "
                              f"{value!r}", field=name)

    @property
    def per_run_humans(self) -> bool:
        """Whether runs have humans of their own (a population or a drifting human)."""
        return self.population is not None or self.human_drift is not None

    @property
    def mixture_population(self) -> bool:
        """Whether the population is a split, mixture or family
        (:func:`hri_envs.humans.splits.population`), not a scripted population or a class.
        """
        return (self.population is not None and not is_custom(self.population)
                and self.population not in POPULATIONS)

    def population_info(self) -> dict[str, Any] | None:
        """The population's name, version, content hash and whether it is held out (None:
        no population; a human class of the user's has no hash).
        """
        if self.population is None:
            return None
        if is_custom(self.population):  # a recorded dataset's has its content hash
            return custom_population_info(self.population, self.graph)
        spec = population(self.population, self.graph, dict(self.human_params))
        members = getattr(spec, "size", None)
        return {"name": self.population, "version": getattr(spec, "version", "1"),
                "hash": population_hash(spec), "held_out": bool(spec.held_out),
                "members": members}

    @property
    def human(self) -> HumanSpec:
        """The study's human as every env takes it (:class:`~hri_envs.humans.spec.
        HumanSpec`; ``--preference all`` cycles the runs over the preferences, so its
        preference is then None and each run's is given where its humans are made).
        """
        return HumanSpec(None if self.preference == "all" else self.preference,
                         self.human_passive, self.turn_back, self.human_rationality,
                         self.population, tuple(self.human_params))

    def human_draws(self, run: int, preference: str) -> list[HumanDraw]:
        """Run ``run``'s human in each episode, as its own draw from ``(seed, run)`` (a
        population, rationality, drift; :meth:`HumanSpec.run_draws`).
        """
        return self.human.run_draws(self.graph, self.seed, run, self.n_episodes,
                                    preference, self.human_drift)

    @cached_property
    def run_humans(self) -> RunHumans:
        """The maker of the study's humans for a batch of runs, read once from
        :attr:`human` (:func:`hri_envs.humans.runs.study_humans`; plain data, pickled with
        the study's units).
        """
        return study_humans(self.human, seed=self.seed, episodes=self.n_episodes,
                            drift=self.human_drift, run_preferences=self.preference_of_run())

    @property
    def physics(self) -> dict[str, Any]:
        """The backend's ``physics`` options this study sets."""
        return {} if self.physics_preset is None else {"preset": self.physics_preset}

    @property
    def n_episodes(self) -> int:
        """Episodes per run after defaults."""
        if self.episodes is not None:
            return self.episodes
        fixed = self.spec.schedules.get(self.schedule)
        return self.spec.episodes if fixed is None else len(fixed)

    @property
    def waiting_reward(self) -> float:
        """r0 after defaults."""
        return self.spec.r0 if self.r0 is None else self.r0

    def preference_of_run(self) -> list[str]:
        """The human preference of each run."""
        prefs = self.spec.preferences
        if self.preference == "all":
            return [prefs[r % len(prefs)] for r in range(self.runs)]
        default = self.spec.default_preference
        return [self.preference or default] * self.runs

    def settings(self) -> dict[str, Any]:
        """Every field that can change a number, JSON-ready (``summary.json``'s "settings").

        All dataclass fields but :data:`EXECUTION_FIELDS` (which only decide where and how
        fast the runs are simulated), so fields added to this class are recorded without
        further code; a field added after a file format was published
        (:data:`LATER_FIELDS`) is left out while at its default, so the files of earlier
        studies (and suite v1) read the same. :meth:`from_settings` reads it back.
        """
        return {f.name: _jsonable(getattr(self, f.name)) for f in dataclasses.fields(self)
                if f.name not in EXECUTION_FIELDS
                and not (f.name in LATER_FIELDS and getattr(self, f.name) == LATER_FIELDS[f.name])}

    @classmethod
    def from_settings(cls, settings: Mapping[str, Any], **execution: Any) -> StudyConfig:
        """The configuration :meth:`settings` describes (lists become tuples).

        Args:
            settings: As written by :meth:`settings`: every field but
                :data:`EXECUTION_FIELDS`, with JSON's types (lists for tuples, "inf" for
                infinity). A missing field is an error rather than a default, so that a
                hand-edited file never runs another study than it reads as.
            execution: Values of :data:`EXECUTION_FIELDS` (``jobs``, ``executor``, ...).

        Raises:
            ConfigError: A missing, unknown or invalid setting (its ``field`` names it).
        """
        names = {f.name for f in dataclasses.fields(cls)} - set(EXECUTION_FIELDS)
        if not isinstance(settings, Mapping):
            raise ConfigError(f"settings must be a JSON object with the fields "
                              f"{', '.join(sorted(names))}, got {type(settings).__name__}",
                              field="settings")
        unknown = sorted(map(str, set(settings) - names))
        if unknown:
            raise ConfigError(f"unknown setting(s) {', '.join(unknown)}; a study's settings "
                              f"are {', '.join(sorted(names))}", field=unknown[0])
        missing = sorted(names - set(settings) - set(LATER_FIELDS))
        if missing:
            raise ConfigError(f"missing setting(s) {', '.join(missing)}; a study's settings "
                              f"name every one of {', '.join(sorted(names))}",
                              field=missing[0])
        kwargs: dict[str, Any] = {}
        for name, value in settings.items():
            if name == "probes":
                keys = {f.name for f in dataclasses.fields(Probe)}
                if not isinstance(value, list) or not all(isinstance(p, dict) and set(p) == keys
                                                          for p in value):
                    raise ConfigError(f"probes must be a list of objects with the fields "
                                      f"{', '.join(sorted(keys))}, got {value!r}",
                                      field="probes")
                value = tuple(Probe(**p) for p in value)
            elif name in ("learner", "human_params") and isinstance(value, list):
                value = tuple(tuple(p) if isinstance(p, list) else p for p in value)
            elif isinstance(value, list):
                value = tuple(value)
            elif isinstance(value, str) and value in ("inf", "-inf"):
                value = float(value)  # written so by settings(): JSON has no infinity
            kwargs[name] = value
        return cls(**kwargs, **execution)


#: Fields of :class:`StudyConfig` that never change a study's numbers.
EXECUTION_FIELDS = ("jobs", "executor", "ray_address", "unit_time_limit")
#: Fields added after the settings' format was published, with their defaults: left out of
#: :meth:`StudyConfig.settings` at the default, and taken as the default when missing.
LATER_FIELDS: dict[str, Any] = {"human_params": (), "imports": ()}


def _jsonable(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {k: _jsonable(v) for k, v in dataclasses.asdict(value).items()}
    if isinstance(value, (tuple, list)):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, float) and math.isinf(value):
        return _json_float(value)  # JSON has no infinity
    return value


@dataclass(frozen=True)
class Unit:
    """A unit of a study's work: one agent's runs ``runs`` with the human preference."""

    config: StudyConfig
    agent: str
    preference: str
    runs: tuple[int, ...]


def _probe(agent: Any, probes: Sequence[Probe]) -> np.ndarray:
    out = np.full((agent.n_runs, len(probes)), np.nan)
    for j, p in enumerate(probes):
        fn = getattr(agent, f"{p.kind}_policy", None)
        if fn is None:
            continue
        pi = fn(p.state, p.intention)  # (B, A)
        out[:, j] = pi[:, p.action] / pi[:, 0] if p.relative_to_wait else pi[:, p.action]
    return out


def _json_float(x: float) -> float | str:
    """A float for JSON: ``inf`` as the string "inf" (``-inf`` as "-inf")."""
    return str(x) if math.isinf(x) else x


def unit_humans(cfg: StudyConfig, preference: str, runs: list[int]
            ) -> tuple[ScriptedHuman | BatchHuman, list[str]]:
    """The unit's human(s) and each run's human label (per episode for drift: "a>b").

    The one place a study's humans are made, by the maker of its human's kind, chosen once
    (:attr:`StudyConfig.run_humans`): a scripted human shared by the runs, each run's own
    scripted humans (a population's draw, a drift), or a human class of the user's
    (``--population module:Class``).
    """
    return cfg.run_humans.make(cfg.graph, runs, preference)


#: What a unit yields: metrics, probes, schedule and each run's human label.
UnitResult = tuple[dict[str, np.ndarray], np.ndarray, dict[str, np.ndarray], list[str]]


@dataclass(frozen=True)
class UnitFailure:
    """A unit whose agent raised: the agent's name, the exception and its traceback text."""

    agent: str
    runs: tuple[int, ...]
    error: BaseException
    traceback: str


def _run_unit(unit: Unit) -> UnitResult:
    cfg = unit.config
    import_modules(cfg.imports)  # a spawned worker (or Ray's) has not imported them yet
    graph = cfg.graph
    runs = list(unit.runs)
    human, labels = unit_humans(cfg, unit.preference, runs)
    schedule = make_schedule(graph, cfg.schedule, runs, cfg.n_episodes, cfg.seed, human)
    agent = make_agent(unit.agent, graph, human, runs, seed=cfg.seed, r0=cfg.waiting_reward,
                       learner=dict(cfg.learner), max_steps=cfg.max_steps, reward=cfg.reward,
                       episodes=cfg.n_episodes)
    probes = np.full((len(runs), cfg.n_episodes + 1, len(cfg.probes)), np.nan)
    if cfg.probes:
        probes[:, 0] = _probe(agent, cfg.probes)

    def record(e: int, a: Any) -> None:
        probes[:, e + 1] = _probe(a, cfg.probes)

    try:
        m = simulate(graph, agent, human, schedule, runs=runs, seed=cfg.seed,
                     r0=cfg.waiting_reward, max_steps=cfg.max_steps,
                     after_episode=record if cfg.probes else None, backend=cfg.backend,
                     reward=cfg.reward, physics=cfg.physics)
    except ActionError as exc:
        raise ActionError(f"agent {unit.agent!r}: {exc}") from exc
    metrics = {k: np.asarray(v, dtype=float)  # the backend's extras, the task's for the file
               for k, v in [*((k, getattr(m, k)) for k in METRICS), *m.extras.items(),
                            *m.task.items()]}
    sched = {"start": schedule.start, "goal": schedule.goal, "turn_back": schedule.turn_back}
    return metrics, probes, sched, labels


def simulate_runs(cfg: StudyConfig, agent: str, runs: Sequence[int]
                  ) -> dict[str, np.ndarray]:
    """The metrics of ``runs`` of ``agent`` alone, as :func:`run_study` would give them for
    those rows (every draw of run ``r`` comes from ``(seed, r)``, so a run simulated on its
    own is the run of the whole study): ``hri-bench validate --replay`` re-simulates a
    results file's runs with it.
    """
    prefs = cfg.preference_of_run()
    out: dict[str, np.ndarray] = {}
    rows = [int(r) for r in runs]
    groups: dict[str, list[int]] = {}
    for r in rows:
        groups.setdefault("" if cfg.population else prefs[r], []).append(r)
    position = {r: i for i, r in enumerate(rows)}
    for pref, members in groups.items():
        metrics = _run_unit(Unit(cfg, agent, pref, tuple(members)))[0]
        for k, v in metrics.items():
            out.setdefault(k, np.zeros((len(rows),) + v.shape[1:]))[
                [position[r] for r in members]] = v
    return out


class StudyStopped(KeyboardInterrupt):
    """A stop signal (SIGINT) of the study's own process, raised by the handler of
    :func:`hri_bench.run.studyio.stop_on_signals` (SIGTERM: its subclass
    ``StudyTerminated``): what tells a stop of the study from an agent that raises
    ``KeyboardInterrupt`` itself.
    """


class _ProcessExit(BaseException):
    """``os._exit(code)`` called by an agent running in this process (:func:`_no_exit`)."""

    def __init__(self, code: Any) -> None:
        super().__init__(f"the agent called os._exit({code!r}) in the benchmark's process")
        self.code = code


@contextlib.contextmanager
def _no_exit() -> Iterator[None]:
    """Within the block, ``os._exit`` called in this process raises :class:`_ProcessExit`
    instead of ending it (an agent's unit: its failure, not the study's end); a process
    forked within keeps the real one.
    """
    real, pid = os._exit, os.getpid()

    def refuse(status: int) -> NoReturn:
        if os.getpid() != pid:
            real(status)
        raise _ProcessExit(status)

    os._exit = refuse
    try:
        yield
    finally:
        os._exit = real


def _agent_stop(exc: BaseException) -> bool:
    """Whether a ``KeyboardInterrupt`` came from the agent rather than from a stop of the
    study: not :class:`StudyStopped`, and raised where SIGINT is handled by the study (or
    ignored, as in a pool worker) rather than by Python's default handler.
    """
    return not isinstance(exc, StudyStopped) and (
        signal.getsignal(signal.SIGINT) is not signal.default_int_handler)


def _run_unit_caught(unit: Unit) -> UnitResult | UnitFailure:
    """:func:`_run_unit`, returning an agent's exception instead of raising it.

    An agent that calls ``sys.exit()`` or ``os._exit()`` or raises ``KeyboardInterrupt``
    itself fails like one that raises (a :class:`RuntimeError` naming it): it must not end
    the study, nor a pool worker (whose unit would never end). A stop of the study itself
    (Ctrl-C, SIGTERM: :class:`StudyStopped`) is raised on.
    """
    try:
        with _no_exit():
            return _run_unit(unit)
    except KeyboardInterrupt as exc:
        if not _agent_stop(exc):
            raise
        return UnitFailure(unit.agent, unit.runs, RuntimeError(
            f"agent {unit.agent!r} raised KeyboardInterrupt" + (f" ({exc})" if str(exc) else "")),
            traceback.format_exc())
    except (Exception, SystemExit, _ProcessExit) as exc:
        text = traceback.format_exc()
        error: Exception
        if isinstance(exc, SystemExit):
            error = RuntimeError(f"agent {unit.agent!r} called sys.exit({exc.code!r})")
        elif isinstance(exc, _ProcessExit):
            error = RuntimeError(f"agent {unit.agent!r} called os._exit({exc.code!r})")
        else:
            try:
                pickle.dumps(exc)
                error = exc
            except Exception:
                error = RuntimeError(str(exc))
        return UnitFailure(unit.agent, unit.runs, error, text)


#: At most this many episodes (runs × episodes per run) in one unit of work on a backend of
#: table look-ups, so that an interrupted study loses at most about that much (a run, which
#: learns over its episodes, is never split). Other backends (the MuJoCo simulation, about
#: 0.2 s a step, one run at a time) get one run per unit. The numbers do not depend on it.
UNIT_EPISODES = 1000


def _runs_per_unit(cfg: StudyConfig) -> int:
    spec = BACKENDS[cfg.backend]
    if not (spec.vectorizable or spec.batch_runs):
        return 1
    return max(1, UNIT_EPISODES // cfg.n_episodes)


def study_units(cfg: StudyConfig) -> list[Unit]:
    """The study's work: per agent and human preference, chunks of runs of at most
    :func:`_runs_per_unit` runs, and at least ``jobs`` chunks (to keep the workers busy).
    """
    per_unit = _runs_per_unit(cfg)
    by_pref: dict[str, list[int]] = {}
    for r, pref in enumerate(cfg.preference_of_run()):
        # A population draws each run's own human: one group, split only by --jobs.
        by_pref.setdefault("" if cfg.population else pref, []).append(r)
    # --preference all: the runs' preferences differ, but an agent that does not plan for
    # one shared human simulates them in one batch (fewer, larger array operations; the
    # numbers are the same: every draw of run r comes from (seed, r)).
    mixed = ({"all": list(range(cfg.runs))}
             if cfg.preference == "all" and not cfg.per_run_humans else None)
    units = []
    for agent in cfg.agents:
        groups = by_pref if mixed is None or agent in REFERENCE_AGENTS else mixed
        for pref, runs in groups.items():
            n_chunks = max(min(cfg.jobs, len(runs)), -(-len(runs) // per_unit))
            for chunk in np.array_split(np.asarray(runs), n_chunks):
                units.append(Unit(cfg, agent, pref, tuple(int(r) for r in chunk)))
    return units


#: The signals that stop a study (:func:`hri_bench.run.studyio.stop_on_signals`).
_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class UnitLostError(RuntimeError):
    """A unit of work that did not finish ended the study: its worker process died (the OOM
    killer, ``kill -9``, an agent calling ``os._exit`` or raising ``KeyboardInterrupt``), or
    it ran past :attr:`StudyConfig.unit_time_limit`.

    The units finished before it are kept (by the caller's ``on_result``), so a resumed study
    simulates only the missing ones.

    Attributes:
        agent: The unit's agent.
        runs: Its runs.
        reason: What happened, in words.
        where: Where the study ran (a suite's "track NAME"), or "".
    """

    def __init__(self, agent: str, runs: Sequence[int], reason: str, where: str = "") -> None:
        super().__init__(agent, tuple(runs), reason, where)  # args: pickled and rebuilt alike
        self.agent, self.runs, self.reason = agent, tuple(runs), reason
        #: Where the study ran, for the message (a suite's "track hanger-paper"), or "".
        self.where = where

    def __str__(self) -> str:
        where = f"{self.where}, " if self.where else ""
        return f"{where}agent {self.agent!r}, {_runs_text(self.runs)}: {self.reason}"


def _runs_text(runs: Sequence[int]) -> str:
    """"run 3", "runs 0–17" (consecutive), or "runs 0, 9, 18, ... (12 runs)"."""
    if len(runs) == 1:
        return f"run {runs[0]}"
    if list(runs) == list(range(runs[0], runs[-1] + 1)):
        return f"runs {runs[0]}–{runs[-1]}"
    shown = ", ".join(map(str, runs[:3]))
    return f"runs {shown}" + (f", ... ({len(runs)} runs)" if len(runs) > 3 else "")


def _lost(unit: Unit, reason: str) -> UnitLostError:
    return UnitLostError(unit.agent, unit.runs, reason)


def _over_time(limit: float) -> str:
    return (f"it ran longer than the time limit of {limit:g} s per unit of work (a hanging "
            "agent? unit_time_limit= sets the limit)")


def _worker_init(mask: Iterable[int]) -> None:
    """Pool worker set-up: leave Ctrl-C to the parent, die on SIGTERM, exit with the parent.

    The worker is forked with SIGINT and SIGTERM blocked (:func:`_start_pool`), so it never
    runs the parent's handlers; they are replaced here, and only then is the parent's signal
    ``mask`` restored (a signal that arrived in between meets the worker's own handling).
    The parent stops the pool on SIGINT/SIGTERM; if it is killed outright (SIGKILL), a
    watchdog thread notices that the worker was re-parented and exits, so no worker is
    left behind.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler (forked)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    parent = os.getppid()  # the study's process

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.2)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


@dataclass(frozen=True)
class _Stopped:
    """What a worker sends back when its unit ended it without a result (the agent raised
    ``KeyboardInterrupt``, say): the reason, in words.
    """

    reason: str


def _pool_worker(conn: Connection, mask: Iterable[int], inherited: Sequence[Connection]
                 ) -> None:
    """A pool worker: receive ``(index, unit)``, send back ``(index, result or failure)``,
    until it receives None or the parent's end closes.

    ``inherited``: the parent's ends of every pipe (forked into this process), closed here
    so that only the parent holds them: a worker that dies then shows the parent an end of
    file, never a pipe that another worker keeps open.
    """
    for other in inherited:
        other.close()
    _worker_init(mask)
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        index, unit = task
        out: UnitResult | UnitFailure | _Stopped
        try:
            out = _run_unit_caught(unit)
        except BaseException as exc:  # KeyboardInterrupt raised by the agent, say
            out = _Stopped(f"the agent raised {type(exc).__name__}"
                           + (f" ({exc})" if str(exc) else "") + " in its worker process")
        try:
            conn.send((index, out))
        except Exception as exc:  # a result that cannot be pickled, say
            conn.send((index, _Stopped(f"its result could not be sent back "
                                       f"({type(exc).__name__}: {exc})")))
        if isinstance(out, _Stopped):
            return


@dataclass(frozen=True, eq=False)
class _Worker:
    """A pool worker process and the parent's end of its pipe."""

    process: Any
    conn: Connection


def _start_pool(processes: int, method: str | None = None) -> list[_Worker]:
    """``processes`` workers (:func:`_pool_worker`), each with a pipe of its own, started
    with the stop signals blocked.

    They stay blocked in the parent only while it starts the workers (all at once, from this
    thread; a worker that dies is not replaced: the study ends). ``method``: the start method
    (None: the platform's default, fork on Linux).
    """
    ctx: Any = multiprocessing.get_context(method)
    forked = ctx.get_start_method() == "fork"
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
    workers: list[_Worker] = []
    try:
        for _ in range(processes):
            ours, theirs = ctx.Pipe()
            inherited = [*(w.conn for w in workers), ours] if forked else []
            process = ctx.Process(target=_pool_worker, args=(theirs, mask, inherited),
                                  daemon=True, name="hri-bench-worker")
            process.start()
            theirs.close()
            workers.append(_Worker(process, ours))
    except BaseException:
        _stop_pool(workers)
        raise
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    return workers


def _stop_pool(workers: Sequence[_Worker]) -> None:
    """End every worker now (SIGTERM, then SIGKILL after a second) and wait for it."""
    for w in workers:
        if w.process.is_alive():
            w.process.terminate()
    for w in workers:
        w.process.join(1.0)
        if w.process.is_alive():
            w.process.kill()
            w.process.join()
        w.conn.close()


def _death(worker: _Worker) -> str:
    """How a worker that ended without sending its unit's result ended, in words."""
    worker.process.join(1.0)
    code = worker.process.exitcode
    if code is None:
        return "its worker process closed its pipe"
    if code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        if -code == signal.SIGKILL:
            return (f"its worker process was killed ({name}: the kernel's out-of-memory "
                    "killer, or kill -9)")
        return f"its worker process was killed by {name}"
    return (f"its worker process ended with exit status {code} (the agent, or code it "
            "called, ended the process: os._exit?)")


#: The environment variable naming a file whose content is the time in seconds that the
#: unit time limit reads instead of the monotonic clock, in the parent's watchdog and in the
#: serial executor's alarm alike: a test advances it once its hanging agent is known to wait
#: (tests/test_study_workers.py), so that no unit ever runs over the limit on a loaded
#: machine's account. Unset (always, outside tests): :func:`time.monotonic`.
CLOCK_FILE = "HRI_BENCH_CLOCK_FILE"
#: How often the watchdogs look at a :data:`CLOCK_FILE`'s time (and re-check the real clock
#: after the alarm's first ring), in seconds.
_CLOCK_POLL_S = 0.05


def _clock() -> float:
    """The time the unit time limit is measured by (:data:`CLOCK_FILE`)."""
    path = os.environ.get(CLOCK_FILE)
    if not path:
        return time.monotonic()
    try:
        return float(Path(path).read_text())  # written whole (os.replace) by its test
    except (OSError, ValueError):  # not written yet: the clock's start
        return 0.0


def _wait_for(deadline: float) -> float | None:
    """How long a watchdog may wait for a unit that ends at ``deadline`` of :func:`_clock`
    (None: no limit); with a :data:`CLOCK_FILE`, at most :data:`_CLOCK_POLL_S`.
    """
    if math.isinf(deadline):
        return None
    left = max(0.0, deadline - _clock())
    return min(left, _CLOCK_POLL_S) if os.environ.get(CLOCK_FILE) else left


def _execute_pool(cfg: StudyConfig, units: list[Unit], todo: Sequence[int], method: str | None
                  ) -> Iterator[tuple[int, UnitResult | UnitFailure]]:
    """The units ``todo`` on ``min(jobs, len(todo))`` worker processes, as they finish.

    Each worker gets one unit at a time, so the parent knows which unit each one works on:
    a worker that dies, or a unit over :attr:`StudyConfig.unit_time_limit`, raises
    :class:`UnitLostError` naming that unit within a fraction of a second. Leaving the
    generator, normally or by an exception (Ctrl-C), stops every worker at once.
    """
    workers = _start_pool(min(cfg.jobs, len(todo)), method)
    queue = list(reversed(todo))
    busy: dict[_Worker, tuple[int, float]] = {}
    limit = cfg.time_limit()

    def assign(w: _Worker) -> None:
        if queue:
            i = queue.pop()
            w.conn.send((i, units[i]))
            busy[w] = (i, _clock())
        else:
            w.conn.send(None)

    try:
        for w in workers:
            assign(w)
        while busy:
            first = min(started for _, started in busy.values())
            ready = set(mp_wait([x for w in busy for x in (w.conn, w.process.sentinel)],
                                _wait_for(first + limit)))
            for w, (i, started) in list(busy.items()):
                if w.conn in ready:
                    try:
                        index, out = w.conn.recv()
                    except (EOFError, OSError):
                        raise _lost(units[i], _death(w)) from None
                    if isinstance(out, _Stopped):
                        raise _lost(units[i], out.reason)
                    del busy[w]
                    assign(w)
                    yield index, out
                elif w.process.sentinel in ready:
                    raise _lost(units[i], _death(w))
                elif _clock() - started > limit:
                    raise _lost(units[i], _over_time(limit))
    finally:
        _stop_pool(workers)


class _TimeUp(BaseException):
    """A serial unit's time is up (raised by SIGALRM's handler; not an agent's Exception)."""


@contextlib.contextmanager
def _alarm(seconds: float) -> Iterator[None]:
    """Raise :class:`_TimeUp` in this thread once ``seconds`` of :func:`_clock` have passed
    (SIGALRM: its first ring after ``seconds`` of wall time, then every
    :data:`_CLOCK_POLL_S` until the clock says so; with a :data:`CLOCK_FILE`, every
    :data:`_CLOCK_POLL_S` from the start).

    Only in the main thread, and only when no other interval timer is running (a test
    runner's, say); elsewhere, and for ``inf``, no limit.
    """
    if (math.isinf(seconds) or threading.current_thread() is not threading.main_thread()
            or signal.getitimer(signal.ITIMER_REAL)[0] > 0):
        yield
        return
    started = _clock()

    def ring(signum: int, frame: Any) -> None:
        if _clock() - started > seconds:
            raise _TimeUp

    previous = signal.signal(signal.SIGALRM, ring)
    first = _CLOCK_POLL_S if os.environ.get(CLOCK_FILE) else seconds
    signal.setitimer(signal.ITIMER_REAL, first, _CLOCK_POLL_S)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _execute(cfg: StudyConfig, units: list[Unit], todo: Sequence[int]
             ) -> Generator[tuple[int, UnitResult | UnitFailure], None, None]:
    """Yield (unit index, result or failure) for the units ``todo`` as they finish.

    Nothing is started (no pool, no Ray) when ``todo`` is empty. A unit that cannot finish
    (its worker died, or it ran past the time limit) raises :class:`UnitLostError`; in the
    serial executor the limit interrupts the agent's Python code (SIGALRM, main thread only).
    """
    if not todo:
        return
    if cfg.executor == "serial" or (cfg.executor == "process" and cfg.jobs == 1):
        for i in todo:
            try:
                with _alarm(cfg.time_limit()):
                    out = _run_unit_caught(units[i])
            except _TimeUp:
                raise _lost(units[i], _over_time(cfg.time_limit())) from None
            yield i, out
    elif cfg.executor == "process":
        for spec in filter(None, map(AGENTS.find, dict.fromkeys(cfg.agents))):
            if spec.warm is not None:
                spec.warm()  # e.g. the Learner's compiled kernels: forked workers inherit them
        # JAX's runtime is multithreaded: a worker forked after it started in this process
        # can hang for good, so once anything here imported JAX (the jaxppo agents, a custom
        # agent, the caller) the workers start fresh (spawn).
        method = "spawn" if "jax" in sys.modules else None
        yield from _execute_pool(cfg, units, todo, method)
    else:
        yield from _execute_ray(cfg, [units[i] for i in todo], list(todo))


def _execute_ray(cfg: StudyConfig, units: list[Unit], index: list[int]
                 ) -> Iterator[tuple[int, UnitResult | UnitFailure]]:
    """The units on Ray, at most ``jobs`` in flight, as they finish; a task whose worker
    fails, or that runs past the time limit (counted from its submission), raises
    :class:`UnitLostError`.
    """
    try:
        import ray
    except ImportError as exc:
        raise MissingExtraError(["ray"], "executor 'ray'") from exc
    if not ray.is_initialized():
        ray.init(address=cfg.ray_address, num_cpus=None if cfg.ray_address else cfg.jobs,
                 include_dashboard=False, log_to_driver=False)
    remote = ray.remote(_run_unit_caught)
    queue = list(reversed(list(zip(units, index, strict=True))))
    running: dict[Any, tuple[Unit, int, float]] = {}
    limit = cfg.time_limit()
    try:
        while queue or running:
            while queue and len(running) < cfg.jobs:
                unit, i = queue.pop()
                running[remote.remote(unit)] = (unit, i, _clock())
            first = min(started for _, _, started in running.values())
            done, _ = ray.wait(list(running), num_returns=1, timeout=_wait_for(first + limit))
            if not done:
                unit, _, started = min(running.values(), key=lambda x: x[2])
                if _clock() - started > limit:
                    raise _lost(unit, _over_time(limit))
                continue
            unit, i, _ = running.pop(done[0])
            try:
                out = ray.get(done[0])
            except ray.exceptions.RayError as exc:
                raise _lost(unit, f"its Ray task failed ({type(exc).__name__}: "
                                          f"{str(exc).splitlines()[0] if str(exc) else ''})"
                                    ) from None
            yield i, out
    finally:
        for ref in running:
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)


def run_study(
    cfg: StudyConfig,
    *,
    progress: bool = False,
    on_unit: Callable[[], None] | None = None,
    done: Mapping[int, UnitResult] | None = None,
    on_result: Callable[[int, UnitResult], None] | None = None,
    keep_going: bool = False,
) -> StudyResult:
    """Simulate a study and gather per-run arrays in run order.

    Args:
        cfg: What to simulate.
        progress: Show a progress bar (tqdm) over work units.
        on_unit: Called after each finished unit (for callers with their own progress).
        done: Results of units already simulated, by their index in the study's units
            (a resumed study, :mod:`hri_bench.run.studyio`); they are not run again.
        on_result: Called as ``on_result(index, result)`` when a unit finishes (to save it).
        keep_going: When an agent raises, record it in :attr:`StudyResult.failures` (its
            traceback) and drop that agent from the result instead of raising.

    Raises:
        UnitLostError: A unit could not finish: its worker process died, or it ran past
            ``cfg.unit_time_limit`` (whatever ``keep_going``); the units finished before it
            were passed to ``on_result``.
    """
    units = study_units(cfg)
    done = dict(done or {})
    n_e, n_p = cfg.n_episodes, len(cfg.probes)
    keys = METRICS + batch_backend(cfg.backend).extras + TASK_METRICS
    metrics = {a: {k: np.zeros((cfg.runs, n_e)) for k in keys} for a in cfg.agents}
    probes = {a: np.full((cfg.runs, n_e + 1, n_p), np.nan) for a in cfg.agents}
    schedule = {k: np.zeros((cfg.runs, n_e), dtype=bool if k == "turn_back" else np.int64)
                for k in ("start", "goal", "turn_back")}
    failures: dict[str, str] = {}

    humans = ["" for _ in range(cfg.runs)]

    def place(i: int, res: UnitResult) -> None:
        m, p, sched, labels = res
        u = units[i]
        rows = list(u.runs)
        for r, label in zip(rows, labels, strict=True):
            humans[r] = label
        for k in keys:
            metrics[u.agent][k][rows] = m[k]
        probes[u.agent][rows] = p
        for k in schedule:
            schedule[k][rows] = sched[k]

    for i, finished in done.items():
        place(i, finished)
    todo = [i for i in range(len(units)) if i not in done]
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(units), initial=len(done), desc=f"{cfg.scenario} study",
                   unit="batch", leave=False)
    t0 = time.perf_counter()
    try:
        # closing(): an exception here stops the pool now, not when the generator is freed.
        with contextlib.closing(_execute(cfg, units, todo)) as executed:
            for i, res in executed:
                if isinstance(res, UnitFailure):
                    if not keep_going:
                        raise res.error
                    failures.setdefault(res.agent, res.traceback)
                else:
                    place(i, res)
                    if on_result is not None:
                        on_result(i, res)
                if bar is not None:
                    bar.update(1)
                if on_unit is not None:
                    on_unit()
    finally:
        if bar is not None:
            bar.close()
    for name in failures:
        del metrics[name], probes[name]
    return StudyResult(cfg, metrics, probes, schedule, time.perf_counter() - t0,
                       humans=humans, failures=failures)


#: The file that computes regret, as the checkout holds it (derived from the module).
REGRET_SOURCE = Path(blind_values.__code__.co_filename).resolve().relative_to(
    Path(__file__).resolve().parents[2]).as_posix()
#: How the suites record regret, word for word as version 1 wrote it (its files are
#: reproduced byte for byte): the file has moved to :data:`REGRET_SOURCE` since.
_RECORDED_REGRET = ("blind's exact expected episode reward from the episode's start support "
                    "minus the agent's reward, mean over runs (hri_bench/regret.py)")


def regret_reference(result: StudyResult, *, recorded: bool = True
                     ) -> tuple[np.ndarray | None, str]:
    """Blind's exact expected reward per (run, episode) and how regret is computed; None
    (with the reason) where the exact blind plan is too large for the study's human.

    Args:
        result: The study.
        recorded: The note as the suites record it (frozen); False: as a study's
            ``summary.json`` and console say it, naming the file that computes regret and,
            where no exact plan fits, whether the references of a bracket ran.
    """
    try:
        values = blind_values(result)
    except ConfigError as exc:
        note = f"not reported: {exc}"
        return None, note if recorded else what_ran(note, result.config.agents)
    if recorded:
        return values, _RECORDED_REGRET
    return values, _RECORDED_REGRET.rsplit("(", 1)[0] + f"({REGRET_SOURCE})"


def summarize(result: StudyResult) -> dict[str, Any]:
    """The ``summary.json`` document (docs/benchmark.md, 'summary.json').

    Identical for identical settings and seed (no wall time: that goes to the run log of
    :mod:`hri_bench.run.studyio`), so a resumed or replayed study's file is byte-identical.
    """
    cfg = result.config
    agents: dict[str, Any] = {}
    blind, regret_note = regret_reference(result, recorded=False)
    for name, m in result.metrics.items():
        r = m["reward"]
        agents[name] = {
            "reward": {"mean": r.mean(0).tolist(), "median": np.median(r, 0).tolist(),
                       "q25": np.percentile(r, 25, 0).tolist(),
                       "q75": np.percentile(r, 75, 0).tolist()},
            **({} if blind is None else {"regret": {"mean": (blind - r).mean(0).tolist()}}),
            **{k: {"mean": m[k].mean(0).tolist()} for k in ("correct", "passive", "wrong")},
            "truncated": {"mean": m["truncated"].mean(0).tolist()},
            "overall": {"reward_mean": float(r.mean()), "reward_median": float(np.median(r)),
                        "truncation_rate": float(m["truncated"].mean()),
                        "truncated_episodes": int(m["truncated"].sum())},
            **{k: {"mean": m[k].mean(0).tolist()} for k in _backend_extras(m)},
        }
        # Statistics (docs/benchmark.md): per episode and over all episodes, bootstrap
        # seeded by the study seed.
        for k in ("reward", "correct", "passive", "wrong"):
            pe = stats.per_episode(m[k], cfg.seed, iqm_ci=k == "reward")
            agents[name][k].update(pe, overall=stats.aggregate(m[k], cfg.seed,
                                                                iqm_ci=k == "reward"))
    prefs = sorted(set(cfg.preference_of_run()))
    spec = cfg.spec
    return {
        "scenario": cfg.scenario,
        "backend": cfg.backend,
        "physics_preset": cfg.physics_preset,
        "schedule": cfg.schedule,
        # With a population each run has its own human (see episodes.csv).
        "preference": None if cfg.population else prefs[0] if len(prefs) == 1 else "all",
        "r0": cfg.waiting_reward,
        "human_passive": cfg.human_passive,
        "turn_back": cfg.turn_back,
        "max_steps": cfg.max_steps,
        "runs": cfg.runs,
        "episodes": cfg.n_episodes,
        "seed": cfg.seed,
        "human_rationality": _json_float(cfg.human_rationality),
        "population": cfg.population,
        "human_drift": cfg.human_drift,
        "human_params": _jsonable(cfg.human_params),
        "population_info": cfg.population_info(),
        "learner": agent_settings("learner", cfg.spec, cfg.waiting_reward,
                                  dict(cfg.learner)),
        "version": __version__,
        "env_ids": {"gymnasium": spec.panda_id if BACKENDS[cfg.backend].physical
                    else spec.gym_id,
                    "pettingzoo": spec.pettingzoo_module},
        "settings": cfg.settings(),
        "agent_configs": {a: agent_settings(a, cfg.spec, cfg.waiting_reward,
                                            dict(cfg.learner))
                          for a in cfg.agents},
        "failed_agents": sorted(result.failures),
        "reward_rule": cfg.reward,
        "regret": regret_note,
        "references": {k: v for k, v in ALL_REFERENCES.items() if k in result.metrics},
        "reference": reference_summary(result),
        "agents": agents,
        "probability_of_improvement": {
            "metric": "reward",
            "table": stats.improvement_table({a: m["reward"] for a, m in result.metrics.items()}),
        },
    }


def write_outputs(result: StudyResult, out: str | os.PathLike[str], *, plots: bool = True
                  ) -> list[Path]:
    """Write ``summary.json``, ``episodes.csv`` and the plots into ``out``; return the paths.

    Every file is written under a temporary name, flushed to disk and renamed into place,
    plots first and ``summary.json`` last, so an interrupted write never leaves a
    complete-looking file, and a ``summary.json`` in place means that every file is.

    Raises:
        OSError: A file cannot be written (its ``filename`` names it; the temporary files
            are removed).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = result.config
    paths: list[Path] = []
    if plots and result.metrics:
        from hri_bench.core import plots as plotting  # matplotlib: the bench extra

        with tempfile.TemporaryDirectory(dir=out, prefix=".plots-") as tmp:
            try:
                made = plotting.study_plots(result, Path(tmp))
            except OSError as exc:  # a full disk, say: name the folder (atomic_path's way)
                exc.filename = exc.filename or str(out)
                raise
            for p in made:
                move_into_place(p, out / p.name)
                paths.append(out / p.name)
    csv_path = out / "episodes.csv"
    prefs = result.humans if cfg.per_run_humans and result.humans else cfg.preference_of_run()
    extras = _backend_extras(next(iter(result.metrics.values()), {}))  # the task's: in the suite's
    with atomic_writer(csv_path, newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["agent", "run", "episode", "preference", "start", "goal", "turn_back",
                         *METRICS, *extras])
        names = cfg.graph.support_names
        s = result.schedule
        for agent, m in result.metrics.items():
            for r in range(cfg.runs):
                for e in range(cfg.n_episodes):
                    writer.writerow([
                        agent, r, e + 1, prefs[r], names[s["start"][r, e]], names[s["goal"][r, e]],
                        int(s["turn_back"][r, e]), round(m["reward"][r, e], 6),
                        *(round(m[k][r, e], 6) for k in ("correct", "passive", "wrong")),
                        int(m["steps"][r, e]), int(m["truncated"][r, e]),
                        *(round(m[k][r, e], 6) for k in extras),
                    ])
    summary_path = out / "summary.json"
    with atomic_writer(summary_path) as f:
        f.write(json.dumps(summarize(result), indent=1, allow_nan=False) + "\n")
    return [summary_path, csv_path, *paths]
