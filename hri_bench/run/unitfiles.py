"""A study's work on disk, in ``DIR/.units``: each finished unit as a ``.npz`` of numpy
arrays (:func:`save_unit`, :func:`load_units`, :func:`unit_path`; written under a temporary
name, then renamed) and a study's finished result (:func:`save_result`,
:func:`load_result`), so that an interrupted study or suite resumes where it stopped
(:mod:`hri_bench.run.studyio`).
"""

from __future__ import annotations

import glob
import json
import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.core.atomic import atomic_path, atomic_writer
from hri_bench.run.runner import TASK_METRICS
from hri_bench.run.study import StudyConfig, StudyResult, Unit, UnitResult

_RESULT_FORMAT = "hri-bench-study-result-1"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)[:40]


def unit_path(folder: Path, index: int, unit: Unit) -> Path:
    """Where unit ``index`` of a study is kept in ``folder`` once finished."""
    name = f"{index:04d}-{_slug(unit.agent)}-{_slug(unit.preference)}"
    return Path(folder) / f"{name}-{unit.runs[0]}-{unit.runs[-1]}.npz"


def remove_temporary(folder: Path, names: Iterable[str]) -> None:
    """Remove the temporary files a killed write of ``names`` left in ``folder``
    (:func:`~hri_bench.core.atomic.atomic_path`'s ``.NAME.*.tmp``).
    """
    for name in names:
        for tmp in Path(folder).glob(f".{glob.escape(name)}.*.tmp"):
            tmp.unlink(missing_ok=True)


def save_unit(path: Path, result: UnitResult) -> None:
    """Write a finished unit's result to ``path`` (numpy arrays, no pickle; atomically)."""
    metrics, probes, schedule, humans = result
    arrays: dict[str, Any] = {**{f"m.{k}": v for k, v in metrics.items()}, "probes": probes,
                              **{f"s.{k}": v for k, v in schedule.items()},
                              "humans": np.array(humans, dtype=str)}
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez(tmp, allow_pickle=False, **arrays)


def load_units(folder: Path, units: list[Unit]) -> dict[int, UnitResult]:
    """The finished units of ``units`` kept in ``folder`` (:func:`unit_path`), by index;
    unreadable files, and units an earlier version wrote without today's metrics, are left
    out (simulated again).
    """
    done: dict[int, UnitResult] = {}
    for i, u in enumerate(units):
        path = unit_path(folder, i, u)
        if not path.is_file():
            continue
        try:
            with np.load(path, allow_pickle=False) as data:
                metrics = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("m.")}
                if not set(TASK_METRICS) <= set(metrics):
                    continue  # written before the task's metrics: simulated again
                schedule = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("s.")}
                done[i] = (metrics, np.array(data["probes"]), schedule,
                           [str(h) for h in data["humans"]])
        except Exception:  # a damaged unit is simulated again
            continue
    return done


def _beside(path: Path, suffix: str) -> Path:
    return path.parent / f"{path.name}{suffix}"


def save_result(path: Path, result: StudyResult, extra: dict[str, Any]) -> None:
    """Write a whole :class:`StudyResult` (but its configuration) to ``PATH.npz`` and
    ``PATH.json`` (its failures, the order of its agents and ``extra``), the arrays first,
    each atomically: the ``.json`` in place means that both are.
    """
    agents = list(result.metrics)
    arrays: dict[str, Any] = {"humans": np.array(result.humans, dtype=str)}
    for j, agent in enumerate(agents):
        arrays.update({f"m.{j}.{k}": v for k, v in result.metrics[agent].items()})
        arrays[f"p.{j}"] = result.probes[agent]
    arrays.update({f"s.{k}": v for k, v in result.schedule.items()})
    with atomic_path(_beside(path, ".npz"), suffix=".npz") as tmp:
        np.savez(tmp, allow_pickle=False, **arrays)
    with atomic_writer(_beside(path, ".json")) as f:
        json.dump({"format": _RESULT_FORMAT, "agents": agents, "failures": result.failures,
                   "wall_time_s": result.wall_time_s, **extra}, f)


def load_result(path: Path, cfg: StudyConfig) -> tuple[StudyResult, dict[str, Any]] | None:
    """The :class:`StudyResult` of study ``cfg`` that :func:`save_result` wrote to ``PATH.*``
    with the document of its ``.json``; None when it is missing or unreadable (the study
    is simulated again).
    """
    try:
        doc = json.loads(_beside(path, ".json").read_text())
        if doc.get("format") != _RESULT_FORMAT:
            return None
        with np.load(_beside(path, ".npz"), allow_pickle=False) as data:
            metrics: dict[str, dict[str, np.ndarray]] = {}
            probes: dict[str, np.ndarray] = {}
            for j, agent in enumerate(doc["agents"]):
                head = f"m.{j}."
                metrics[agent] = {k[len(head):]: np.array(data[k]) for k in data.files
                                  if k.startswith(head)}
                probes[agent] = np.array(data[f"p.{j}"])
            schedule = {k[2:]: np.array(data[k]) for k in data.files if k.startswith("s.")}
            humans = [str(h) for h in data["humans"]]
    except Exception:  # missing, damaged or of another layout: simulated again
        return None
    result = StudyResult(cfg, metrics, probes, schedule, float(doc["wall_time_s"]),
                         humans=humans, failures=dict(doc["failures"]))
    return result, doc
