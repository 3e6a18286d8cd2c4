"""An output folder held while a command writes in it: ``out/.lock`` (:data:`LOCK`, locked
with :func:`fcntl.flock` by :class:`FolderLock`), the check that ``out`` can be written
(:func:`check_out`), and :class:`LockedFolder`, the base of a study's and a suite's folder
(:class:`~hri_bench.run.studyio.StudyDir`, :class:`~hri_bench.suite.resume.SuiteDir`).

The kernel releases a lock when its process ends, however it ends; a forked child (a pool
worker) closes its copies at once, so that the lock ends with the command's process.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path
from types import TracebackType
from typing import Self

from hri_envs.errors import ConfigError

#: The lock file in a study's folder (removed when the study ends; one left by a killed
#: study is not locked, and only the lock counts).
LOCK = ".lock"


#: Descriptors of the locks this process holds; a forked child (a pool worker) closes its
#: copies at once, so that the lock ends with the study's process, not with its last worker.
_HELD_LOCKS: set[int] = set()


def _close_locks_in_child() -> None:
    for fd in _HELD_LOCKS:
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD_LOCKS.clear()


os.register_at_fork(after_in_child=_close_locks_in_child)


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
