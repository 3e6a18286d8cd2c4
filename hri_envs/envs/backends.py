"""Simulation backends by name: what the envs and the benchmark run an episode on.

A backend has two faces, both looked up here by its name so that no caller compares names:

* an :class:`~hri_envs.envs.episode.Episode` subclass, one running episode with scalar
  state, for the single-episode envs;
* a :class:`BatchBackend` subclass, which advances the runs of a study for the benchmark's
  one simulation loop (:func:`hri_bench.run.runner.simulate`).

Both are named as ``"module:Class"`` entry points (Gymnasium's convention) and imported only
when used, so an optional backend costs nothing until it is asked for, and a missing extra
gives one line with the install command. :func:`register_backend` adds a backend of your own.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from hri_envs.envs.episode import Episode
from hri_envs.errors import BackendUnavailableError, ConfigError, install_command
from hri_envs.humans.spec import HumanBody
from hri_envs.registry import Registry
from hri_envs.task.graph import TaskGraph

__all__ = [
    "BACKENDS",
    "BackendSpec",
    "BatchBackend",
    "BatchStep",
    "DEFAULT_UNIT_TIME_LIMIT",
    "GraphBatch",
    "backend_spec",
    "batch_backend",
    "body_options",
    "carry_backend",
    "carry_vector_backend",
    "check_backend",
    "episode_backend",
    "options_checker",
    "register_backend",
]


#: A study's default time limit per unit of work (:attr:`BackendSpec.unit_time_limit`):
#: generous, as a unit is at most 1,000 episodes on the graph backend (well under a minute
#: for the built-in agents) or one run on the MuJoCo backend (at most 20 episodes × 100 steps
#: of about 0.2 s).
DEFAULT_UNIT_TIME_LIMIT = 3600.0


@dataclass(frozen=True)
class BackendSpec:
    """A registered backend.

    Attributes:
        name: What ``backend=`` says.
        episode: ``"module:Class"`` of its :class:`~hri_envs.envs.episode.Episode`.
        batch: ``"module:Class"`` of its :class:`BatchBackend`.
        requires: Modules it needs (checked before it is loaded).
        extra: The ``hri-envs`` extra that installs them.
        vectorizable: The numpy vector env can run it (only table look-ups can).
        options: ``"module:function"`` checking its ``physics={...}`` options (it returns
            them checked, or raises a :class:`~hri_envs.errors.ConfigError` naming the key);
            None: the backend takes no options.
        presets: Names ``physics={"preset": ...}`` (and ``--physics-preset``) accepts (the
            checker knows them too; listed here for help texts that must not import it).
        body: ``"module:function"`` turning a :class:`~hri_envs.humans.spec.HumanBody` (a
            ``HumanSpec(body=...)``) into its ``physics`` options (checked, or a
            :class:`~hri_envs.errors.ConfigError` with ``field="human"``); None: the backend
            has no physical human, and refuses a body.
        batch_runs: Its :class:`BatchBackend` simulates many runs at once (a study hands it
            chunks of runs rather than one run at a time).
        physical: It simulates the Panda (its Gymnasium id is the scenario's Panda id).
        vector_entry: ``"module:Class"`` of a vector env that steps many envs of this
            backend at once (``gymnasium.make_vec(..., vectorization_mode=
            "vector_entry_point", backend=...)``), None: refused.
        carry: ``"module:callable"`` making the continuous envs' simulation (the arguments
            of :class:`~hri_envs.physics.carry.sim.CarrySim`), None: the continuous envs do
            not run on it.
        carry_drives: The human arm's drives it runs (``CarryEnv(drive=...)``).
        carry_vector: ``"module:Class"`` of the continuous envs' vector env (``gymnasium.
            make_vec("hri_envs/HangerPandaContinuous-v0", ..., "vector_entry_point")``),
            None: refused.
        unit_time_limit: The default most wall seconds one unit of a study's work may take
            on it (``hri-bench study --unit-time-limit``); ``inf``: no limit.
    """

    name: str
    episode: str
    batch: str
    requires: tuple[str, ...] = ()
    extra: str | None = None
    vectorizable: bool = False
    options: str | None = None
    presets: tuple[str, ...] = ()
    body: str | None = None
    batch_runs: bool = False
    physical: bool = False
    vector_entry: str | None = None
    carry: str | None = None
    carry_drives: tuple[str, ...] = ()
    carry_vector: str | None = None
    unit_time_limit: float = DEFAULT_UNIT_TIME_LIMIT


def _check(spec: BackendSpec) -> None:
    """What :func:`register_backend` checks (its docstring)."""
    entries = {"episode": spec.episode, "batch": spec.batch, "options": spec.options,
               "body": spec.body, "vector_entry": spec.vector_entry, "carry": spec.carry,
               "carry_vector": spec.carry_vector}
    for field, entry in entries.items():
        if entry is None and field not in ("episode", "batch"):
            continue
        if not (isinstance(entry, str) and all(entry.partition(":")[::2])):
            raise ConfigError(f"backend {spec.name!r}: {field} must be a 'module:name' entry "
                              f"point, got {entry!r}", field="backend")
    for field in ("requires", "presets", "carry_drives"):
        value = getattr(spec, field)
        if not (isinstance(value, tuple) and all(isinstance(v, str) and v for v in value)):
            raise ConfigError(f"backend {spec.name!r}: {field} must be a tuple of names, got "
                              f"{value!r}", field="backend")
    for field in ("presets", "body"):
        if getattr(spec, field) and spec.options is None:
            raise ConfigError(f"backend {spec.name!r} names {field} but no options checker to "
                              "accept them", field="backend")
    if not (isinstance(spec.unit_time_limit, int | float) and spec.unit_time_limit > 0):
        raise ConfigError(f"backend {spec.name!r}: unit_time_limit must be a number of "
                          f"seconds > 0 (inf: none), got {spec.unit_time_limit!r}",
                          field="backend")


#: The backends, by name (:func:`register_backend`; a :class:`~hri_envs.registry.Registry`).
BACKENDS: Registry[BackendSpec] = Registry("backend", BackendSpec, field="backend",
                                           check=_check)


def register_backend(spec: BackendSpec, *, replace: bool = False) -> BackendSpec:
    """Make ``spec.name`` a valid ``backend=`` for the envs and ``hri-bench study``; returns
    it.

    Nothing of the backend is imported here (its extra may be missing);
    :func:`hri_envs.conformance.check_backend` loads it and runs it.

    Args:
        spec: The backend.
        replace: Replace the backend registered under its name (otherwise refused).

    Raises:
        ConfigError: ``spec`` is not a :class:`BackendSpec` or has no name, an entry point
            is not ``"module:name"``, ``requires``, ``presets`` or ``carry_drives`` is not a
            tuple of names, it names presets or a body without an options checker, its
            ``unit_time_limit`` is not > 0, or its name is another backend's and
            ``replace`` is False.
    """
    return BACKENDS.register(spec, replace=replace)


register_backend(BackendSpec("graph", "hri_envs.envs.episode:Episode",
                             "hri_envs.envs.backends:GraphBatch", vectorizable=True))
register_backend(BackendSpec("mujoco", "hri_envs.physics.panda.episode:PhysicsEpisode",
                             "hri_envs.physics.panda.batch:PhysicsBatch",
                             requires=("mujoco", "mink", "gymnasium_robotics"), extra="mujoco",
                             options="hri_envs.physics.panda.options:check_options",
                             presets=("weak-human", "noisy-sensor"), physical=True,
                             body="hri_envs.physics.panda.options:body_options",
                             carry="hri_envs.physics.carry.sim:CarrySim",
                             carry_drives=("torque", "muscle")))
# The same physics, many worlds at once on MuJoCo Warp (docs/physics.md, "Many worlds").
register_backend(BackendSpec("mjwarp", "hri_envs.physics.panda.warp.episode:WarpPhysicsEpisode",
                             "hri_envs.physics.panda.warp.batch:WarpPhysicsBatch",
                             requires=("mujoco", "mink", "gymnasium_robotics", "warp",
                                       "mujoco_warp", "mink_warp"), extra="mjwarp",
                             options="hri_envs.physics.panda.options:check_options",
                             presets=("weak-human", "noisy-sensor"), batch_runs=True,
                             body="hri_envs.physics.panda.options:body_options",
                             physical=True,
                             vector_entry="hri_envs.physics.panda.warp.vector:PandaVectorEnv",
                             carry="hri_envs.physics.carry.warp.sim:make_carry_sim",
                             carry_drives=("torque",),
                             carry_vector="hri_envs.physics.carry.warp.vector:CarryVectorEnv",
                             # a unit batches up to 1,000 episodes into its worlds, whose speed
                             # is the device's: hours on a CPU
                             unit_time_limit=math.inf))


def backend_spec(name: str) -> BackendSpec:
    """The registered backend ``name``; a clear error for an unknown or unavailable one."""
    spec = BACKENDS.get(name)
    missing = [m for m in spec.requires if importlib.util.find_spec(m) is None]
    if missing:
        raise BackendUnavailableError(
            f"backend={name!r} needs {', '.join(missing)}: "
            f"{install_command([spec.extra or name])}; or use backend='graph', the abstract "
            "transition graph", field="backend")
    return spec


def check_backend(backend: str) -> str:
    """Validate a backend name (registered, and its extra installed)."""
    return backend_spec(backend).name


def _load(entry: str) -> Any:
    module, _, attr = entry.partition(":")
    return getattr(importlib.import_module(module), attr)


def options_checker(name: str) -> Callable[[Mapping[str, Any]], dict[str, Any]] | None:
    """The function checking backend ``name``'s ``physics`` options (None: it takes none)."""
    entry = backend_spec(name).options
    return None if entry is None else _load(entry)


def body_options(name: str, body: HumanBody) -> dict[str, Any]:
    """The ``physics`` options of backend ``name`` that a :class:`~hri_envs.humans.spec.
    HumanBody` describes (:attr:`BackendSpec.body`).

    Raises:
        ConfigError: (``field="human"``) The backend has no physical human, or it refuses
            the body.
    """
    entry = backend_spec(name).body
    if entry is None:
        takes = [n for n, spec in BACKENDS.items() if spec.body]
        raise ConfigError(f"backend={name!r} has no physical human: HumanSpec.body applies "
                          f"to the backends {', '.join(takes)} and the continuous envs",
                          field="human")
    options: dict[str, Any] = _load(entry)(body)
    return options


def episode_backend(name: str) -> type[Episode]:
    """The :class:`~hri_envs.envs.episode.Episode` class of backend ``name``."""
    cls: type[Episode] = _load(backend_spec(name).episode)
    return cls


def carry_backend(name: str, drive: str) -> Callable[..., Any]:
    """What makes the continuous envs' simulation on backend ``name`` with the arm's
    ``drive`` (the arguments of :class:`~hri_envs.physics.carry.sim.CarrySim`).

    Raises:
        ConfigError: The continuous envs do not run on ``name``, or not with ``drive``
            (naming what is allowed).
    """
    spec = backend_spec(name)
    if spec.carry is None:
        allowed = [n for n, s in BACKENDS.items() if s.carry is not None]
        raise ConfigError(f"the continuous envs do not run on backend={name!r}; allowed: "
                          f"{', '.join(allowed)}", field="backend")
    if drive not in spec.carry_drives:
        raise ConfigError(f"drive={drive!r} does not run on backend={name!r}; allowed there: "
                          f"{', '.join(spec.carry_drives)}", field="drive")
    maker: Callable[..., Any] = _load(spec.carry)
    return maker


def carry_vector_backend(name: str) -> Any:
    """The continuous envs' vector env class on backend ``name``.

    Raises:
        ConfigError: ``name`` has none (naming the backends that have one).
    """
    spec = backend_spec(name)
    if spec.carry_vector is None:
        allowed = [n for n, s in BACKENDS.items() if s.carry_vector is not None]
        raise ConfigError(f"the continuous envs have no vector env on backend={name!r}; "
                          f"allowed: {', '.join(allowed)} (or vectorization_mode='async' for "
                          "C worlds in processes)", field="backend")
    return _load(spec.carry_vector)


def batch_backend(name: str) -> type[BatchBackend]:
    """The :class:`BatchBackend` class of backend ``name``."""
    cls: type[BatchBackend] = _load(backend_spec(name).batch)
    return cls


class BatchStep(NamedTuple):
    """One joint step of a batch of runs, as a :class:`BatchBackend` reports it.

    Attributes:
        next_state: (B,) int, the state each run reached.
        human_seen: (B,) int, the human's action as the robot observes it.
        fault: (B,) bool, the run cannot go on (it is truncated), or None for no faults.
        extras: Per-run figures of this step, (B,) each, keyed as :attr:`BatchBackend.extras`.
        penalty: (B,) bool, the step failed physically (the object dropped, ...) and earns
            r⁻ whatever the graph says; None for never.
    """

    next_state: np.ndarray
    human_seen: np.ndarray
    fault: np.ndarray | None
    extras: dict[str, np.ndarray]
    penalty: np.ndarray | None = None


class BatchBackend(ABC):
    """How the benchmark's simulation loop moves a batch of runs.

    Args:
        graph: The task graph.
        runs: The run indices of the batch (a backend's random streams derive from
            ``(seed, run, ...)`` only, so numbers do not depend on the batching).
        seed: The study's base seed.
        physics: Validated ``physics`` options (:func:`hri_envs.envs.config.
            check_physics_options`); a backend without options gets none.
    """

    #: Per-episode figures the backend adds to the metrics (summed over the steps).
    extras: ClassVar[tuple[str, ...]] = ()
    #: Those of :attr:`extras` reported as a mean per step rather than a sum.
    step_means: ClassVar[tuple[str, ...]] = ()

    def __init__(self, graph: TaskGraph, runs: Sequence[int] | np.ndarray, seed: int,
                 physics: Mapping[str, Any] | None = None) -> None:
        self.graph = graph
        self.physics = dict(physics or {})
        self.runs = np.asarray(runs, dtype=np.int64)
        self.seed = int(seed)

    def groups(self) -> list[np.ndarray]:
        """Row indices of the runs simulated together, one group after the other."""
        return [np.arange(len(self.runs))]

    def begin(self, rows: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Place the runs ``rows`` at their start supports; (len(rows),) bool: cannot start."""
        return np.zeros(len(rows), dtype=bool)

    @abstractmethod
    def transition(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                   active: np.ndarray) -> BatchStep:
        """Where the joint actions take the ``active`` runs (other rows are ignored)."""


class GraphBatch(BatchBackend):
    """The ``"graph"`` backend of the benchmark: all runs in lockstep, by table look-up."""

    def transition(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                   active: np.ndarray) -> BatchStep:
        """The graph's ``next_state[s, a_R, a_H]``; the robot sees the human's true action."""
        return BatchStep(self.graph.next_state[state, a_r, a_h], a_h, None, {})
