"""Studies that survive faults: a checked output folder, finished units on disk, resume.

``hri-bench study --out DIR`` keeps its work in ``DIR`` (docs/benchmark.md, 'Interrupted
studies'):

- ``DIR/.units/study.json``: the study's settings and ``jobs`` (which decide how the runs
  are cut into units); ``--resume`` refuses a folder whose settings differ.
- ``DIR/.units/<key>.npz``: one finished unit (agent × preference × chunk of runs), written
  as soon as it finishes (numpy arrays, no pickle), under a temporary name then renamed.
- ``DIR/errors.log``: the traceback of every agent that raised, by name.
- ``DIR/run_log.jsonl``: one line per invocation (start time, wall time, units simulated
  and resumed, outcome). Wall time lives here, not in ``summary.json``, so that a resumed
  or replayed study's ``summary.json`` and ``episodes.csv`` are byte-identical to an
  uninterrupted run's.

:class:`StudyDir` checks the folder before any simulation; :func:`run_in` runs a study
there, saving and reusing units; :func:`stop_on_signals` turns SIGTERM into the same
:class:`KeyboardInterrupt` as Ctrl-C, so both stop the worker pool and keep the finished
units.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from hri_bench.atomic import atomic_path, atomic_writer
from hri_bench.study import (
    StudyConfig,
    StudyResult,
    UnitResult,
    _Unit,
    _units,
    run_study,
)
from hri_envs.errors import ConfigError

__all__ = ["OUTPUT_FILES", "StudyDir", "StudyTerminated", "run_in", "stop_on_signals"]

UNITS = ".units"
MANIFEST = "study.json"
ERRORS_LOG = "errors.log"
RUN_LOG = "run_log.jsonl"
_FORMAT = "hri-bench-units-1"
#: Files a study writes into its folder (removed by ``overwrite`` before it starts).
OUTPUT_FILES = ("summary.json", "episodes.csv", "reward.png", "decisions.png", "impulse.png",
                ERRORS_LOG, RUN_LOG)


class StudyTerminated(KeyboardInterrupt):
    """SIGTERM arrived during a study (handled like Ctrl-C: stop, keep finished units)."""


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Within the block, SIGINT raises :class:`KeyboardInterrupt` and SIGTERM
    :class:`StudyTerminated` (also when the launching shell had SIGINT ignored, as for a
    background job). Only in the main thread; elsewhere a no-op.
    """
    def interrupt(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt(f"signal {signum}")

    def terminate(signum: int, frame: FrameType | None) -> None:
        raise StudyTerminated(f"signal {signum}")

    try:
        previous = {signal.SIGINT: signal.signal(signal.SIGINT, interrupt),
                    signal.SIGTERM: signal.signal(signal.SIGTERM, terminate)}
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _manifest(cfg: StudyConfig) -> dict[str, Any]:
    return {"format": _FORMAT, "settings": cfg.settings(), "jobs": cfg.jobs}


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)[:40]


class StudyDir:
    """The output folder of one study, checked before any simulation.

    Args:
        out: The folder (created if missing).
        cfg: The study.
        resume: Continue the study whose finished units are in ``out/.units``.
        overwrite: Start afresh in a non-empty folder (removes the study files
            :data:`OUTPUT_FILES`, ``.units`` and leftover temporary plot folders; other
            files are left alone).

    Raises:
        ConfigError: (``field="out"``) ``out`` is not a writable directory (also when
            creating it or its manifest fails, as under ``/proc``), is not empty and
            neither ``resume`` nor ``overwrite`` is given, or holds a different study than
            the one to resume.
    """

    def __init__(self, out: str | os.PathLike[str], cfg: StudyConfig, *, resume: bool = False,
                 overwrite: bool = False) -> None:
        self.out = Path(out)
        self.cfg = cfg
        self.units_dir = self.out / UNITS
        if resume and overwrite:
            raise ConfigError("give either resume or overwrite, not both", field="resume")
        try:
            self._check(resume, overwrite)
        except OSError as exc:  # e.g. /proc/x, a read-only file system, a name too long
            raise ConfigError(f"cannot use {str(self.out)!r} as the study's folder "
                              f"({exc.strerror or exc}); give a directory you can write to",
                              field="out") from None

    def _check(self, resume: bool, overwrite: bool) -> None:
        out = self.out
        if out.exists() and not out.is_dir():
            raise ConfigError(f"{str(out)!r} is a file; give a directory (new or empty)",
                              field="out")
        existing = out if out.exists() else next(p for p in out.absolute().parents if p.exists())
        if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
            raise ConfigError(f"cannot write in {str(existing)!r}; give a directory you can "
                              "write to", field="out")
        nonempty = out.exists() and any(out.iterdir())
        manifest = self.units_dir / MANIFEST
        if nonempty and not (resume or overwrite):
            raise ConfigError(
                f"{str(out)!r} is not empty; give a new or empty directory, --resume to "
                "continue the study that was interrupted there, or --overwrite to start afresh",
                field="out")
        if nonempty and resume:
            if not manifest.is_file():
                raise ConfigError(f"nothing to resume in {str(out)!r}: it has no "
                                  f"{UNITS}/{MANIFEST}; use --overwrite to start afresh",
                                  field="out")
            try:
                saved = json.loads(manifest.read_text())
            except (OSError, ValueError) as exc:
                raise ConfigError(f"cannot read {manifest}: {exc}; use --overwrite",
                                  field="out") from exc
            want = json.loads(json.dumps(_manifest(self.cfg)))
            if saved != want:
                differ = sorted(k for k in {**saved.get("settings", {}), **want["settings"]}
                                if saved.get("settings", {}).get(k) != want["settings"].get(k))
                if saved.get("jobs") != want["jobs"]:
                    differ.append("jobs")
                raise ConfigError(
                    f"{str(out)!r} holds a different study (differs in: "
                    f"{', '.join(differ) or 'format'}); resume with the same settings and "
                    "--jobs, or use --overwrite", field="out")
        if overwrite:
            shutil.rmtree(self.units_dir, ignore_errors=True)
            for tmp in out.glob(".plots-*"):  # left by a kill while plotting
                shutil.rmtree(tmp, ignore_errors=True)
            for name in OUTPUT_FILES:
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
        self.units_dir.mkdir(parents=True, exist_ok=True)
        if not manifest.is_file():
            with atomic_writer(manifest) as f:
                json.dump(_manifest(self.cfg), f, indent=1)

    def unit_path(self, index: int, unit: _Unit) -> Path:
        """Where unit ``index`` of the study is kept once finished."""
        name = f"{index:04d}-{_slug(unit.agent)}-{_slug(unit.preference)}"
        return self.units_dir / f"{name}-{unit.runs[0]}-{unit.runs[-1]}.npz"

    def save_unit(self, index: int, unit: _Unit, result: UnitResult) -> None:
        """Write a finished unit (atomically)."""
        metrics, probes, schedule, humans = result
        arrays: dict[str, Any] = {**{f"m.{k}": v for k, v in metrics.items()}, "probes": probes,
                                  **{f"s.{k}": v for k, v in schedule.items()},
                                  "humans": np.array(humans, dtype=str)}
        with atomic_path(self.unit_path(index, unit), suffix=".npz") as tmp:
            np.savez(tmp, allow_pickle=False, **arrays)

    def load_done(self, units: list[_Unit]) -> dict[int, UnitResult]:
        """The finished units found on disk, by index (unreadable files are run again)."""
        done: dict[int, UnitResult] = {}
        for i, u in enumerate(units):
            path = self.unit_path(i, u)
            if not path.is_file():
                continue
            try:
                with np.load(path, allow_pickle=False) as data:
                    metrics = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("m.")}
                    schedule = {k[2:]: np.array(data[k]) for k in data.files
                                if k.startswith("s.")}
                    done[i] = (metrics, np.array(data["probes"]), schedule,
                               [str(h) for h in data["humans"]])
            except Exception:  # a damaged unit is simulated again
                continue
        return done

    def log_failures(self, failures: dict[str, str]) -> Path | None:
        """Write ``errors.log`` with each failed agent's traceback (None if none failed)."""
        path = self.out / ERRORS_LOG
        if not failures:
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
            return None
        with atomic_writer(path) as f:
            for agent, text in failures.items():
                f.write(f"agent {agent!r} raised:\n{text}\n")
        return path

    def log_run(self, record: dict[str, Any]) -> None:
        """Append one line to ``run_log.jsonl``."""
        with (self.out / RUN_LOG).open("a") as f:
            f.write(json.dumps(record) + "\n")

    def finish(self) -> None:
        """Remove the unit files once the final files are written."""
        shutil.rmtree(self.units_dir, ignore_errors=True)


def run_in(folder: StudyDir, *, progress: bool = False) -> StudyResult:
    """Run ``folder``'s study, reusing its finished units and saving each new one.

    Agents that raise are recorded (``StudyResult.failures``), not raised; Ctrl-C and
    SIGTERM (within :func:`stop_on_signals`) raise :class:`KeyboardInterrupt` after the pool
    is stopped, with every finished unit on disk. Appends the run to ``run_log.jsonl``.
    """
    cfg = folder.cfg
    units = _units(cfg)
    done = folder.load_done(units)
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    t0 = time.perf_counter()
    n_new = 0

    def save(i: int, res: UnitResult) -> None:
        nonlocal n_new
        folder.save_unit(i, units[i], res)
        n_new += 1

    status = "interrupted"
    try:
        result = run_study(cfg, progress=progress, done=done, on_result=save, keep_going=True)
        status = "failed" if result.failures else "complete"
        return result
    finally:
        folder.log_run({"started": started, "wall_time_s": round(time.perf_counter() - t0, 3),
                        "units": len(units), "resumed": len(done), "simulated": n_new,
                        "status": status})
