"""Files that appear complete or not at all: write to a temporary name, then rename.

:func:`os.replace` within one directory is atomic on POSIX and Windows, so a reader (or a
study resumed after a kill) sees either the previous file or the whole new one, never a
truncated one. This module imports nothing from the package.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["atomic_path", "atomic_writer"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str = "") -> Iterator[Path]:
    """A temporary path beside ``path``, renamed to ``path`` when the block succeeds.

    Args:
        path: The final file.
        suffix: Ending of the temporary name (some writers, e.g. ``numpy.savez``, append
            ``.npz`` unless the name ends with it).

    Yields:
        The temporary path to write; it is removed if the block raises.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=f".tmp{suffix}")
    os.close(fd)
    try:
        yield Path(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0o600 -> what open() would give
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str], mode: str = "w", **kwargs: Any
                  ) -> Iterator[IO[Any]]:
    """``open(path, mode, **kwargs)`` whose contents replace ``path`` only when complete."""
    with atomic_path(path) as tmp, open(tmp, mode, **kwargs) as f:
        yield f

