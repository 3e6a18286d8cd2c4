"""What made a number: agents' code identity, package versions, the suite's content hash.

* :func:`~hri_bench.run.agents.agent_identity` (in :mod:`hri_bench.run.agents`, re-exported
  here): a built-in agent is named by the installed ``hri-envs`` version; ``sb3:PATH`` by
  the model file's sha256, ``jaxppo[:PATH]`` by its checkpoint files'; ``module:Class`` by
  the sha256 of its module's source file (every ``.py`` file of its top-level package when
  it is in one), the files' combined hash ``code_sha256``, and the constructor keywords the
  benchmark passes it (:func:`hri_bench.run.agents.contract_keywords`).
* :func:`software`: Python's and the numerical packages' versions.
* :func:`suite_hash`: sha256 of the canonical JSON of the suite's version and its tracks'
  definitions, so that a track changed under the same name changes the hash.
* :func:`code_changes`: which agents' code differs from a recorded identity (the replay's
  warning).

See docs/results.md, "What is recorded".
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import platform
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from hri_bench.run.agents import agent_identity, package_version

__all__ = ["PACKAGES", "agent_identity", "code_changes", "software", "suite_hash",
           "track_hash"]

#: Packages whose versions a results file records (None where not installed).
PACKAGES: tuple[str, ...] = ("hri-envs", "numpy", "scipy", "gymnasium", "pettingzoo", "mujoco")


def software() -> dict[str, str | None]:
    """``python`` and each of :data:`PACKAGES`' installed versions (None: not installed)."""
    return {"python": platform.python_version(), **{p: package_version(p) for p in PACKAGES}}


def code_changes(recorded: Mapping[str, Any], agents: Iterable[str]) -> list[str]:
    """One line per agent whose code differs from its ``recorded`` identity (custom code
    hash, model file hash, or the hri-envs version of a built-in one).
    """
    lines = []
    for name in agents:
        old = recorded.get(name)
        if not isinstance(old, Mapping):
            continue
        try:
            new = agent_identity(name)
        except Exception as exc:  # noqa: BLE001 - the replay refuses it later, by name
            lines.append(f"agent {name!r}: cannot be identified now ({exc})")
            continue
        for key in ("code_sha256", "sha256", "version"):
            if key in old and old.get(key) != new.get(key):
                what = {"code_sha256": "its source files' hash", "sha256": "its model file's "
                        "hash", "version": "the hri-envs version"}[key]
                changed = ""
                if key == "code_sha256":
                    files = sorted(set(old.get("files", {})) ^ set(new.get("files", {})) | {
                        f for f in set(old.get("files", {})) & set(new.get("files", {}))
                        if old["files"][f] != new["files"][f]})
                    changed = f" (changed: {', '.join(files)})" if files else ""
                lines.append(f"agent {name!r}: {what} differs from the recorded one{changed}: "
                             f"{str(old.get(key))[:12]} then, {str(new.get(key))[:12]} now; "
                             "the numbers may differ")
    return lines


def _canonical(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, float) and value != value:
        return "nan"
    if isinstance(value, float) and value in (float("inf"), float("-inf")):
        return str(value)
    return value


def track_hash(track: Any) -> str:
    """sha256 of a track's definition (every field of the :class:`hri_bench.suite.Track`)."""
    text = json.dumps(_canonical(track), sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def suite_hash(version: str, tracks: Sequence[Any]) -> str:
    """sha256 of the suite version and its tracks' hashes, in order."""
    text = json.dumps([version, [track_hash(t) for t in tracks]], separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
