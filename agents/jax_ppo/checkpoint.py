"""Save and load a trained policy: one ``.npz`` of arrays plus a JSON config, no pickle.

The JSON (the network's sizes, the scenario, how it was trained) is stored in the archive
as the uint8 array ``__config__``; everything is read with ``allow_pickle=False``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import LearnerStateError

__all__ = ["CONFIG_KEY", "FORMAT", "load", "save"]

CONFIG_KEY = "__config__"
#: The format tag every checkpoint carries.
FORMAT = "hri-envs/jaxppo-v1"


def save(path: str | os.PathLike[str], params: dict[str, Any], config: dict[str, Any]) -> Path:
    """Write ``params`` (name -> array) and ``config`` (JSON-ready) to ``path`` (.npz)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    blob = json.dumps({"format": FORMAT, **config}, sort_keys=True).encode()
    arrays = {k: np.asarray(v) for k, v in params.items()}
    arrays[CONFIG_KEY] = np.frombuffer(blob, dtype=np.uint8)
    with open(path, "wb") as f:
        np.savez(f, **arrays)  # type: ignore[arg-type]
    return path


def load(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """``(params, config)`` of a checkpoint written by :func:`save`.

    Raises:
        LearnerStateError: The file is missing, not an ``.npz`` of this format, or holds
            objects (which would need pickle).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise LearnerStateError(f"cannot read the JAX PPO checkpoint {str(path)!r}: {exc}; "
                                "give a .npz written by agents.jax_ppo.checkpoint.save") from None
    blob = arrays.pop(CONFIG_KEY, None)
    try:
        config = json.loads(bytes(blob).decode()) if blob is not None else None
    except (UnicodeDecodeError, json.JSONDecodeError):
        config = None
    if not isinstance(config, dict) or config.get("format") != FORMAT:
        raise LearnerStateError(f"{str(path)!r} is not a JAX PPO checkpoint ({FORMAT}): its "
                                f"{CONFIG_KEY!r} entry is missing or not this format's JSON")
    return arrays, config
