"""The fixed message format between the benchmark and an agent in a process of its own.

A message is a JSON object and a few NumPy arrays, framed on a byte stream (a pipe) as

    8 bytes    the length of the JSON text, big-endian
    the JSON   UTF-8; ``arrays`` lists each array as ``[name, dtype, shape]``
    the arrays their raw bytes, in the order listed, C order

Nothing is ever unpickled: a reader accepts only the dtypes of :data:`DTYPES` (booleans,
integers and floats, as integer or float actions of a continuous agent need), at most
:data:`MAX_BYTES` in a message, and rebuilds each array from its bytes with
:func:`numpy.frombuffer`. So whatever an agent's process writes, the benchmark reads data,
never code (docs/agents.md, "Your agent runs in a process of its own").
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import IO, Any

import numpy as np

__all__ = ["DTYPES", "MAX_BYTES", "WireError", "read_message", "write_message"]

#: The array types a message may hold (little-endian, as NumPy names them).
DTYPES: frozenset[str] = frozenset({"|b1", "|i1", "|u1", "<i4", "<i8", "<f4", "<f8"})
#: The largest message read (JSON and arrays): a batch's observations are a few kB.
MAX_BYTES = 256 * 2**20
_HEADER = 8


class WireError(RuntimeError):
    """A message that breaks the format, or a stream that ended mid-message."""


def write_message(stream: IO[bytes], header: Mapping[str, Any],
                  arrays: Mapping[str, np.ndarray] | None = None) -> None:
    """Write one message (``header`` must be JSON; its ``arrays`` key is set here)."""
    parts = []
    listed = []
    for name, value in (arrays or {}).items():
        arr = np.ascontiguousarray(value)
        if arr.dtype.kind == "b":
            arr = arr.astype("|b1")
        elif arr.dtype.str not in DTYPES:
            arr = arr.astype("<f8" if arr.dtype.kind == "f" else "<i8")
        listed.append([name, arr.dtype.str, list(arr.shape)])
        parts.append(arr.tobytes())
    text = json.dumps({**header, "arrays": listed}, allow_nan=False,
                      separators=(",", ":")).encode()
    stream.write(len(text).to_bytes(_HEADER, "big") + text + b"".join(parts))
    stream.flush()


def _read_exactly(stream: IO[bytes], n: int) -> bytes:
    data = stream.read(n)
    if data is None or len(data) != n:
        raise WireError(f"the stream ended after {0 if not data else len(data)} of {n} bytes")
    return data


def read_message(stream: IO[bytes]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """One message: ``(header, arrays)``.

    Raises:
        WireError: The stream ended, or the message breaks the format (a dtype not in
            :data:`DTYPES`, a size over :data:`MAX_BYTES`, JSON that is not an object).
        EOFError: The stream ended cleanly before a message.
    """
    first = stream.read(_HEADER)
    if not first:
        raise EOFError("the stream ended")
    if len(first) != _HEADER:
        raise WireError("the stream ended inside a message's length")
    size = int.from_bytes(first, "big")
    if size > MAX_BYTES:
        raise WireError(f"a message of {size} bytes; at most {MAX_BYTES}")
    try:
        header = json.loads(_read_exactly(stream, size))
    except (ValueError, UnicodeDecodeError) as exc:
        raise WireError(f"a message whose header is not JSON ({exc})") from None
    listed = header.pop("arrays", []) if isinstance(header, dict) else None
    if not isinstance(header, dict) or not isinstance(listed, list):
        raise WireError("a message whose header is not a JSON object with a list of arrays")
    arrays: dict[str, np.ndarray] = {}
    total = size
    for item in listed:
        if not (isinstance(item, list) and len(item) == 3 and isinstance(item[0], str)
                and item[1] in DTYPES and isinstance(item[2], list)
                and all(isinstance(d, int) and not isinstance(d, bool) and 0 <= d <= MAX_BYTES
                        for d in item[2])):
            raise WireError(f"a message lists an array as {str(item)[:80]}; expected "
                            f"[name, one of {sorted(DTYPES)}, [dims]]")
        dtype = np.dtype(item[1])
        count = int(np.prod(item[2], dtype=np.int64)) if item[2] else 1
        nbytes = count * dtype.itemsize
        total += nbytes
        if total > MAX_BYTES:
            raise WireError(f"a message of more than {MAX_BYTES} bytes")
        raw = _read_exactly(stream, nbytes)
        arrays[item[0]] = np.frombuffer(raw, dtype=dtype).reshape(item[2]).copy()
    return header, arrays
