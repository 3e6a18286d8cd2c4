"""The dataset folder as ``serve`` keeps it: one server at a time, sessions a killed server
left ``running`` marked ``interrupted``, and recordings private to the user.

* **One server per dataset.** A server holds ``<dataset>/.serve.lock`` (:func:`fcntl.flock`)
  while it runs; a second server on the same dataset is refused, naming the process that
  holds it (two would give two participants the same row of the design). The kernel
  releases the lock when the process ends, however it ends.
* **Interrupted sessions.** A session is ``running`` in its ``session.json`` until it ends;
  a server that is killed (``kill -9``, a power cut) cannot say so. The next server on the
  dataset, holding the lock, knows that no session of it runs, and marks each ``running``
  one ``interrupted`` (its episodes on disk are whole and kept).
* **Private recordings.** The dataset's folders are made ``0700`` and its files ``0600``
  (owner only) when the server starts, and every session's when it ends; ``serve`` also
  sets the process's umask to ``077``, so that files are private from the moment they are
  written.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import stat
import time
from pathlib import Path
from typing import Any

from hri_bench.core.atomic import atomic_writer
from hri_bench.data.datasets import Dataset
from hri_envs.errors import ConfigError

__all__ = ["LOCK", "DatasetLock", "mark_interrupted", "make_private"]

#: The lock file in the dataset's folder.
LOCK = ".serve.lock"
#: A session's metadata file (hri_bench.data.datasets writes it).
SESSION_FILE = "session.json"


class DatasetLock:
    """Hold ``<dataset>/.serve.lock`` until :meth:`release` (or the process ends).

    Raises:
        ConfigError: Another process holds it (``field="dataset"``), or the folder cannot
            hold it.
    """

    def __init__(self, dataset: Dataset) -> None:
        path = dataset.path / LOCK
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
        except OSError as exc:
            raise ConfigError(f"cannot lock {dataset.path} ({exc.strerror or exc}); give a "
                              "dataset folder you can write to", field="dataset") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            os.close(fd)
            raise ConfigError(
                f"another hri-bench serve{f' (process {holder})' if holder.isdigit() else ''} "
                f"records into the dataset {dataset.dataset_id!r} ({dataset.path}); stop it, "
                "or give another --dataset", field="dataset") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd: int | None = fd

    def release(self) -> None:
        """Let another server use the dataset."""
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor releases the flock
            self._fd = None


def mark_interrupted(dataset: Dataset) -> list[str]:
    """Mark every session of ``dataset`` still ``running`` as ``interrupted`` (call it only
    holding the :class:`DatasetLock`: then none runs); the participants marked.
    """
    marked = []
    for folder in dataset.session_dirs():
        path = folder / SESSION_FILE
        try:
            meta: Any = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue  # unreadable: left to `dataset show` to name
        if not isinstance(meta, dict) or meta.get("status") != "running":
            continue
        meta.update(status="interrupted",
                    episodes_recorded=len(list(folder.glob("episode-*.parquet"))),
                    interrupted_noticed_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
        with atomic_writer(path) as f:
            f.write(json.dumps(meta, indent=1, sort_keys=True, allow_nan=False) + "\n")
        marked.append(folder.name)
    return marked


def make_private(path: Path) -> None:
    """Make ``path`` and everything under it the owner's only: folders ``0700``, regular
    files ``0600`` (symbolic links are left alone, and not followed).

    Raises:
        OSError: A mode cannot be changed (another user's file, say).
    """
    def chmod(p: Path) -> None:
        try:
            mode = os.lstat(p).st_mode
        except FileNotFoundError:  # removed meanwhile (a temporary file)
            return
        if stat.S_ISDIR(mode) or stat.S_ISREG(mode):
            with contextlib.suppress(FileNotFoundError):
                os.chmod(p, 0o700 if stat.S_ISDIR(mode) else 0o600)

    chmod(path)
    if path.is_dir() and not path.is_symlink():
        for root, dirs, files in os.walk(path):
            for name in (*dirs, *files):
                chmod(Path(root) / name)
