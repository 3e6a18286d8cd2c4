"""Read an ``.npz`` archive of plain arrays with bounded memory, and never with pickle.

``np.load`` on an ``.npz`` allocates what a member's header declares before it reads a
byte, and decompresses whatever the member holds: a few kilobytes of deflated zeros can
declare (and cost) gigabytes. :class:`BoundedNpz` reads the zip directory and each
member's ``.npy`` header first (a few hundred bytes each), so the caller can refuse
shapes, dtypes and sizes before any array is read; a member is read only if its size in
the zip directory is exactly what its header declares, and all members read together
stay under ``max_bytes``. Object arrays (which need pickle) are refused.
"""

from __future__ import annotations

import math
import os
import zipfile
from pathlib import Path
from typing import IO, NamedTuple

import numpy as np
from numpy.lib import format as npy_format

from hri_envs.errors import LearnerStateError

__all__ = ["MAX_HEADER_BYTES", "BoundedNpz", "Header"]

#: The largest ``.npy`` header read (numpy's own default limit).
MAX_HEADER_BYTES = 10_000


class Header(NamedTuple):
    """What a member's ``.npy`` header declares.

    Attributes:
        shape: The array's shape.
        dtype: Its dtype (never an object dtype).
        nbytes: The bytes its data takes (shape × item size).
    """

    shape: tuple[int, ...]
    dtype: np.dtype
    nbytes: int


def _read_header(f: IO[bytes]) -> tuple[tuple[int, ...], np.dtype]:
    version = npy_format.read_magic(f)
    if version == (1, 0):
        shape, _, dtype = npy_format.read_array_header_1_0(f, max_header_size=MAX_HEADER_BYTES)
    elif version in ((2, 0), (3, 0)):
        shape, _, dtype = npy_format.read_array_header_2_0(f, max_header_size=MAX_HEADER_BYTES)
    else:
        raise ValueError(f"unknown .npy format version {version}")
    return tuple(int(n) for n in shape), np.dtype(dtype)


class BoundedNpz:
    """An ``.npz`` archive whose members are read only after their headers are checked.

    Opening it reads the zip directory and every ``.npy`` member's header
    (:attr:`headers`); :meth:`read` reads one member's array.

    Args:
        path: The archive.
        max_bytes: The most array data :meth:`read` returns in all (the sum of the
            members read).
        max_members: The most ``.npy`` members the archive may hold.

    Raises:
        LearnerStateError: More than ``max_members`` members, a member holds objects
            (pickle), declares a header larger than
            :data:`MAX_HEADER_BYTES`, or its uncompressed size in the zip directory is not
            the size its header declares (a deflate bomb, or a damaged member).
        OSError, zipfile.BadZipFile, ValueError, EOFError: The file cannot be read as a
            zip archive of ``.npy`` members (callers turn these into their own error).
    """

    def __init__(self, path: str | os.PathLike[str], *, max_bytes: int,
                 max_members: int = 64) -> None:
        self.path = Path(path)
        self.max_bytes = max_bytes
        self._read_bytes = 0
        self._zip = zipfile.ZipFile(self.path)
        try:
            self.headers: dict[str, Header] = {}
            self._infos: dict[str, zipfile.ZipInfo] = {}
            members = [i for i in self._zip.infolist() if i.filename.endswith(".npy")]
            if len(members) > max_members:
                raise LearnerStateError(f"{self.path}: {len(members):,} arrays; at most "
                                        f"{max_members} are read")
            for info in members:
                name = info.filename[:-4]
                with self._zip.open(info) as f:
                    shape, dtype = _read_header(f)
                    offset = f.tell()
                if dtype.hasobject:
                    raise LearnerStateError(f"{self.path}: {name} holds Python objects, which "
                                            "would need pickle; only plain arrays are read")
                nbytes = math.prod(shape) * dtype.itemsize
                if info.file_size != offset + nbytes:
                    raise LearnerStateError(
                        f"{self.path}: {name} takes {info.file_size:,} bytes in the archive's "
                        f"directory, but its header declares {offset + nbytes:,} (shape "
                        f"{shape} of {dtype}): a damaged or forged member, not read")
                self.headers[name] = Header(shape, dtype, nbytes)
                self._infos[name] = info
        except BaseException:
            self._zip.close()
            raise

    def read_all(self, names: list[str] | tuple[str, ...]) -> list[np.ndarray]:
        """The arrays of members ``names``, after checking that together they fit.

        Raises:
            LearnerStateError: They would exceed ``max_bytes`` (with what was read before),
                checked before any of them is read.
            KeyError, zipfile.BadZipFile, ValueError, EOFError: As :meth:`read`.
        """
        self._check_fits(names)
        return [self.read(name) for name in names]

    def _check_fits(self, names: list[str] | tuple[str, ...]) -> None:
        total = self._read_bytes + sum(self.headers[name].nbytes for name in names)
        if total > self.max_bytes:
            shapes = ", ".join(f"{n} {self.headers[n].shape}" for n in names)
            raise LearnerStateError(
                f"{self.path}: its arrays would take {total / 2**20:,.0f} MiB ({shapes}), "
                f"more than {self.max_bytes / 2**20:,.0f} MiB: larger than any state this "
                "reads, not read")

    def read(self, name: str) -> np.ndarray:
        """The array of member ``name`` (its header as :attr:`headers` says).

        Raises:
            LearnerStateError: Reading it would exceed ``max_bytes`` in all.
            KeyError: No such member.
            zipfile.BadZipFile, ValueError, EOFError: Its data is damaged (the CRC is
                checked).
        """
        header = self.headers[name]
        self._check_fits([name])
        with self._zip.open(self._infos[name]) as f:
            array = npy_format.read_array(f, allow_pickle=False,
                                          max_header_size=MAX_HEADER_BYTES)
            if f.read(1):  # nothing after the data; reading to the end checks the CRC
                raise ValueError(f"{name} has bytes after its data")
        self._read_bytes += header.nbytes
        return array

    def close(self) -> None:
        """Close the archive."""
        self._zip.close()

    def __enter__(self) -> BoundedNpz:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
