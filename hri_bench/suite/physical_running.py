"""Running the physical suite: every track's runs, the results file, the leaderboard.

``hri-bench suite --physical --out DIR`` runs the version's tracks
(:mod:`hri_bench.suite.physical_tracks`) with the robot agents named and the references,
in units of a few runs of one agent (:func:`hri_bench.run.physical.simulate_unit`), on
``--jobs`` processes, and writes

* ``DIR/results.json``: the physical results file (:mod:`hri_bench.suite.physical_results`);
* ``DIR/leaderboard.md``: the headline and the tracks (:mod:`hri_bench.suite.physical_board`);
* ``DIR/ranking.png``, ``DIR/goal_effort.png``: the headline with its CIs; per track each
  agent's goal rate against the human's effort;
* ``DIR/suite_log.json``: the wall time, the units' CPU time, the jobs and the load.

Every finished unit is kept in ``DIR/.physical-units/`` (a few kB each), so ``--resume``
after an interruption runs only the rest, and gives the same files (every draw of a run
comes from the suite seed, the track and the run); ``--resume`` with more robots in
``--agents`` after a suite ended runs only the new robots' units (the references' and the
others' are kept). ``--overwrite`` starts afresh.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.core.atomic import atomic_writer
from hri_bench.run import provenance
from hri_bench.run.folders import FolderLock
from hri_bench.run.physical import FIGURES, PhysicalUnit, simulate_unit
from hri_bench.suite import physical_results as pr
from hri_bench.suite.physical_board import leaderboard, write_figures
from hri_bench.suite.physical_tracks import (
    DEFAULT_AGENTS,
    FLOOR,
    PHYSICAL_LATEST,
    REFERENCE,
    PhysicalTrack,
    check_physical_version,
    select_physical_tracks,
    track_runs,
)
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph

__all__ = ["RUNS_PER_UNIT", "UNITS_DIR", "is_custom", "make_robot", "physical_suite_hash",
           "plan_units", "run_physical_suite"]

#: Runs per unit of work (one agent, one track): small enough to keep both cores busy and
#: lose little to an interruption.
RUNS_PER_UNIT = 4
UNITS_DIR = ".physical-units"
#: A unit's CPU seconds (its process's), kept beside its figures for ``suite_log.json``.
CPU_KEY = "cpu_s"


def physical_suite_hash(version: str, tracks: Sequence[PhysicalTrack]) -> str:
    """sha256 of the version, its tracks' definitions and their populations' content."""
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    doc = {"version": version, "tracks": [
        {**asdict(t), "population_hash": physical_population(t.population,
                                                             t.graph).content_hash()}
        for t in tracks]}
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def plan_units(tracks: Sequence[PhysicalTrack], agents: Sequence[str], seed: int,
               runs_scale: float) -> list[PhysicalUnit]:
    """The suite's work: per track and agent, chunks of :data:`RUNS_PER_UNIT` runs."""
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    units = []
    for t in tracks:
        pop = physical_population(t.population, t.graph)
        runs = list(range(track_runs(t, runs_scale)))
        members = [pop.member_index(seed, r) for r in runs]
        for agent in agents:
            for i in range(0, len(runs), RUNS_PER_UNIT):
                chunk = runs[i:i + RUNS_PER_UNIT]
                units.append(PhysicalUnit(t.name, t.scenario, agent, t.population,
                                          tuple(members[r] for r in chunk), tuple(chunk),
                                          t.episodes, seed))
    return units


def _key(unit: PhysicalUnit) -> str:
    text = json.dumps(asdict(unit), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def is_custom(name: str) -> bool:
    """Whether ``name`` is a robot of your own (``module:Class``), not a registry name."""
    return ":" in name


def make_robot(name: str, graph: TaskGraph, stream: np.random.Generator) -> Any:
    """A robot for one run on ``graph``'s scenario, seeded from the run's own stream: a
    registry robot here, a ``module:Class`` in a process of its own
    (:mod:`hri_bench.run.physical_host`).
    """
    if is_custom(name):
        from hri_bench.run.physical_host import IsolatedPhysicalAgent  # noqa: PLC0415

        return IsolatedPhysicalAgent(name, graph,
                                     np.frombuffer(stream.bytes(32), dtype=np.uint8))
    from baselines.physical import make_physical_agent  # noqa: PLC0415

    return make_physical_agent(name, graph, int(stream.integers(2**31)))


def _work(unit: PhysicalUnit) -> dict[str, np.ndarray]:
    """One unit in a worker (or in the parent with one job)."""
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    humans = physical_population(unit.population, unit.graph).members
    cpu = time.process_time()
    figures = simulate_unit(unit, make_robot, humans)
    figures[CPU_KEY] = np.array(time.process_time() - cpu)  # this process's (robots' hosts
    return figures                                          # of your own not counted)


def _execute(units: Sequence[PhysicalUnit], store: Path, jobs: int,
             progress: Callable[[int, int], None]) -> None:
    """Runs the units not in ``store`` (each result saved there as it ends)."""
    todo = [u for u in units if not (store / f"{_key(u)}.npz").exists()]
    done = len(units) - len(todo)
    progress(done, len(units))

    def keep(unit: PhysicalUnit, figures: dict[str, np.ndarray]) -> None:
        nonlocal done
        tmp = store / f"{_key(unit)}.tmp.npz"
        np.savez(tmp, **figures)  # type: ignore[arg-type]
        os.replace(tmp, store / f"{_key(unit)}.npz")
        done += 1
        progress(done, len(units))

    if jobs <= 1:
        for u in todo:
            keep(u, _work(u))
        return
    with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(_work, u): u for u in todo}
        for fut in as_completed(futures):
            keep(futures[fut], fut.result())


def _load(store: Path, unit: PhysicalUnit) -> tuple[dict[str, np.ndarray], float]:
    """A finished unit's figures and CPU seconds."""
    with np.load(store / f"{_key(unit)}.npz", allow_pickle=False) as z:
        return {k: z[k] for k in FIGURES}, float(z[CPU_KEY]) if CPU_KEY in z else 0.0


def _assemble(tracks: Sequence[PhysicalTrack], runs_scale: float,
              units: Sequence[PhysicalUnit], store: Path) -> tuple[dict[str, Any], float]:
    """The ``runs[seed]`` block of one seed's ``units`` (per track each run's human and each
    agent's figures, the agents in the units' order) and the units' CPU seconds.
    """
    sizes = {t.name: (track_runs(t, runs_scale), t.episodes) for t in tracks}
    humans = {t: [0] * n for t, (n, _) in sizes.items()}
    figures: dict[str, dict[str, dict[str, np.ndarray]]] = {t: {} for t in sizes}
    cpu = 0.0
    for u in units:
        loaded, seconds = _load(store, u)
        cpu += seconds
        figs = figures[u.track].setdefault(
            u.agent, {k: np.full(sizes[u.track], np.nan) for k in FIGURES})
        for k in FIGURES:
            figs[k][list(u.runs)] = loaded[k]
        for r, m in zip(u.runs, u.members, strict=True):
            humans[u.track][r] = int(m)
    return {t: {"humans": humans[t], "agents": {a: pr.round_runs(f) for a, f in by.items()}}
            for t, by in figures.items()}, cpu


def _members(t: PhysicalTrack) -> list[dict[str, Any]]:
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    pop = physical_population(t.population, t.graph)
    return [{"family": f, "label": lab, "fingerprint": fp}
            for f, lab, fp in zip(pop.families, pop.labels, pop.fingerprints, strict=True)]


def _agent_entry(name: str) -> dict[str, Any]:
    if is_custom(name):
        from hri_bench.run.agents import source_identity  # noqa: PLC0415
        from hri_bench.run.physical_host import describe_physical  # noqa: PLC0415

        info = describe_physical(name)
        return {"privileged": False, "reference": False,
                "description": f"{info['module']}.{info['class']} (your own)",
                "identity": {"kind": "custom", "module": info["module"],
                             "class": info["class"], "constructor": list(info["keywords"]),
                             **source_identity(info["module"])}}
    from baselines.physical import PHYSICAL_AGENTS  # noqa: PLC0415

    entry = PHYSICAL_AGENTS[name]
    return {"privileged": bool(entry.privileged), "reference": bool(entry.reference),
            "description": entry.description,
            "identity": {"kind": "builtin", "package": "hri-envs",
                         "version": provenance.software()["hri-envs"]}}


def run_physical_suite(out: str | os.PathLike[str], *, version: str = PHYSICAL_LATEST,
                       agents: Sequence[str] | None = None, seeds: Sequence[int] = (0,),
                       runs_scale: float = 1.0, jobs: int = 1,
                       tracks: str | Sequence[str] | None = None, resume: bool = False,
                       overwrite: bool = False,
                       progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Run the physical suite into ``out`` (module docstring); the results document.

    Raises:
        ConfigError: A bad version, track, agent, scale or job count, or an ``out`` that
            holds files and neither ``resume`` nor ``overwrite`` was given.
    """
    version = check_physical_version(version)
    chosen = select_physical_tracks(tracks, version)
    ranked = list(DEFAULT_AGENTS if agents is None else agents)
    from baselines.physical import PHYSICAL_AGENTS  # noqa: PLC0415

    unknown = [a for a in ranked if a not in PHYSICAL_AGENTS and not is_custom(a)]
    if unknown or not ranked:
        raise ConfigError(f"unknown physical robot(s) {', '.join(map(repr, unknown)) or '(none)'}"
                          f"; allowed: {', '.join(PHYSICAL_AGENTS)}, or module:Class of your "
                          "own", field="agents")
    privileged = [a for a in ranked if not is_custom(a) and PHYSICAL_AGENTS[a].privileged]
    if privileged:
        raise ConfigError(f"{', '.join(map(repr, privileged))} read(s) the simulation: a "
                          "reference, always run and shown apart, never ranked", field="agents")
    from hri_bench.run.physical_host import describe_physical  # noqa: PLC0415

    for a in ranked:
        if is_custom(a):
            describe_physical(a)  # imports it in a host: a clear error before any run
    every = list(dict.fromkeys([*ranked, FLOOR, REFERENCE]))
    if not (isinstance(runs_scale, int | float) and 0 < runs_scale <= 10):
        raise ConfigError(f"runs_scale must be in (0, 10], got {runs_scale!r}",
                          field="runs_scale")
    folder = Path(out)
    if folder.exists() and any(p.name != UNITS_DIR for p in folder.iterdir()) \
            and not (resume or overwrite):
        raise ConfigError(f"{folder} already holds files: give resume= to finish an "
                          "interrupted suite, or overwrite= to start again", field="out")
    lock = FolderLock(folder, "physical suite")
    lock.acquire()
    try:
        store = folder / UNITS_DIR
        if overwrite and not resume and store.exists():
            shutil.rmtree(store)
        store.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        runs: dict[str, Any] = {}
        cpu = 0.0
        for seed in seeds:
            units = plan_units(chosen, every, int(seed), runs_scale)
            _execute(units, store, jobs, progress or (lambda done, total: None))
            runs[str(seed)], seconds = _assemble(chosen, runs_scale, units, store)
            cpu += seconds
        doc = _document(version, chosen, every, seeds, runs_scale, runs)
        _write(folder, doc, time.perf_counter() - t0, jobs, cpu)
        return doc
    finally:
        lock.release()


def _document(version: str, chosen: Sequence[PhysicalTrack], agents: Sequence[str],
              seeds: Sequence[int], runs_scale: float, runs: dict[str, Any]) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "format": pr.FORMAT, "schema_version": pr.SCHEMA_VERSION, "suite": "physical",
        "suite_version": version, "suite_hash": physical_suite_hash(version, chosen),
        "seeds": [int(s) for s in seeds], "runs_scale": runs_scale,
        "agents": {a: _agent_entry(a) for a in agents}, "software": provenance.software(),
        "tracks": {t.name: {**asdict(t), "runs": track_runs(t, runs_scale),
                            "members": _members(t)} for t in chosen},
        "runs": runs}
    doc["statistics"], doc["aggregate"] = pr.compute(doc)
    return doc


def _write(folder: Path, doc: dict[str, Any], wall: float, jobs: int, cpu: float) -> None:
    with atomic_writer(folder / "results.json") as f:
        json.dump(doc, f, indent=1, allow_nan=False)
    with atomic_writer(folder / "leaderboard.md") as f:
        f.write(leaderboard(doc))
    write_figures(doc, folder)
    with atomic_writer(folder / "suite_log.json") as f:
        json.dump({"wall_time_s": wall, "jobs": jobs, "cpu_time_s": cpu,
                   "load_average": os.getloadavg()}, f, indent=1)
