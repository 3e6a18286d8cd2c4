"""Recorded sessions as datasets: the multi-agent episode schema and a Minari view.

Every session of ``hri-bench serve`` (a person in the human's seat) and of ``hri-bench
dataset record`` (scripted humans, labelled synthetic) is written here, one Parquet file per
finished episode, so that a crash loses at most the episode in progress of the session that
crashed. On disk (docs/people.md, "Datasets")::

    ROOT/<dataset id>/dataset.json                          id, schema, scenario, synthetic
    ROOT/<dataset id>/sessions/<participant>/session.json   the session's settings and state
    ROOT/<dataset id>/sessions/<participant>/episode-0001.parquet   its steps (COLUMNS)
    ROOT/<dataset id>/minari/                               the robot's view (export_minari)

``ROOT`` is ``--data``, else ``$HRI_BENCH_DATASETS``, else ``~/.hri-bench/datasets``. A
dataset id is ``name-vN`` (Minari's form; ``-v0`` is added to a bare name). Participants are
anonymous random ids (``p`` and 12 hex digits for people, ``s0001`` ... for scripted
humans); nothing else about a person is stored.

Every episode file is checked as it is read (:mod:`hri_bench.data.checks`; an episode in
two files is refused too), and the sessions that did not finish (:data:`UNFINISHED`) are
left out of the data unless asked for by participant.

Two views of the same steps:

* **The multi-agent episode schema** (:data:`COLUMNS`): one row per joint step with both
  agents' observations, actions and rewards, the intention, the robot's belief where it
  has one, timestamps and response times. :meth:`Dataset.steps` reads it as one Arrow table,
  :func:`export_parquet` writes it as one file whose schema metadata holds the dataset id,
  the schema version and the content hash (:meth:`Dataset.content_hash`).
* **Minari** (:func:`export_minari`): the robot's Gymnasium view (the observations of
  ``hri_envs/Hanger-v0``, the robot's actions and rewards), loadable with
  ``minari.load_dataset`` (Minari has no multi-agent format).

Needs the ``web`` extra (pyarrow, and minari for the Minari view).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import secrets
import shutil
import tempfile
import threading
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from hri_bench.core.atomic import atomic_path, atomic_writer, fsync_dir
from hri_bench.data.checks import check_steps, read_episode
from hri_bench.data.physical import (
    NULLABLE,
    PHYSICAL_COLUMNS,
    PHYSICAL_SCHEMA,
    check_physical_steps,
    robot_episode_arrays,
)
from hri_envs import __version__  # importing hri_envs registers the env ids
from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import SCENARIOS, NamedScenario, as_graph

__all__ = [
    "COLUMNS",
    "DATASETS_ENV",
    "MINARI_NAMESPACE",
    "SCHEMA_VERSION",
    "UNFINISHED",
    "Dataset",
    "SessionWriter",
    "check_dataset_id",
    "create_dataset",
    "data_root",
    "export_minari",
    "export_parquet",
    "list_datasets",
    "new_participant_id",
    "open_dataset",
    "robot_episodes",
]

#: Version of the multi-agent episode schema (:data:`COLUMNS`).
SCHEMA_VERSION = "hri-envs/episodes/1"
#: The environment variable naming the datasets' root folder.
DATASETS_ENV = "HRI_BENCH_DATASETS"
#: The Minari namespace of exported datasets: ``hri-envs/<dataset id>``.
MINARI_NAMESPACE = "hri-envs"

#: The multi-agent episode schema: one row per joint step (name, Arrow type, meaning).
#: Indices are the task graph's: supports (start, intentions), states, actions
#: (``TaskGraph.support_names``, ``state_names``, ``agent_action_label``).
COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("participant", "string", "anonymous participant id (random; nothing personal)"),
    ("session_index", "int32", "the participant's row of the counterbalanced design (join order)"),
    ("synthetic", "bool", "true for scripted humans (never human data)"),
    ("episode", "int32", "episode of the session, from 0"),
    ("step", "int32", "step of the episode, from 0"),
    ("start", "int8", "the episode's start support"),
    ("assigned_intention", "int8", "the goal the human was given for the episode"),
    ("intention", "int8", "ι in the human's observation at this step (after turning back)"),
    ("state", "int16", "the state before the step"),
    ("next_state", "int16", "the state after the step"),
    ("action_mask", "list<int8>", "the actions valid in state (both agents' mask)"),
    ("robot_last_human_action", "int16", "last_human_action in the robot's observation"),
    ("human_last_human_action", "int16", "last_human_action in the human's observation"),
    ("robot_action", "int16", "the robot's action (the human saw it before acting)"),
    ("human_action", "int16", "the human's action"),
    ("robot_reward", "float64", "the robot's cooperation reward R_R of the step"),
    ("human_reward", "float64", "the human's goal reward of the step (-1 aborted, +1 reached ι)"),
    ("aborted", "bool", "the joint action was aborted (nothing moved)"),
    ("belief", "list<float64>", "the robot's belief over intentions when it acted; null if "
     "the agent exposes none"),
    ("t_shown", "float64", "Unix time [s] the human was asked to act (the picture sent)"),
    ("t_action", "float64", "Unix time [s] the human's action arrived"),
    ("response_s", "float64", "t_action - t_shown [s], measured by the server"),
    ("client_response_ms", "float64", "picture shown to key press [ms], measured in the "
     "browser; null for scripted humans"),
    ("terminated", "bool", "this step ended the episode (the object rests on a goal)"),
    ("truncated", "bool", "the episode stopped after this step without ending (step limit)"),
    ("layout", "list<float64>", "the supports' layout (wheel stands x, y [m]); empty: nominal"),
)

_ID_RE = re.compile(r"^[a-z0-9][a-z0-9_.-]{0,62}-v(0|[1-9][0-9]{0,5})$")
_NAME_RE = re.compile(r"^[a-z0-9][a-z0-9_.-]{0,62}$")
_PARTICIPANT_RE = re.compile(r"^(p[0-9a-f]{12}|s[0-9]{4,9})$")
_EPISODE_FILE = "episode-{:04d}.parquet"
_DATASET_FILE = "dataset.json"
_SESSION_FILE = "session.json"
_RECORDING_LOCK = ".recording"  # flock()ed by ``dataset record`` while it records
#: Session statuses of a session that did not finish: ``running`` (in progress, or its
#: server was killed) and ``interrupted`` (its recorder was stopped or killed). Their
#: episodes are left out of :meth:`Dataset.steps` (so of the content hash, the exports and
#: the fits) unless asked for by participant.
UNFINISHED = ("running", "interrupted")
_lock = threading.Lock()  # MINARI_DATASETS_PATH is process-wide; dataset.json creation


def _pa() -> Any:
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError as exc:
        raise MissingExtraError(["pyarrow"], "recorded datasets") from exc
    return pyarrow


def _arrow_type(pa: Any, name: str) -> Any:
    if name.startswith("list<"):
        return pa.list_(_arrow_type(pa, name[5:-1]))
    return {"string": pa.string(), "bool": pa.bool_(), "int8": pa.int8(),
            "int16": pa.int16(), "int32": pa.int32(), "float32": pa.float32(),
            "float64": pa.float64()}[name]


def schema(metadata: Mapping[str, str] | None = None, *, physical: bool = False) -> Any:
    """The Arrow schema of :data:`COLUMNS` (``physical``: of
    :data:`~hri_bench.data.physical.PHYSICAL_COLUMNS`), each field's meaning in its metadata.
    """
    pa = _pa()
    columns, nullable = ((PHYSICAL_COLUMNS, NULLABLE) if physical
                         else (COLUMNS, frozenset({"belief", "client_response_ms"})))
    fields = [pa.field(n, _arrow_type(pa, t), nullable=n in nullable, metadata={"doc": doc})
              for n, t, doc in columns]
    return pa.schema(fields, metadata=dict(metadata or {}))


def data_root(root: str | os.PathLike[str] | None = None) -> Path:
    """The datasets' root folder: ``root``, else ``$HRI_BENCH_DATASETS``, else
    ``~/.hri-bench/datasets``.
    """
    if root is not None:
        return Path(root)
    env = os.environ.get(DATASETS_ENV)
    return Path(env) if env else Path.home() / ".hri-bench" / "datasets"


def check_dataset_id(name: Any, field: str = "dataset") -> str:
    """A dataset id ``name-vN`` (lower-case letters, digits, ``_ . -``); ``-v0`` is added to
    a bare name. A :class:`ConfigError` naming ``field`` otherwise (ids are folder names:
    no ``/``, no ``..``).
    """
    if isinstance(name, str) and _NAME_RE.match(name) and not _ID_RE.match(name):
        name = f"{name}-v0"
    if not isinstance(name, str) or not _ID_RE.match(name) or ".." in name:
        raise ConfigError(f"a dataset id is 'name-vN' (lower-case letters, digits, '_', '.', "
                          f"'-'; up to 63 characters; e.g. hanger-people-v0), got {name!r}",
                          field=field)
    return name


def new_participant_id() -> str:
    """A fresh anonymous participant id: ``p`` and 12 random hex digits."""
    return "p" + secrets.token_hex(6)


#: The largest ``dataset.json`` or ``session.json`` read.
_MAX_JSON_BYTES = 4 * 2**20


def _read_json(path: Path, what: str) -> dict[str, Any]:
    try:
        if not path.is_file():
            raise OSError("not a regular file")
        with open(path, "rb") as f:
            data = f.read(_MAX_JSON_BYTES + 1)
        if len(data) > _MAX_JSON_BYTES:
            raise ValueError(f"larger than {_MAX_JSON_BYTES // 2**20} MiB")
        doc = json.loads(data)
    except (OSError, ValueError, RecursionError) as exc:
        raise ConfigError(f"{path}: cannot read {what} ({exc})", field="dataset") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: {what} is no JSON object", field="dataset")
    return doc


def _session_meta(folder: Path) -> dict[str, Any]:
    """A session folder's ``session.json``, checked: its participant is the folder's, its
    status a string and its session index a whole number >= 0.
    """
    path = folder / _SESSION_FILE
    meta = _read_json(path, "a session's metadata")
    index = meta.get("session_index")
    if meta.get("participant") != folder.name:
        raise ConfigError(f"{path}: participant {meta.get('participant')!r} is not the "
                          f"folder's {folder.name!r}", field="dataset")
    if not isinstance(meta.get("status"), str):
        raise ConfigError(f"{path}: no status (a string)", field="dataset")
    if isinstance(index, bool) or not isinstance(index, int) or index < 0:
        raise ConfigError(f"{path}: session_index must be a whole number >= 0, got "
                          f"{index!r}", field="dataset")
    return meta


def _write_json(path: Path, doc: Mapping[str, Any]) -> None:
    with atomic_writer(path) as f:
        f.write(json.dumps(doc, indent=1, sort_keys=True, allow_nan=False) + "\n")


@dataclass(frozen=True)
class Dataset(NamedScenario):
    """A dataset folder (:func:`open_dataset`, :func:`create_dataset`).

    Attributes:
        path: ``ROOT/<dataset id>``.
        meta: ``dataset.json``: ``dataset_id``, ``schema``, ``scenario``, ``synthetic``,
            ``created_utc``, ``description``.
    """

    path: Path
    meta: dict[str, Any]

    @property
    def dataset_id(self) -> str:
        """The id, ``name-vN``."""
        return str(self.meta["dataset_id"])

    @property
    def scenario(self) -> str:
        """"hanger" or "wheel"."""
        return str(self.meta["scenario"])

    @property
    def synthetic(self) -> bool:
        """Whether the sessions are scripted humans' (never human data)."""
        return bool(self.meta["synthetic"])

    @property
    def physical(self) -> bool:
        """Whether the sessions are of the continuous physical envs (schema
        :data:`~hri_bench.data.physical.PHYSICAL_SCHEMA`), not of the task graph.
        """
        return self.meta.get("schema") == PHYSICAL_SCHEMA

    @property
    def minari_id(self) -> str:
        """The id of the Minari view: ``hri-envs/<dataset id>``."""
        return f"{MINARI_NAMESPACE}/{self.dataset_id}"

    def session_dirs(self) -> list[Path]:
        """The sessions' folders (one per participant), sorted by name."""
        base = self.path / "sessions"
        if not base.is_dir():
            return []
        return sorted(p for p in base.iterdir()
                      if p.is_dir() and _PARTICIPANT_RE.match(p.name))

    def sessions(self) -> list[dict[str, Any]]:
        """Each session's ``session.json`` (with ``episodes_recorded`` counted from its
        files), in join order. A scripted session still ``running`` while no ``hri-bench
        dataset record`` records this dataset is given as ``interrupted`` (its recorder
        was killed).

        Raises:
            ConfigError: A ``session.json`` that is unreadable, is not of the folder's
                participant, or has no status or session index (``field="dataset"``).
        """
        out = []
        recording: bool | None = None
        for d in self.session_dirs():
            if not (d / _SESSION_FILE).is_file():
                continue
            meta = _session_meta(d)
            meta["episodes_recorded"] = len(self.episode_paths([d.name]))
            if meta["status"] == "running" and meta.get("source") == "scripted":
                if recording is None:
                    recording = self.recorder_alive()
                if not recording:
                    meta["status"] = "interrupted"
            out.append(meta)
        return sorted(out, key=lambda m: (m["session_index"], m["participant"]))

    def participants(self, *, unfinished: bool = True) -> list[str]:
        """The participants' ids, in join order (``unfinished=False``: of the sessions that
        finished, whose status is not in :data:`UNFINISHED`).
        """
        return [str(m["participant"]) for m in self.sessions()
                if unfinished or m["status"] not in UNFINISHED]

    def unfinished(self) -> list[dict[str, Any]]:
        """The sessions that did not finish (status in :data:`UNFINISHED`): ``participant``,
        ``status``, ``episodes_recorded``, ``episodes_planned``.
        """
        return [{k: m.get(k) for k in ("participant", "status", "episodes_recorded",
                                        "episodes_planned")}
                for m in self.sessions() if m["status"] in UNFINISHED]

    def recorder_alive(self) -> bool:
        """Whether an ``hri-bench dataset record`` is recording into this dataset now (it
        holds the dataset's recording lock; the kernel frees it when the process ends).
        """
        try:
            fd = os.open(self.path / _RECORDING_LOCK, os.O_RDONLY)
        except OSError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        except OSError:
            return False
        finally:
            os.close(fd)  # and with it the shared lock
        return False

    @contextlib.contextmanager
    def recording(self, timeout_s: float = 5.0) -> Iterator[None]:
        """Hold the dataset's recording lock while sessions are recorded into it; first mark
        scripted sessions a killed recorder left ``running`` as ``interrupted``.

        Raises:
            ConfigError: Another process records into the dataset (``field="dataset"``).
        """
        fd = os.open(self.path / _RECORDING_LOCK, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            deadline = time.monotonic() + timeout_s  # readers hold it for a moment only
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        raise ConfigError(f"another hri-bench dataset record is recording "
                                          f"into {self.dataset_id} ({self.path}); wait for "
                                          "it to end", field="dataset") from None
                    time.sleep(0.05)
            for folder in self.session_dirs():  # the lock is held: no other recorder
                if (folder / _SESSION_FILE).is_file():
                    meta = _session_meta(folder)
                    if meta["status"] == "running" and meta.get("source") == "scripted":
                        _write_json(folder / _SESSION_FILE, {**meta, "status": "interrupted"})
            yield
        finally:
            os.close(fd)

    def check_orphans(self) -> None:
        """Refuse a session folder holding episode files but no ``session.json`` (its
        settings and status are unknown: neither its steps nor the dataset's can be read as
        a whole).

        Raises:
            ConfigError: Naming the first such folder (``field="dataset"``).
        """
        orphans = [d for d in self.session_dirs() if not (d / _SESSION_FILE).is_file()
                   and self.episode_paths([d.name])]
        if orphans:
            raise ConfigError(f"{orphans[0]}: episode files without a session.json",
                              field="dataset")

    def episode_paths(self, participants: Sequence[str] | None = None) -> list[Path]:
        """The episode files of ``participants`` (default all), by participant and episode."""
        dirs = self.session_dirs()
        if participants is not None:
            wanted = set(participants)
            dirs = [d for d in dirs if d.name in wanted]
        return [p for d in dirs for p in sorted(d.glob("episode-*.parquet"))]

    def steps(self, participants: Sequence[str] | None = None) -> Any:
        """Every recorded step of ``participants`` (default: every finished session's, see
        :data:`UNFINISHED`) as one Arrow table of :data:`COLUMNS`, sorted by session index,
        participant, episode and step.

        Raises:
            ConfigError: An episode file that is unreadable, not of the schema or not an
                episode of its session that the scenario's graph can have produced
                (:mod:`hri_bench.data.checks`), an episode in two files, or episode files
                of a session without ``session.json`` (``field="dataset"``).
        """
        pa = _pa()
        if participants is None:
            participants = self.participants(unfinished=False)
            self.check_orphans()
        paths = self.episode_paths(participants)
        target = schema(physical=self.physical)
        if not paths:
            return target.empty_table()
        graph = self.graph
        tables, seen = [], dict[tuple[str, int], Path]()
        for path in paths:
            table = read_episode(path, target)
            if self.physical:
                check_physical_steps(table, path, graph, participant=path.parent.name,
                                     synthetic=self.synthetic)
            else:
                check_steps(table, path, graph, participant=path.parent.name,
                            synthetic=self.synthetic)
            key = (path.parent.name, int(table.column("episode")[0].as_py()))
            if key in seen:
                raise ConfigError(f"{path}: episode {key[1] + 1} of {key[0]} is in "
                                  f"{seen[key].name} too (a copied file?); remove one",
                                  field="dataset")
            seen[key] = path
            tables.append(table)
        table = pa.concat_tables(tables).combine_chunks()
        return table.sort_by([("session_index", "ascending"), ("participant", "ascending"),
                              ("episode", "ascending"), ("step", "ascending")])

    def content_hash(self) -> str:
        """``sha256:`` of the steps: the Arrow IPC stream of :meth:`steps` without schema
        metadata, so it names the data, whatever the files' compression or writer.
        """
        pa = _pa()
        table = self.steps().replace_schema_metadata(None)
        sink = pa.BufferOutputStream()
        with pa.ipc.new_stream(sink, table.schema) as writer:
            writer.write_table(table)
        return "sha256:" + hashlib.sha256(sink.getvalue().to_pybytes()).hexdigest()

    def summary(self) -> dict[str, Any]:
        """What ``hri-bench dataset show`` prints: the metadata, the finished sessions'
        counts and content hash, the unfinished sessions, and every session.
        """
        sessions = self.sessions()
        used = [m for m in sessions if m["status"] not in UNFINISHED]
        table = self.steps()
        return {**self.meta, "participants": len(used),
                "episodes": sum(m["episodes_recorded"] for m in used),
                "steps": table.num_rows, "content_hash": self.content_hash(),
                "unfinished": self.unfinished(),
                "minari_id": self.minari_id, "path": str(self.path),
                "sessions": [{k: m.get(k) for k in ("participant", "session_index", "status",
                                                     "episodes_planned", "episodes_recorded",
                                                     "agent", "source", "started_utc")}
                             for m in sessions]}


def _utc() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def open_dataset(name: str | os.PathLike[str], root: str | os.PathLike[str] | None = None,
                 *, field: str = "dataset") -> Dataset:
    """The dataset ``name``: a dataset id under the root (:func:`data_root`), or the path of
    a dataset folder.

    Raises:
        ConfigError: No such dataset, or its ``dataset.json`` is unreadable (``field``
            names the option that named it).
    """
    given = Path(name)
    if (given / _DATASET_FILE).is_file():
        path = given
    else:
        dataset_id = check_dataset_id(str(name), field)
        path = data_root(root) / dataset_id
        if not (path / _DATASET_FILE).is_file():
            known = ", ".join(d.dataset_id for d in list_datasets(root)) or "none"
            raise ConfigError(f"no dataset {dataset_id!r} in {data_root(root)} (datasets "
                              f"there: {known}); give a dataset id or a dataset folder",
                              field=field)
    meta = _read_json(path / _DATASET_FILE, "a dataset's metadata")
    if meta.get("schema") not in (SCHEMA_VERSION, PHYSICAL_SCHEMA) \
            or meta.get("scenario") not in SCENARIOS:
        raise ConfigError(f"{path}: not a dataset of schema {SCHEMA_VERSION} or "
                          f"{PHYSICAL_SCHEMA} for a known scenario", field=field)
    try:  # it names folders and Minari's files: a plain name, never a path
        if check_dataset_id(meta.get("dataset_id"), field) != meta["dataset_id"]:
            raise ConfigError("not of the form name-vN", field=field)
    except ConfigError as exc:
        raise ConfigError(f"{path / _DATASET_FILE}: dataset_id {meta.get('dataset_id')!r} "
                          f"is no dataset id ({exc})", field=field) from None
    if not isinstance(meta.get("synthetic"), bool):
        raise ConfigError(f"{path / _DATASET_FILE}: synthetic must be true or false",
                          field=field)
    return Dataset(path, meta)


def create_dataset(dataset_id: str, scenario: TaskGraph | str, *, synthetic: bool,
                   root: str | os.PathLike[str] | None = None, description: str = "",
                   physical: bool = False) -> Dataset:
    """Create the dataset ``dataset_id`` under the root, or open it if it exists with the
    same scenario and the same kind of data (people or synthetic, graph or ``physical``
    sessions), to add sessions to it. ``scenario`` is the task graph, or a registered
    scenario's name (resolved here); ``dataset.json`` records its name.

    Raises:
        ConfigError: A bad id or an unknown scenario, or an existing dataset of another
            scenario or kind (people and scripted humans never share a dataset, nor graph
            and physical sessions; ``field="dataset"``).
    """
    name = as_graph(scenario).name  # what dataset.json records
    dataset_id = check_dataset_id(dataset_id)
    path = data_root(root) / dataset_id
    with _lock:
        if (path / _DATASET_FILE).is_file():
            found = open_dataset(path)
            if found.scenario != name or found.synthetic != synthetic \
                    or found.physical != physical:
                kind = ("synthetic" if found.synthetic else "people's") + (
                    " physical" if found.physical else "")
                raise ConfigError(f"dataset {dataset_id!r} holds {kind} {found.scenario} "
                                  "sessions; give another dataset id", field="dataset")
            return found
        (path / "sessions").mkdir(parents=True, exist_ok=True)
        meta = {"dataset_id": dataset_id,
                "schema": PHYSICAL_SCHEMA if physical else SCHEMA_VERSION, "scenario": name,
                "synthetic": bool(synthetic), "created_utc": _utc(),
                "description": description, "hri_envs_version": __version__}
        _write_json(path / _DATASET_FILE, meta)
    return Dataset(path, meta)


def list_datasets(root: str | os.PathLike[str] | None = None) -> list[Dataset]:
    """The datasets under the root, by id (folders that are not datasets are skipped)."""
    base = data_root(root)
    if not base.is_dir():
        return []
    out = []
    for p in sorted(base.iterdir()):
        if (p / _DATASET_FILE).is_file():
            with contextlib.suppress(ConfigError):
                out.append(open_dataset(p))
    return out


class SessionWriter:
    """Writes one participant's session: ``session.json`` and one file per episode.

    Each file is written under a temporary name and renamed into place
    (:mod:`hri_bench.core.atomic`), so a reader, or a crash, sees whole episodes only.

    Args:
        dataset: The dataset.
        participant: The anonymous participant id (:func:`new_participant_id`).
        meta: The session's settings (agent, design, ...) for ``session.json``.
    """

    def __init__(self, dataset: Dataset, participant: str, meta: Mapping[str, Any]) -> None:
        if not _PARTICIPANT_RE.match(participant):
            raise ConfigError(f"participant ids are 'p' and 12 hex digits or 's' and 4-9 "
                              f"digits, got {participant!r}", field="participant")
        self.dataset = dataset
        self.participant = participant
        self.path = dataset.path / "sessions" / participant
        if self.path.exists():
            raise ConfigError(f"session {participant} exists in {dataset.dataset_id}",
                              field="participant")
        self.path.mkdir(parents=True)
        fsync_dir(self.path.parent)
        self.meta: dict[str, Any] = {"participant": participant,
                                     "schema": dataset.meta["schema"],
                                     "dataset_id": dataset.dataset_id,
                                     "synthetic": dataset.synthetic, "status": "running",
                                     "started_utc": _utc(), "finished_utc": None, **meta}
        self.episodes = 0
        self._write_meta()

    def _write_meta(self) -> None:
        _write_json(self.path / _SESSION_FILE, self.meta)

    def update(self, **fields: Any) -> None:
        """Change fields of ``session.json`` (e.g. ``status``) and write it."""
        self.meta.update(fields)
        self._write_meta()

    def write_episode(self, columns: Mapping[str, Sequence[Any]]) -> Path:
        """Write the next episode's steps (a list per column of :data:`COLUMNS`)."""
        pa = _pa()
        import pyarrow.parquet as pq

        physical = self.dataset.physical
        names = [n for n, _, _ in (PHYSICAL_COLUMNS if physical else COLUMNS)]
        missing = [n for n in names if n not in columns]
        if missing:
            raise ConfigError(f"an episode needs every column; missing {', '.join(missing)}",
                              field="columns")
        meta = {"schema": self.dataset.meta["schema"], "dataset_id": self.dataset.dataset_id,
                "scenario": self.dataset.scenario}
        table = pa.table({n: columns[n] for n in names}, schema=schema(meta, physical=physical))
        target = self.path / _EPISODE_FILE.format(self.episodes + 1)
        with atomic_path(target, ".parquet") as tmp:
            pq.write_table(table, tmp)
        self.episodes += 1
        return target

    def finish(self, status: str = "complete") -> None:
        """Mark the session finished (``complete``, ``stopped``, ``abandoned`` or ``failed``)."""
        self.update(status=status, finished_utc=_utc(), episodes_recorded=self.episodes)


# ------------------------------------------------------------------- the robot's view
@dataclass(frozen=True)
class RobotEpisode:
    """One episode in the robot's Gymnasium view (``hri_envs/Hanger-v0``'s spaces).

    Attributes:
        observations: ``state``, ``start``, ``last_human_action`` (T+1,) int64 and
            ``action_mask`` (T+1, A) int8: the observation after reset, then after each step.
        actions: (T,) the robot's actions.
        rewards: (T,) its rewards.
        terminations, truncations: (T,) bool.
        infos: The env's step info keys, (T+1,) each (the reset's first).
        participant, episode: Where it comes from.
    """

    observations: dict[str, np.ndarray] | np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    terminations: np.ndarray
    truncations: np.ndarray
    infos: dict[str, np.ndarray]
    participant: str
    episode: int


def robot_episodes(dataset: Dataset) -> Iterator[RobotEpisode]:
    """The dataset's episodes in the robot's view, in :meth:`Dataset.steps`'s order (of a
    physical dataset: the continuous env's observation vectors and actions,
    :func:`~hri_bench.data.physical.robot_episode_arrays`).
    """
    graph = dataset.graph
    table = dataset.steps()
    if table.num_rows == 0:
        return
    if dataset.physical:
        for ep in robot_episode_arrays(table):
            yield RobotEpisode(**ep)
        return
    cols = {n: table.column(n).to_numpy(zero_copy_only=False)
            for n in ("participant", "episode", "start", "state", "next_state",
                      "robot_last_human_action", "robot_action", "human_action",
                      "robot_reward", "aborted", "terminated", "truncated", "intention")}
    key = np.array([f"{p}/{e}" for p, e in zip(cols["participant"], cols["episode"],
                                               strict=True)])
    cuts = np.flatnonzero(key[1:] != key[:-1]) + 1
    for rows in np.split(np.arange(table.num_rows), cuts):
        states = np.append(cols["state"][rows], cols["next_state"][rows[-1]]).astype(np.int64)
        last_h = np.append(cols["robot_last_human_action"][rows],
                           cols["human_action"][rows[-1]]).astype(np.int64)
        a_r = cols["robot_action"][rows].astype(np.int64)
        n = len(rows)
        reached = np.zeros(n + 1, dtype=bool)
        end = cols["terminated"][rows[-1]]
        reached[-1] = bool(end) and graph.support[states[-1]] == cols["intention"][rows[-1]]
        yield RobotEpisode(
            observations={"state": states,
                          "start": np.full(n + 1, cols["start"][rows[0]], dtype=np.int64),
                          "last_human_action": last_h,
                          "action_mask": graph.valid[states].astype(np.int8)},
            actions=a_r, rewards=cols["robot_reward"][rows].astype(np.float64),
            terminations=cols["terminated"][rows].astype(bool),
            truncations=cols["truncated"][rows].astype(bool),
            infos={"aborted": np.append(False, cols["aborted"][rows]).astype(bool),
                   "invalid_action": np.append(False, ~graph.valid[states[:-1], a_r]),
                   "reached_intention": reached},
            participant=str(cols["participant"][rows[0]]), episode=int(cols["episode"][rows[0]]))


def _check_spaces(env: Any, episodes: Sequence[RobotEpisode]) -> None:
    """Raise a :class:`ConfigError` naming the first step whose observation is outside the
    env's observation space, or whose action is outside its action space.
    """
    obs_space, act_space = env.observation_space, env.action_space
    for ep in episodes:
        where = f"participant {ep.participant} episode {ep.episode + 1}"
        for t in range(len(ep.actions) + 1):
            if not isinstance(ep.observations, dict):  # a physical episode's vectors
                if not obs_space.contains(ep.observations[t]):
                    raise ConfigError(f"{where}, observation {t} (0: after reset) is outside "
                                      f"the env's {obs_space}; not exported", field="dataset")
                if t < len(ep.actions) and not act_space.contains(ep.actions[t]):
                    raise ConfigError(f"{where}, step {t}: the robot's action is outside the "
                                      f"env's {act_space}; not exported", field="dataset")
                continue
            obs = {k: v[t] for k, v in ep.observations.items()}
            if not obs_space.contains(obs):
                bad = next((k for k, v in obs.items() if not obs_space[k].contains(v)), "")
                value = np.asarray(obs.get(bad)).tolist()
                raise ConfigError(f"{where}, observation {t} (0: after reset): {bad} "
                                  f"{value} is outside the env's "
                                  f"{obs_space[bad] if bad else obs_space}; not exported",
                                  field="dataset")
            if t < len(ep.actions) and not act_space.contains(ep.actions[t]):
                raise ConfigError(f"{where}, step {t}: the robot's action {ep.actions[t]} is "
                                  f"outside the env's {act_space}; not exported",
                                  field="dataset")


def export_minari(dataset: Dataset, out: str | os.PathLike[str] | None = None) -> Path:
    """Write the robot's view as a Minari dataset ``hri-envs/<dataset id>`` (data format
    ``arrow``) under the Minari root ``out`` (default ``<dataset>/minari``), replacing an
    earlier export there; returns that root. Load it with
    ``MINARI_DATASETS_PATH=<root>`` and ``minari.load_dataset("hri-envs/<id>")``.

    The dataset is built in a temporary folder beside the root and renamed into place.

    Raises:
        MissingExtraError: minari (or pyarrow) is not installed.
        ConfigError: The dataset has no episode yet, or an observation or action outside
            the env's spaces (naming the first such step; nothing is written).
    """
    try:
        import minari  # noqa: F401  (the extra, checked before anything is read)
        from minari.data_collector import EpisodeBuffer
    except ImportError as exc:
        raise MissingExtraError(["minari"], "the Minari view of a dataset") from exc
    root = Path(out) if out is not None else dataset.path / "minari"
    episodes = list(robot_episodes(dataset))
    if not episodes:
        raise ConfigError(f"dataset {dataset.dataset_id} has no recorded episode yet",
                          field="dataset")
    buffers = [EpisodeBuffer(id=i, observations=ep.observations, actions=ep.actions,
                             rewards=ep.rewards.tolist(), terminations=ep.terminations.tolist(),
                             truncations=ep.truncations.tolist(),
                             # lists: Minari 0.5.4 cannot read back 1-d arrays as infos
                             infos={k: v.tolist() for k, v in ep.infos.items()},
                             options={"participant": ep.participant, "episode": ep.episode})
               for i, ep in enumerate(episodes)]
    env = gym.make(_gym_id(dataset))
    try:
        _check_spaces(env, episodes)
        _write_minari(dataset, root, buffers, env)
    except OSError as exc:  # named by the folder asked for, not its temporary one
        exc.filename = str(root)
        raise
    finally:
        env.close()
    return root


def _gym_id(dataset: Dataset) -> str:
    """The env whose robot's view a dataset's Minari export is: the graph env, or the
    continuous env's v1 for a physical dataset.
    """
    spec = dataset.spec
    if not dataset.physical:
        return str(spec.gym_id)
    from hri_envs.registration import continuous_id  # noqa: PLC0415

    return continuous_id(str(spec.continuous_id), 1)


def _write_minari(dataset: Dataset, root: Path, buffers: list[Any], env: Any) -> None:
    """Build the Minari dataset beside ``root`` and rename it into place."""
    import minari

    content = dataset.content_hash()
    kind = "scripted humans (synthetic)" if dataset.synthetic else "people"
    root.parent.mkdir(parents=True, exist_ok=True)
    build = Path(tempfile.mkdtemp(dir=root.parent, prefix=f".{root.name}.build-"))
    try:
        with _lock, warnings.catch_warnings():
            # Minari warns of metadata a recording has no use for (author, permalink)
            warnings.simplefilter("ignore", UserWarning)
            before = os.environ.get("MINARI_DATASETS_PATH")
            # absolute: Minari joins a relative root to paths it already joined it to
            os.environ["MINARI_DATASETS_PATH"] = str(build.absolute())
            try:
                minari.create_dataset_from_buffers(
                    dataset.minari_id, buffers, env=env, algorithm_name="hri-bench",
                    description=(f"The robot's view of {dataset.dataset_id}: {kind} in the "
                                 f"human's seat of {_gym_id(dataset)}; content {content}; "
                                 "multi-agent steps in the dataset's Parquet files "
                                 f"({dataset.meta['schema']})."),
                    data_format="arrow")
            finally:
                if before is None:
                    del os.environ["MINARI_DATASETS_PATH"]
                else:
                    os.environ["MINARI_DATASETS_PATH"] = before
        old = None
        if root.exists():
            old = root.parent / f".{root.name}.old-{secrets.token_hex(4)}"
            os.replace(root, old)
        os.replace(build, root)
        fsync_dir(root.parent)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(build, ignore_errors=True)


def export_parquet(dataset: Dataset, path: str | os.PathLike[str]) -> Path:
    """Write every step as one Parquet file whose schema metadata holds ``dataset_id``,
    ``schema``, ``scenario``, ``synthetic``, ``content_hash`` and ``participants``.
    """
    _pa()
    import pyarrow.parquet as pq

    table = dataset.steps()
    meta = {"dataset_id": dataset.dataset_id, "schema": dataset.meta["schema"],
            "scenario": dataset.scenario, "synthetic": json.dumps(dataset.synthetic),
            "content_hash": dataset.content_hash(),
            "participants": json.dumps(dataset.participants()),
            "hri_envs_version": str(dataset.meta.get("hri_envs_version", ""))}
    table = table.replace_schema_metadata(meta)
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path, ".parquet") as tmp:
            pq.write_table(table, tmp)
    except OSError as exc:  # named by the file asked for, not its temporary name
        exc.filename = str(path)
        raise
    return path
