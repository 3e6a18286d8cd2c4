"""Files that appear complete or not at all: write to a temporary name, then rename.

:func:`os.replace` within one directory is atomic on POSIX and Windows, so a reader (or a
study resumed after a kill) sees either the previous file or the whole new one, never a
truncated one. The file is flushed to disk before the rename and the directory after it,
so a file that is in place stays in place across a crash of the machine. This module
imports nothing from the package.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_path", "atomic_writer", "fsync_dir", "move_into_place"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def fsync_dir(path: str | os.PathLike[str]) -> None:
    """Flush a directory's entries (a rename or an unlink in it) to disk, where the system
    allows it (POSIX; a no-op where directories cannot be opened, as on Windows).
    """
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems do not sync directories
        pass
    finally:
        os.close(fd)


def move_into_place(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
    """Flush ``src`` to disk and rename it to ``dst`` (same file system), durably."""
    with open(src, "rb+") as f:
        os.fsync(f.fileno())
    os.replace(src, dst)
    fsync_dir(Path(dst).parent)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str = "") -> Iterator[Path]:
    """A temporary path beside ``path``, renamed to ``path`` when the block succeeds.

    Args:
        path: The final file.
        suffix: Ending of the temporary name (some writers, e.g. ``numpy.savez``, append
            ``.npz`` unless the name ends with it).

    Yields:
        The temporary path to write; it is removed if the block raises. An
        :class:`OSError` without a file name (a full disk, say) is given ``path`` as its
        ``filename``, so that the caller can say which file could not be written.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{suffix}")
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0o600 -> what open() would give
        move_into_place(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.filename is None:
            exc.filename = str(path)
        raise


@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str], mode: str = "w", **kwargs: Any
                  ) -> Iterator[IO[Any]]:
    """``open(path, mode, **kwargs)`` whose contents replace ``path`` only when complete."""
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as f:
        yield f
