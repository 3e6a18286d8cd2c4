"""What made a number: agents' code identity, package versions, the suite's content hash.

* :func:`agent_identity`: a built-in agent is named by the installed ``hri-envs`` version;
  ``sb3:PATH`` by the model file's sha256, ``jaxppo[:PATH]`` by its checkpoint files';
  ``module:Class`` by the sha256 of its module's source file (every ``.py`` file of its
  top-level package when it is in one), the files' combined hash ``code_sha256``, and the
  constructor keywords the benchmark passes it (:func:`hri_bench.run.agents.contract_keywords`).
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
import importlib
import importlib.metadata
import json
import platform
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["PACKAGES", "agent_identity", "code_changes", "software", "suite_hash",
           "track_hash"]

#: Packages whose versions a results file records (None where not installed).
PACKAGES: tuple[str, ...] = ("hri-envs", "numpy", "scipy", "gymnasium", "pettingzoo", "mujoco")


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _combined(hashes: dict[str, str]) -> str:
    """One sha256 for several files, from their names and hashes."""
    return hashlib.sha256(json.dumps(hashes, sort_keys=True).encode()).hexdigest()


def _version(package: str) -> str | None:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return None


def software() -> dict[str, str | None]:
    """``python`` and each of :data:`PACKAGES`' installed versions (None: not installed)."""
    return {"python": platform.python_version(), **{p: _version(p) for p in PACKAGES}}


def _source_files(module_name: str) -> tuple[Path, list[Path]]:
    """(root, files): every ``.py`` file of the module's top-level package (or the module's
    own file when it is in none), with the folder their names are given relative to.
    """
    module = sys.modules.get(module_name) or importlib.import_module(module_name)
    top = module_name.split(".")[0]
    top_file = getattr(sys.modules.get(top) or importlib.import_module(top), "__file__", None)
    if top_file is not None and Path(top_file).name == "__init__.py":
        package = Path(top_file).parent
        return package.parent, sorted(p for p in package.rglob("*.py") if p.is_file())
    path = getattr(module, "__file__", None)
    return (Path("."), []) if path is None else (Path(path).parent, [Path(path)])


def agent_identity(name: str) -> dict[str, Any]:
    """How agent ``name`` of a study is identified (module docstring)."""
    from hri_bench.run.agents import (
        KNOWN_AGENTS,
        SB3_PREFIX,
        contract_keywords,
        import_agent,
        jaxppo_path,
    )

    if name in KNOWN_AGENTS and jaxppo_path(name) is None:
        return {"kind": "builtin", "package": "hri-envs", "version": _version("hri-envs")}
    if name.startswith(SB3_PREFIX):
        path = Path(name[len(SB3_PREFIX):])
        return {"kind": "sb3", "path": str(path),
                "sha256": _sha256(path) if path.is_file() else None}
    model = jaxppo_path(name)
    if model is not None:  # a file, or a folder of <scenario>.npz: their combined hash
        files = sorted(p for p in model.rglob("*") if p.is_file()) if model.is_dir() else (
            [model] if model.is_file() else [])
        hashes = {p.relative_to(model).as_posix() if model.is_dir() else p.name: _sha256(p)
                  for p in files}
        return {"kind": "jaxppo", "path": str(model),
                "sha256": _combined(hashes) if hashes else None}
    cls = import_agent(name)
    root, files = _source_files(cls.__module__)
    hashes = {p.relative_to(root).as_posix(): _sha256(p) for p in files}
    return {"kind": "custom", "module": cls.__module__, "class": cls.__qualname__,
            "files": hashes, "code_sha256": _combined(hashes),
            "constructor": list(contract_keywords(cls))}


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
