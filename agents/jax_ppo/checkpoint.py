"""Save and load a trained policy: one ``.npz`` of arrays plus a JSON config, no pickle.

The JSON (the network's sizes, the scenario, how it was trained) is stored in the archive
as the uint8 array ``__config__``; everything is read with bounded memory and without
pickle (:class:`~agents.archive.BoundedNpz`). Weights that are not all finite (a training
that diverged) are refused both when saved and when loaded.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from agents.archive import BoundedNpz
from hri_envs.errors import LearnerStateError

__all__ = ["CONFIG_KEY", "FORMAT", "MAX_CHECKPOINT_BYTES", "load", "save"]

CONFIG_KEY = "__config__"
#: The format tag every checkpoint carries.
FORMAT = "hri-envs/jaxppo-v1"
#: The most memory a checkpoint's arrays may take when loaded (the shipped ones: 50 kB).
MAX_CHECKPOINT_BYTES = 256 * 2**20
#: The most its JSON config may take.
MAX_CONFIG_BYTES = 2**20


def _not_finite(arrays: dict[str, np.ndarray]) -> str | None:
    """The first array that is not all finite real numbers, with what it holds."""
    for name, a in arrays.items():
        if a.dtype.kind not in "fiu":
            return f"{name} holds {a.dtype} values (weights are real numbers)"
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            return f"{name} holds NaN or infinity"
    return None


def save(path: str | os.PathLike[str], params: dict[str, Any], config: dict[str, Any]) -> Path:
    """Write ``params`` (name -> array) and ``config`` (JSON-ready) to ``path`` (.npz).

    Raises:
        LearnerStateError: A weight is NaN or infinite, or not a real number (nothing is
            written: :func:`load` would refuse it).
    """
    path = Path(path)
    arrays = {k: np.asarray(v) for k, v in params.items()}
    bad = _not_finite(arrays)
    if bad is not None:
        raise LearnerStateError(f"not saving {str(path)!r}: weight {bad} (the training "
                                "diverged: lower the learning rate or the coefficients)")
    path.parent.mkdir(parents=True, exist_ok=True)
    blob = json.dumps({"format": FORMAT, **config}, sort_keys=True).encode()
    arrays[CONFIG_KEY] = np.frombuffer(blob, dtype=np.uint8)
    with open(path, "wb") as f:
        np.savez(f, **arrays)  # type: ignore[arg-type]
    return path


def load(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``(params, config)`` of a checkpoint written by :func:`save`.

    Raises:
        LearnerStateError: The file is missing, not an ``.npz`` of this format, holds
            objects (which would need pickle), arrays larger than
            :data:`MAX_CHECKPOINT_BYTES` in all, or weights that are not all finite real
            numbers (naming the file and the array).
    """
    path = Path(path)
    try:
        with BoundedNpz(path, max_bytes=MAX_CHECKPOINT_BYTES) as npz:
            head = npz.headers.get(CONFIG_KEY)
            blob = None
            if (head is not None and head.dtype == np.uint8 and len(head.shape) == 1
                    and head.nbytes <= MAX_CONFIG_BYTES):
                blob = npz.read(CONFIG_KEY)
            arrays: dict[str, np.ndarray] = {}
            if blob is not None:  # the weights only with a config (checked below)
                names = [k for k in npz.headers if k != CONFIG_KEY]
                arrays = dict(zip(names, npz.read_all(names), strict=True))
    except LearnerStateError as exc:
        raise LearnerStateError(f"cannot read the JAX PPO checkpoint: {exc}") from None
    except Exception as exc:  # zip, zlib, EOF, header ... errors alike
        raise LearnerStateError(f"cannot read the JAX PPO checkpoint {str(path)!r}: {exc}; "
                                "give a .npz written by agents.jax_ppo.checkpoint.save") from None
    try:
        config = json.loads(bytes(blob).decode()) if blob is not None else None
    except (UnicodeDecodeError, json.JSONDecodeError):
        config = None
    if not isinstance(config, dict) or config.get("format") != FORMAT:
        raise LearnerStateError(f"{str(path)!r} is not a JAX PPO checkpoint ({FORMAT}): its "
                                f"{CONFIG_KEY!r} entry is missing or not this format's JSON")
    bad = _not_finite(arrays)
    if bad is not None:
        raise LearnerStateError(f"{str(path)!r}: weight {bad}; a policy that cannot act is "
                                "refused (retrain it: the training diverged)")
    return arrays, config
