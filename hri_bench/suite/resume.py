"""A suite's output folder: locked, checked before anything runs, and resumable.

``hri-bench suite --out DIR`` (docs/benchmark.md, "Suite") holds, as ``hri-bench study``
does, ``DIR/.lock`` while it works (:class:`~hri_bench.run.folders.FolderLock`: a second
suite or study on ``DIR`` is refused), refuses a non-empty ``DIR`` unless ``--resume`` or
``--overwrite``, and keeps its work in ``DIR/.suite`` until every file is written:

- ``.suite/plan.json``: what the suite runs (version, agents, tracks, populations, runs
  scale, seeds); ``--resume`` refuses a folder whose plan differs;
- ``.suite/NN-TRACK.npz`` and ``.json``: each finished track's study (its arrays, the agents
  that raised, its wall time), so that a resumed suite does not run it again;
- ``.suite/NN-TRACK/``: the finished units of the track in progress
  (:func:`~hri_bench.run.unitfiles.save_unit`), so that it loses at most the units in progress.

``suite_log.json``, written last, records the plan too; ``.suite`` is then removed, and a
resume of the complete suite does nothing. ``--overwrite`` removes only the files a suite
writes (:func:`own_files`: its outputs, every track's figure of any version, ``seed-S``
folders, ``.suite``), never others.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hri_bench.core.atomic import atomic_writer, fsync_dir
from hri_bench.run.folders import LOCK, LockedFolder
from hri_bench.run.study import StudyConfig, StudyResult, Unit
from hri_bench.run.studyio import differing_keys
from hri_bench.run.unitfiles import (
    load_result,
    load_units,
    remove_temporary,
    save_result,
    save_unit,
    unit_path,
)
from hri_bench.suite.tracks import TRACKS_BY_VERSION, Track
from hri_envs.errors import ConfigError

__all__ = ["OUTPUT_FILES", "PLAN_FORMAT", "STATE", "SUITE_LOG", "SuiteDir", "TrackStore",
           "complete_suite", "own_files", "suite_plan"]

#: Where a suite keeps its work until every file is written.
STATE = ".suite"
PLAN = "plan.json"
PLAN_FORMAT = "hri-bench-suite-plan-1"
#: The suite's log, written last (wall times, how it was run, its plan).
SUITE_LOG = "suite_log.json"
#: The files a suite writes into its folder, besides one figure per track.
OUTPUT_FILES = ("suite.json", "results.json", "leaderboard.md", SUITE_LOG, "errors.log",
                "profiles.png", "ranking.png")
_SEED_FOLDER = re.compile(r"seed-\d+")
_POPULATION_FIGURE = re.compile(r".+-recorded(-irl)?-.+\.png")


def suite_plan(version: str, agents: Sequence[str], tracks: Sequence[str],
               populations: Sequence[str], runs_scale: float, seeds: Sequence[int]
               ) -> dict[str, Any]:
    """What a suite runs, as ``plan.json`` and ``suite_log.json`` record it."""
    return json.loads(json.dumps({
        "format": PLAN_FORMAT, "suite_version": version, "agents": list(agents),
        "tracks": list(tracks), "populations": list(populations), "runs_scale": runs_scale,
        "seeds": [int(s) for s in seeds]}))


def _figure_names() -> set[str]:
    return {f"{name}.png" for tracks in TRACKS_BY_VERSION.values() for name in tracks}


def own_files(folder: Path) -> list[Path]:
    """What a suite wrote in ``folder``: :data:`OUTPUT_FILES`, the figure of any track of any
    version (a population's own track too), ``seed-S`` folders, ``.suite`` and temporary
    files of its writes; the lock is not listed.
    """
    figures = _figure_names()
    own = []
    for p in sorted(Path(folder).iterdir()):
        name = p.name
        if p.is_dir() and not p.is_symlink():
            if name == STATE or _SEED_FOLDER.fullmatch(name):
                own.append(p)
        elif (name in OUTPUT_FILES or name in figures or _POPULATION_FIGURE.fullmatch(name)
              or (name.startswith(".") and name.endswith(".tmp"))):
            own.append(p)
    return own


def _remove(paths: Sequence[Path]) -> None:
    for p in paths:
        if p.is_dir() and not p.is_symlink():
            if p.name == STATE:
                shutil.rmtree(p)
            else:  # a seed-S folder: the suite's files in it, then the folder if empty
                _remove(own_files(p))
                with contextlib.suppress(OSError):
                    (p / LOCK).unlink(missing_ok=True)
                    p.rmdir()
        else:
            p.unlink(missing_ok=True)


class SuiteDir(LockedFolder):
    """The output folder of one suite (``plan``, :func:`suite_plan`), locked and checked
    before anything runs (:class:`~hri_bench.run.folders.LockedFolder`).

    Args:
        out: The folder (created if missing).
        plan: The suite's plan.
        resume: Continue the suite whose plan is in ``out/.suite`` (or do nothing if the
            suite in ``out`` is already complete: :attr:`complete`).
        overwrite: Start afresh in a non-empty folder (removes the suite's own files,
            :func:`own_files`; other files are left alone).

    Raises:
        ConfigError: (``field="out"``) ``out`` is not a writable directory, another suite or
            study works in it, it is not empty and neither ``resume`` nor ``overwrite`` is
            given, or it holds another suite than the one to resume.
    """

    kind = "suite"

    def __init__(self, out: str | os.PathLike[str], plan: dict[str, Any], *,
                 resume: bool = False, overwrite: bool = False) -> None:
        self.plan = plan
        super().__init__(out, resume=resume, overwrite=overwrite)

    def _check(self, resume: bool, overwrite: bool) -> None:
        out = self.out
        if any(p.name != LOCK for p in out.iterdir()) and not (resume or overwrite):
            raise ConfigError(
                f"{str(out)!r} is not empty; give a new or empty directory, --resume to "
                "continue the suite that was interrupted there, or --overwrite to start "
                "afresh (it removes only the suite's own files)", field="out")
        if overwrite:
            _remove(own_files(out))
        elif resume:
            self._check_resume()
        fsync_dir(out)

    def _check_resume(self) -> None:
        saved = _read(self.out / STATE / PLAN)
        if saved is not None:
            _same_plan(saved, self.plan, self.out, "")
        else:
            log = _read(self.out / SUITE_LOG)
            if log is None or "plan" not in log:
                if any(p.name != LOCK for p in self.out.iterdir()):
                    raise ConfigError(
                        f"nothing to resume in {str(self.out)!r}: it has no {STATE}/{PLAN} "
                        f"and no complete suite of this version of hri-bench; use "
                        "--overwrite to start afresh", field="out")
                return
            _same_plan(log["plan"], self.plan, self.out, "complete ")
            self.complete = True
            _drop_state(self.out)
        remove_temporary(self.out, OUTPUT_FILES)


def _drop_state(out: Path) -> None:
    """Remove what a suite killed while it removed ``.suite`` left (its plan was removed
    first, so the suite is complete: :meth:`TrackStore.finish`).
    """
    if (out / STATE).is_dir() and not (out / STATE / PLAN).exists():
        shutil.rmtree(out / STATE)
        fsync_dir(out)


def _read(path: Path) -> Any:
    """A small JSON file, or None when missing or unreadable."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _same_plan(saved: Any, plan: dict[str, Any], out: Path, what: str) -> None:
    if saved == plan:
        return
    saved = saved if isinstance(saved, dict) else {}
    differ = differing_keys(saved, plan)
    raise ConfigError(f"{str(out)!r} holds a different, {what}suite (differs in: "
                      f"{', '.join(differ)}); resume with the same settings, or use "
                      "--overwrite", field="out")


def complete_suite(out: Path, plan: dict[str, Any]) -> dict[str, Any] | None:
    """``suite.json``'s document if ``out`` holds the complete suite of ``plan`` (its
    ``suite_log.json``, written last, records that plan and no ``.suite`` is in progress);
    what a kill left of ``.suite`` after its plan was removed is removed then.
    """
    log = _read(Path(out) / SUITE_LOG)
    if not isinstance(log, dict) or log.get("plan") != plan or (Path(out) / STATE / PLAN).exists():
        return None
    doc = _read(Path(out) / "suite.json")
    if not isinstance(doc, dict):
        return None
    _drop_state(Path(out))
    return doc


class TrackStore:
    """A suite's work in ``out/.suite``: its plan, finished tracks and units.

    Args:
        out: The suite's folder.
        plan: Its plan (:func:`suite_plan`).
        resume: Reuse what ``out/.suite`` holds (its plan must be ``plan``); otherwise it is
            removed first.

    Raises:
        ConfigError: (``field="out"``) ``resume`` and ``out/.suite`` holds another plan.
    """

    def __init__(self, out: Path, plan: dict[str, Any], *, resume: bool) -> None:
        self.out, self.plan = Path(out), plan
        self.state = self.out / STATE
        saved = _read(self.state / PLAN)
        if resume and saved is not None:
            _same_plan(saved, plan, self.out, "")
            for tmp in self.state.rglob(".*.tmp*"):  # what a killed write left
                tmp.unlink(missing_ok=True)
        elif self.state.exists():
            shutil.rmtree(self.state)
        self.state.mkdir(parents=True, exist_ok=True)
        if saved is None or not resume:
            with atomic_writer(self.state / PLAN) as f:
                json.dump(plan, f, indent=1)

    def _base(self, k: int, track: Track) -> Path:
        slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", track.name)[:60]
        return self.state / f"{k:02d}-{slug}"

    def finished(self, k: int, track: Track, cfg: StudyConfig
                 ) -> tuple[StudyResult, float] | None:
        """Track ``k``'s result and wall time, if it finished before."""
        loaded = load_result(self._base(k, track), cfg)
        if loaded is None or loaded[1].get("track") != track.name:
            return None
        return loaded[0], float(loaded[1]["track_wall_time_s"])

    def units_done(self, k: int, track: Track, units: list[Unit]) -> dict[int, Any]:
        """The finished units of track ``k`` in progress."""
        return load_units(self._base(k, track), units)

    def save_unit(self, k: int, track: Track, index: int, unit: Unit, result: Any) -> None:
        """Keep a finished unit of track ``k``."""
        folder = self._base(k, track)
        folder.mkdir(exist_ok=True)
        save_unit(unit_path(folder, index, unit), result)

    def save(self, k: int, track: Track, result: StudyResult, wall: float) -> None:
        """Keep track ``k``'s finished study; its units are then dropped."""
        save_result(self._base(k, track), result,
                    {"track": track.name, "track_wall_time_s": wall})
        shutil.rmtree(self._base(k, track), ignore_errors=True)

    def finish(self) -> None:
        """Remove ``.suite`` once every file is written (the plan first: a kill halfway
        leaves a folder whose ``suite_log.json`` says it is complete).
        """
        (self.state / PLAN).unlink(missing_ok=True)
        shutil.rmtree(self.state, ignore_errors=True)
        fsync_dir(self.out)
