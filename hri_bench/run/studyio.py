"""Studies that survive faults: a checked output folder, finished units on disk, resume.

``hri-bench study --out DIR`` keeps its work in ``DIR`` (docs/benchmark.md, 'Interrupted
studies'):

- ``DIR/.units/study.json``: the study's settings and ``jobs`` (which decide how the runs
  are cut into units); ``--resume`` refuses a folder whose settings differ.
- ``DIR/.units/<key>.npz``: one finished unit (agent × preference × chunk of runs), written
  as soon as it finishes (numpy arrays, no pickle), under a temporary name then renamed.
- ``DIR/errors.log``: the traceback of every agent that raised, by name.
- ``DIR/run_log.jsonl``: one line per invocation (start time, wall time, units simulated
  and resumed, outcome), appended when it ends: "complete" only once every output is on
  disk. Wall time lives here, not in ``summary.json``, so that a resumed or replayed
  study's ``summary.json`` and ``episodes.csv`` are byte-identical to an uninterrupted
  run's.
- ``DIR/.lock``: locked (:func:`fcntl.flock`) while a study works in ``DIR``, so that a
  second one is refused instead of overwriting the first's files. The kernel releases it
  when the process ends, however it ends, so ``--resume`` works after any kill; the file
  is removed when the study ends (a killed study leaves it, unlocked).

:class:`StudyDir` locks and checks the folder before any simulation; :func:`run_in` runs a
study there, saving and reusing units, and writes its files; :func:`stop_on_signals`
turns SIGTERM into the same :class:`KeyboardInterrupt` as Ctrl-C, so both stop the worker
pool and keep the finished units.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from types import FrameType
from typing import Any, NamedTuple

from hri_bench.core.atomic import atomic_writer, fsync_dir
from hri_bench.run.folders import LOCK, LockedFolder
from hri_bench.run.study import (
    StudyConfig,
    StudyResult,
    StudyStopped,
    Unit,
    UnitResult,
    run_study,
    study_units,
    write_outputs,
)
from hri_bench.run.unitfiles import load_units, remove_temporary, save_unit, unit_path
from hri_envs.errors import ConfigError

__all__ = ["OUTPUT_FILES", "UNITS", "StudyDir", "StudyRun", "StudyTerminated", "differing_keys",
           "run_in", "stop_on_signals"]

UNITS = ".units"
MANIFEST = "study.json"
_FORMAT = "hri-bench-units-1"
ERRORS_LOG = "errors.log"
RUN_LOG = "run_log.jsonl"
SUMMARY = "summary.json"
#: Files a study writes into its folder (removed by ``overwrite`` before it starts).
OUTPUT_FILES = (SUMMARY, "episodes.csv", "reward.png", "decisions.png", "impulse.png",
                ERRORS_LOG, RUN_LOG)


def differing_keys(a: Mapping[str, Any], b: Mapping[str, Any]) -> list[str]:
    """The keys whose values differ between ``a`` and ``b`` (missing counts as None), sorted:
    what a refused resume names.
    """
    return sorted(k for k in {**a, **b} if a.get(k) != b.get(k))


class StudyTerminated(StudyStopped):
    """SIGTERM arrived during a study (handled like Ctrl-C: stop, keep finished units)."""


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Within the block, SIGINT raises :class:`~hri_bench.run.study.StudyStopped` (a
    :class:`KeyboardInterrupt`) and SIGTERM :class:`StudyTerminated` (also when the
    launching shell had SIGINT ignored, as for a background job): a stop of the study, never
    taken for an agent that raises ``KeyboardInterrupt``. Only in the main thread; elsewhere
    a no-op.
    """
    def interrupt(signum: int, frame: FrameType | None) -> None:
        raise StudyStopped(f"signal {signum}")

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


class StudyDir(LockedFolder):
    """The output folder of one study, locked and checked before any simulation
    (:class:`LockedFolder`).

    Args:
        out: The folder (created if missing).
        cfg: The study.
        resume: Continue the study whose finished units are in ``out/.units`` (or do
            nothing if the study in ``out`` is already complete: :attr:`complete`).
        overwrite: Start afresh in a non-empty folder (removes the study files
            :data:`OUTPUT_FILES` and ``.units``; other files are left alone).

    The folder stays locked (:data:`LOCK`) until :meth:`close` or the process ends (use it
    as a context manager); another study on the folder meanwhile is refused. With
    ``resume`` or ``overwrite``, what a killed study left half-written (temporary files,
    ``.plots-*`` folders) is removed once the lock is held.

    Raises:
        ConfigError: (``field="out"``) ``out`` is not a writable directory (also when
            creating it or its manifest fails, as under ``/proc``), another study is
            working in it, it is not empty and neither ``resume`` nor ``overwrite`` is
            given, or it holds a different study than the one to resume.
    """

    kind = "study"

    def __init__(self, out: str | os.PathLike[str], cfg: StudyConfig, *, resume: bool = False,
                 overwrite: bool = False) -> None:
        self.cfg = cfg
        self.units_dir = Path(out) / UNITS
        super().__init__(out, resume=resume, overwrite=overwrite)

    def _check(self, resume: bool, overwrite: bool) -> None:
        out = self.out
        nonempty = any(p.name != LOCK for p in out.iterdir())
        manifest = self.units_dir / MANIFEST
        if nonempty and not (resume or overwrite):
            raise ConfigError(
                f"{str(out)!r} is not empty; give a new or empty directory, --resume to "
                "continue the study that was interrupted there, or --overwrite to start afresh",
                field="out")
        want = json.loads(json.dumps(_manifest(self.cfg)))
        if nonempty and resume and not manifest.is_file():
            self._check_complete(want["settings"])
        elif nonempty and resume:
            try:
                saved = json.loads(manifest.read_text())
            except (OSError, ValueError) as exc:
                raise ConfigError(f"cannot read {manifest}: {exc}; use --overwrite",
                                  field="out") from exc
            if saved != want:
                differ = differing_keys(saved.get("settings", {}), want["settings"])
                if saved.get("jobs") != want["jobs"]:
                    differ.append("jobs")
                raise ConfigError(
                    f"{str(out)!r} holds a different study (differs in: "
                    f"{', '.join(differ) or 'format'}); resume with the same settings and "
                    "--jobs, or use --overwrite", field="out")
        if resume or overwrite:
            self._remove_leftovers()
        if overwrite:
            shutil.rmtree(self.units_dir, ignore_errors=True)
            for name in OUTPUT_FILES:
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
        if self.complete:
            return
        self.units_dir.mkdir(parents=True, exist_ok=True)
        if not manifest.is_file():
            with atomic_writer(manifest) as f:
                json.dump(_manifest(self.cfg), f, indent=1)

    def _check_complete(self, settings: dict[str, Any]) -> None:
        """A folder without unit files to resume: complete if its ``summary.json`` (written
        last, and only once every other file is in place) is this study's.
        """
        summary = self.out / SUMMARY
        try:
            saved = json.loads(summary.read_text())["settings"]
        except (OSError, ValueError, KeyError, TypeError):
            raise ConfigError(f"nothing to resume in {str(self.out)!r}: it has no "
                              f"{UNITS}/{MANIFEST} and no complete study; use --overwrite to "
                              "start afresh", field="out") from None
        if saved != settings:
            differ = differing_keys(saved, settings)
            raise ConfigError(f"{str(self.out)!r} holds a different, complete study (differs "
                              f"in: {', '.join(differ)}); use --overwrite", field="out")
        self.complete = True

    def _remove_leftovers(self) -> None:
        """Remove what a killed study left half-done: temporary files of its outputs and
        units, temporary plot folders, and unit files of a complete study (called with the
        lock held, so they belong to no live study).
        """
        out = self.out
        remove_temporary(out, OUTPUT_FILES)
        for tmp in out.glob(".plots-*"):
            shutil.rmtree(tmp, ignore_errors=True)
        if self.complete:
            shutil.rmtree(self.units_dir, ignore_errors=True)
        elif self.units_dir.is_dir():
            for tmp in self.units_dir.glob(".*.tmp*"):
                tmp.unlink(missing_ok=True)
        fsync_dir(out)

    def unit_path(self, index: int, unit: Unit) -> Path:
        """Where unit ``index`` of the study is kept once finished."""
        return unit_path(self.units_dir, index, unit)

    def save_unit(self, index: int, unit: Unit, result: UnitResult) -> None:
        """Write a finished unit (atomically)."""
        save_unit(self.unit_path(index, unit), result)

    def load_done(self, units: list[Unit]) -> dict[int, UnitResult]:
        """The finished units found on disk, by index (unreadable files, and units an earlier
        version wrote without today's metrics, are run again).
        """
        return load_units(self.units_dir, units)

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
        """Append one line to ``run_log.jsonl`` and flush it to disk.

        One ``write`` of the whole line to a file opened for appending: a kill leaves the
        line whole or absent, never half of it.
        """
        line = (json.dumps(record) + "\n").encode()
        fd = os.open(self.out / RUN_LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, line)
            os.fsync(fd)
        except OSError as exc:
            exc.filename = exc.filename or str(self.out / RUN_LOG)
            raise
        finally:
            os.close(fd)

    def finish(self) -> None:
        """Remove the unit files once the final files are written.

        The manifest goes first: a kill halfway leaves a folder that ``--resume`` sees as
        complete (and cleans), not one with units missing.
        """
        (self.units_dir / MANIFEST).unlink(missing_ok=True)
        shutil.rmtree(self.units_dir, ignore_errors=True)
        fsync_dir(self.out)


class StudyRun(NamedTuple):
    """What :func:`run_in` did."""

    #: The study's result; None when the folder already held the complete study.
    result: StudyResult | None
    #: The files written (``summary.json``, ``episodes.csv``, plots).
    paths: list[Path]
    #: ``errors.log`` when an agent raised, else None.
    errors: Path | None


def run_in(folder: StudyDir, *, progress: bool = False, plots: bool = True) -> StudyRun:
    """Run ``folder``'s study, reusing its finished units and saving each new one, and write
    its files (:func:`~hri_bench.run.study.write_outputs`, ``errors.log``).

    Agents that raise are recorded (``StudyResult.failures``), not raised; Ctrl-C and
    SIGTERM (within :func:`stop_on_signals`) raise :class:`KeyboardInterrupt` after the pool
    is stopped, with every finished unit on disk. When every agent ran, the unit files are
    removed once the final files are in place. Appends the run to ``run_log.jsonl`` last:
    "complete" means that every file is on disk.

    Raises:
        OSError: A file cannot be written (its ``filename`` says which); the finished units
            stay on disk for ``--resume``.
    """
    cfg = folder.cfg
    units = study_units(cfg)
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    t0 = time.perf_counter()

    def record(status: str, resumed: int, simulated: int) -> dict[str, Any]:
        return {"started": started, "wall_time_s": round(time.perf_counter() - t0, 3),
                "units": len(units), "resumed": resumed, "simulated": simulated,
                "status": status}

    if folder.complete:
        folder.log_run(record("complete", len(units), 0))
        return StudyRun(None, [], None)
    done = folder.load_done(units)
    n_new = 0

    def save(i: int, res: UnitResult) -> None:
        nonlocal n_new
        folder.save_unit(i, units[i], res)
        n_new += 1

    status = "interrupted"
    try:
        result = run_study(cfg, progress=progress, done=done, on_result=save, keep_going=True)
        paths = write_outputs(result, folder.out, plots=plots)
        errors = folder.log_failures(result.failures)
        if errors is None:
            folder.finish()
        status = "failed" if result.failures else "complete"
    except BaseException:
        with contextlib.suppress(OSError):  # a full disk must not hide the first error
            folder.log_run(record(status, len(done), n_new))
        raise
    folder.log_run(record(status, len(done), n_new))
    return StudyRun(result, paths, errors)
