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
import fcntl
import glob
import json
import os
import re
import shutil
import signal
import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any, NamedTuple, Self

import numpy as np

from hri_bench.core.atomic import atomic_path, atomic_writer, fsync_dir
from hri_bench.run.runner import TASK_METRICS
from hri_bench.run.study import (
    StudyConfig,
    StudyResult,
    StudyStopped,
    UnitResult,
    _Unit,
    _units,
    run_study,
    write_outputs,
)
from hri_envs.errors import ConfigError

__all__ = ["LOCK", "OUTPUT_FILES", "UNITS", "FolderLock", "LockedFolder", "StudyDir", "StudyRun",
           "StudyTerminated", "check_out", "differing_keys", "load_result", "load_units",
           "remove_temporary", "run_in", "save_result", "save_unit", "stop_on_signals", "unit_path"]

UNITS = ".units"
MANIFEST = "study.json"
ERRORS_LOG = "errors.log"
RUN_LOG = "run_log.jsonl"
SUMMARY = "summary.json"
#: The lock file in a study's folder (removed when the study ends; one left by a killed
#: study is not locked, and only the lock counts).
LOCK = ".lock"
_FORMAT = "hri-bench-units-1"
_RESULT_FORMAT = "hri-bench-study-result-1"
#: Files a study writes into its folder (removed by ``overwrite`` before it starts).
OUTPUT_FILES = (SUMMARY, "episodes.csv", "reward.png", "decisions.png", "impulse.png",
                ERRORS_LOG, RUN_LOG)

#: Descriptors of the locks this process holds; a forked child (a pool worker) closes its
#: copies at once, so that the lock ends with the study's process, not with its last worker.
_HELD_LOCKS: set[int] = set()


def differing_keys(a: Mapping[str, Any], b: Mapping[str, Any]) -> list[str]:
    """The keys whose values differ between ``a`` and ``b`` (missing counts as None), sorted:
    what a refused resume names.
    """
    return sorted(k for k in {**a, **b} if a.get(k) != b.get(k))


def _close_locks_in_child() -> None:
    for fd in _HELD_LOCKS:
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_close_locks_in_child)


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


def check_out(out: Path, what: str) -> None:
    """Refuse an output folder that is a file, or whose first existing ancestor cannot be
    written (a :class:`ConfigError` with ``field="out"``; ``what``: "study", "suite", ...).
    """
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{str(out)!r} is a file; give a directory (new or empty) for the "
                          f"{what}", field="out")
    existing = out if out.exists() else next(p for p in out.absolute().parents if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"cannot write in {str(existing)!r}; give a directory you can "
                          "write to", field="out")


class FolderLock:
    """``out/.lock``, locked (:func:`fcntl.flock`) while a study, suite or leaderboard works
    in ``out`` (:data:`LOCK`): a second one is refused, saying which process holds it.

    ``kind`` ("study", "suite", ...) is written beside the process id, so that the refusal
    names what is running. The kernel releases the lock when the process ends, however it
    ends; :meth:`release` removes the file.
    """

    def __init__(self, out: Path, kind: str) -> None:
        self.out, self.kind = Path(out), kind
        self.fd: int | None = None

    def acquire(self) -> None:
        """Lock ``out/.lock`` (creating ``out``) or raise a :class:`ConfigError` naming the
        process that holds it.

        The file is removed when the lock is released; a process that opened it just before
        then would hold a lock on a removed file, so the lock counts only if the file it
        locked is still the one in the folder.
        """
        self.out.mkdir(parents=True, exist_ok=True)
        path = self.out / LOCK
        while True:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                words = os.pread(fd, 64, 0).decode(errors="replace").split()
                os.close(fd)
                pid = f" (process {words[0]})" if words and words[0].isdigit() else ""
                kind = words[1] if len(words) > 1 and words[1].isalpha() else "study"
                raise ConfigError(
                    f"another {kind}{pid} is writing in {str(self.out)!r}; wait for it to "
                    "end (--resume then continues it if it was stopped), or give another "
                    "--out", field="out") from None
            try:
                locked, current = os.fstat(fd), os.stat(path)
                if (locked.st_dev, locked.st_ino) == (current.st_dev, current.st_ino):
                    break
            except FileNotFoundError:
                pass
            os.close(fd)
        _HELD_LOCKS.add(fd)
        self.fd = fd
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()} {self.kind}\n".encode(), 0)

    def release(self) -> None:
        """Release the lock (another process may then work in the folder); remove its file."""
        if self.fd is not None:
            with contextlib.suppress(FileNotFoundError):
                (self.out / LOCK).unlink()  # while locked: see acquire
            _HELD_LOCKS.discard(self.fd)
            os.close(self.fd)  # closing the descriptor releases the flock
            self.fd = None



def _manifest(cfg: StudyConfig) -> dict[str, Any]:
    return {"format": _FORMAT, "settings": cfg.settings(), "jobs": cfg.jobs}


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)[:40]


def unit_path(folder: Path, index: int, unit: _Unit) -> Path:
    """Where unit ``index`` of a study is kept in ``folder`` once finished."""
    name = f"{index:04d}-{_slug(unit.agent)}-{_slug(unit.preference)}"
    return Path(folder) / f"{name}-{unit.runs[0]}-{unit.runs[-1]}.npz"


def remove_temporary(folder: Path, names: Iterable[str]) -> None:
    """Remove the temporary files a killed write of ``names`` left in ``folder``
    (:func:`~hri_bench.core.atomic.atomic_path`'s ``.NAME.*.tmp``).
    """
    for name in names:
        for tmp in Path(folder).glob(f".{glob.escape(name)}.*.tmp"):
            tmp.unlink(missing_ok=True)


def save_unit(path: Path, result: UnitResult) -> None:
    """Write a finished unit's result to ``path`` (numpy arrays, no pickle; atomically)."""
    metrics, probes, schedule, humans = result
    arrays: dict[str, Any] = {**{f"m.{k}": v for k, v in metrics.items()}, "probes": probes,
                              **{f"s.{k}": v for k, v in schedule.items()},
                              "humans": np.array(humans, dtype=str)}
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez(tmp, allow_pickle=False, **arrays)


def load_units(folder: Path, units: list[_Unit]) -> dict[int, UnitResult]:
    """The finished units of ``units`` kept in ``folder`` (:func:`unit_path`), by index;
    unreadable files, and units an earlier version wrote without today's metrics, are left
    out (simulated again).
    """
    done: dict[int, UnitResult] = {}
    for i, u in enumerate(units):
        path = unit_path(folder, i, u)
        if not path.is_file():
            continue
        try:
            with np.load(path, allow_pickle=False) as data:
                metrics = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("m.")}
                if not set(TASK_METRICS) <= set(metrics):
                    continue  # written before the task's metrics: simulated again
                schedule = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("s.")}
                done[i] = (metrics, np.array(data["probes"]), schedule,
                           [str(h) for h in data["humans"]])
        except Exception:  # a damaged unit is simulated again
            continue
    return done


def _beside(path: Path, suffix: str) -> Path:
    return path.parent / f"{path.name}{suffix}"


def save_result(path: Path, result: StudyResult, extra: dict[str, Any]) -> None:
    """Write a whole :class:`StudyResult` (but its configuration) to ``PATH.npz`` and
    ``PATH.json`` (its failures, the order of its agents and ``extra``), the arrays first,
    each atomically: the ``.json`` in place means that both are.
    """
    agents = list(result.metrics)
    arrays: dict[str, Any] = {"humans": np.array(result.humans, dtype=str)}
    for j, agent in enumerate(agents):
        arrays.update({f"m.{j}.{k}": v for k, v in result.metrics[agent].items()})
        arrays[f"p.{j}"] = result.probes[agent]
    arrays.update({f"s.{k}": v for k, v in result.schedule.items()})
    with atomic_path(_beside(path, ".npz"), suffix=".npz") as tmp:
        np.savez(tmp, allow_pickle=False, **arrays)
    with atomic_writer(_beside(path, ".json")) as f:
        json.dump({"format": _RESULT_FORMAT, "agents": agents, "failures": result.failures,
                   "wall_time_s": result.wall_time_s, **extra}, f)


def load_result(path: Path, cfg: StudyConfig) -> tuple[StudyResult, dict[str, Any]] | None:
    """The :class:`StudyResult` of study ``cfg`` that :func:`save_result` wrote to ``PATH.*``
    with the document of its ``.json``; None when it is missing or unreadable (the study
    is simulated again).
    """
    try:
        doc = json.loads(_beside(path, ".json").read_text())
        if doc.get("format") != _RESULT_FORMAT:
            return None
        with np.load(_beside(path, ".npz"), allow_pickle=False) as data:
            metrics: dict[str, dict[str, np.ndarray]] = {}
            probes: dict[str, np.ndarray] = {}
            for j, agent in enumerate(doc["agents"]):
                head = f"m.{j}."
                metrics[agent] = {k[len(head):]: np.array(data[k]) for k in data.files
                                  if k.startswith(head)}
                probes[agent] = np.array(data[f"p.{j}"])
            schedule = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("s.")}
            humans = [str(h) for h in data["humans"]]
    except Exception:  # missing, damaged or of another layout: simulated again
        return None
    result = StudyResult(cfg, metrics, probes, schedule, float(doc["wall_time_s"]),
                         humans=humans, failures=dict(doc["failures"]))
    return result, doc



class LockedFolder:
    """An output folder a command holds while it writes (:data:`LOCK`), checked before
    anything runs: a study's (:class:`StudyDir`), a suite's
    (:class:`~hri_bench.suite.resume.SuiteDir`).

    The folder is created if missing and stays locked until :meth:`close` or the process
    ends (use it as a context manager); another command on it meanwhile is refused. A
    subclass names its command (``kind``) and checks the folder's contents in
    :meth:`_check`, with the lock held.

    Raises:
        ConfigError: (``field="out"``) both ``resume`` and ``overwrite``, ``out`` is not a
            writable directory (also when writing in it fails, as under ``/proc``), another
            command works in it, or what :meth:`_check` refuses.
    """

    #: The command whose folder it is ("study", "suite"), for the lock and the messages.
    kind = ""

    def __init__(self, out: str | os.PathLike[str], *, resume: bool = False,
                 overwrite: bool = False) -> None:
        self.out = Path(out)
        #: What ``out`` holds was already complete (``resume``): nothing to do.
        self.complete = False
        self._lock = FolderLock(self.out, self.kind)
        if resume and overwrite:
            raise ConfigError("give either --resume or --overwrite, not both", field="out")
        check_out(self.out, self.kind)
        try:
            self._lock.acquire()
            self._check(resume, overwrite)
        except OSError as exc:  # e.g. /proc/x, a read-only file system, a name too long
            self.close()
            raise ConfigError(f"cannot use {str(self.out)!r} as the {self.kind}'s folder "
                              f"({exc.strerror or exc}); give a directory you can write to",
                              field="out") from None
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> Self:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        """Release the folder's lock (another command may then work there)."""
        self._lock.release()

    def _check(self, resume: bool, overwrite: bool) -> None:
        """Check (and with ``overwrite``, clear) the folder, its lock held."""


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

    def unit_path(self, index: int, unit: _Unit) -> Path:
        """Where unit ``index`` of the study is kept once finished."""
        return unit_path(self.units_dir, index, unit)

    def save_unit(self, index: int, unit: _Unit, result: UnitResult) -> None:
        """Write a finished unit (atomically)."""
        save_unit(self.unit_path(index, unit), result)

    def load_done(self, units: list[_Unit]) -> dict[int, UnitResult]:
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
    units = _units(cfg)
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
