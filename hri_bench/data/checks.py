"""Checks of recorded episode files against the schema and the scenario's task graph.

Every reader of a dataset (``hri-bench dataset show/export/fit``, ``replay``, the
``recorded:`` populations) reads its episode files through :func:`read_episode`, which
refuses a file with a :class:`~hri_envs.errors.ConfigError` (``field="dataset"``) that
names the file, the step and what is wrong:

* not a readable Parquet file (truncated, corrupt, empty, a folder, unreadable), or one of
  more than :data:`MAX_EPISODE_ROWS` rows, :data:`MAX_EPISODE_VALUES` values or
  :data:`MAX_EPISODE_BYTES` of data;
* a column missing, of another kind than the schema's (a string for an integer, say),
  with values its schema type cannot hold, or with nulls where the schema has none;
* no step, or steps that are not one episode of the session whose folder holds the file
  (its participant, the dataset's ``synthetic`` flag, one episode and session index,
  steps 0, 1, ...);
* an index outside the scenario's graph (supports, intentions, states, actions), or steps
  the graph cannot have produced: the first state not the start support's, a state not
  the previous step's next state, a next state or an ``aborted`` flag that is not the
  graph's for the recorded state and actions, an action mask that is not the state's, the
  robot's ``last_human_action`` not the human's previous action, an episode end before
  the last step or none at it;
* a reward or time that is not finite, a robot reward outside [-1, 0] (every reward
  rule's range) or a human reward other than -1, 0 and +1 (the goal reward's), a belief
  that is not a probability per intention, a layout of an odd number of coordinates.

Whether the recorded rewards and episode ends are the env's is ``hri-bench replay``'s
check (:mod:`hri_bench.data.replay`). This module imports nothing from the package but
:mod:`hri_envs`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph

__all__ = ["MAX_EPISODE_BYTES", "MAX_EPISODE_ROWS", "MAX_EPISODE_VALUES", "check_ends",
           "check_numbers", "check_session", "check_steps", "list_column", "read_episode",
           "refusal"]

#: The most rows (steps) an episode file may hold (``--max-steps`` allows 10,000).
MAX_EPISODE_ROWS = 100_000
#: The most values (list entries counted) and bytes an episode file's data may hold once
#: decompressed (a step has about 45 values in a few hundred bytes), so that a small file
#: cannot fill the memory.
MAX_EPISODE_VALUES = 4_000_000
MAX_EPISODE_BYTES = 64 * 2**20


def refusal(path: Path, what: str) -> ConfigError:
    """The error that refuses dataset file ``path`` because of ``what``."""
    return ConfigError(f"{path}: {what}", field="dataset")


def _kind(pa: Any, t: Any) -> str:
    """The kind of an Arrow type a schema column of that kind accepts."""
    types = pa.types
    if types.is_list(t) or types.is_large_list(t):
        return f"list<{_kind(pa, t.value_type)}>"
    for kind, test in (("integer", types.is_integer), ("float", types.is_floating),
                       ("bool", types.is_boolean), ("string", types.is_string),
                       ("string", types.is_large_string), ("null", types.is_null)):
        if test(t):
            return kind
    return str(t)


def _accepts(target: str, given: str) -> bool:
    """Whether a column of kind ``given`` may be cast to one of kind ``target`` (integers
    may be read as floats; a column of nulls is judged by its nulls).
    """
    if target.startswith("list<"):
        return given.startswith("list<") and _accepts(target[5:-1], given[5:-1])
    return given in (target, "null") or (target == "float" and given == "integer")


def read_episode(path: Path, target: Any) -> Any:
    """The episode file ``path`` as an Arrow table of the ``target`` schema's columns and
    types, or a :class:`ConfigError` naming the file (module docstring; the values are
    :func:`check_steps`'s).
    """
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    if not path.is_file():
        raise refusal(path, "is not a file (an episode is one Parquet file)")

    def unreadable(exc: Exception) -> ConfigError:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        return refusal(path, f"is not a readable Parquet file ({reason})")

    errors = (pa.ArrowException, OSError, ValueError, IndexError)
    try:
        meta = pq.read_metadata(path)
        chunks = [meta.row_group(i).column(j) for i in range(meta.num_row_groups)
                  for j in range(meta.num_columns)]
        values = sum(c.num_values for c in chunks)
        size = sum(c.total_uncompressed_size for c in chunks)
    except errors as exc:
        raise unreadable(exc) from None
    if meta.num_rows > MAX_EPISODE_ROWS:
        raise refusal(path, f"holds {meta.num_rows} rows; an episode file holds at most "
                            f"{MAX_EPISODE_ROWS} steps")
    if values > MAX_EPISODE_VALUES or size > MAX_EPISODE_BYTES:
        raise refusal(path, f"holds {values} values in {size / 2**20:.1f} MiB; an episode "
                            f"file holds at most {MAX_EPISODE_VALUES} values in "
                            f"{MAX_EPISODE_BYTES // 2**20} MiB")
    try:
        table = pq.read_table(path)
    except errors as exc:
        raise unreadable(exc) from None
    missing = [f.name for f in target if f.name not in table.schema.names]
    if missing:
        raise refusal(path, f"has no column {', '.join(missing)} (the schema's columns are "
                            "in docs/people.md, 'Datasets')")
    columns = []
    for field in target:
        col = table.column(field.name)
        want, got = _kind(pa, field.type), _kind(pa, col.type)
        if not _accepts(want, got):
            raise refusal(path, f"column {field.name} is {col.type}; the schema's is "
                                f"{field.type}")
        if col.null_count and not field.nullable:
            raise refusal(path, f"column {field.name} has {col.null_count} null value(s)")
        try:
            col = col.cast(field.type)
        except (pa.ArrowException, ValueError) as exc:
            raise refusal(path, f"column {field.name}: values its type {field.type} cannot "
                                f"hold ({' '.join(str(exc).split())})") from None
        if pa.types.is_list(field.type):
            values = pc.list_flatten(col)
            if values.null_count:
                raise refusal(path, f"column {field.name} has null values in its lists")
        columns.append(col)
    return pa.Table.from_arrays(columns, schema=target)


def list_column(col: Any) -> tuple[np.ndarray, np.ndarray]:
    """(lengths (N,), flat values) of a list column; null lists have length -1."""
    import pyarrow.compute as pc

    lengths = pc.list_value_length(col).to_numpy(zero_copy_only=False)
    lengths = np.where(np.isnan(lengths.astype(float)), -1, lengths).astype(np.int64)
    return lengths, pc.list_flatten(col).to_numpy(zero_copy_only=False)


def check_steps(table: Any, path: Path, graph: TaskGraph, *, participant: str,
                synthetic: bool) -> None:
    """Raise a :class:`ConfigError` naming ``path`` and the step unless the table (one
    episode file, read by :func:`read_episode`) is one episode of ``participant``'s session
    that ``graph`` can have produced (module docstring).
    """
    n = table.num_rows
    if n == 0:
        raise refusal(path, "holds no step (an episode file has one row per step)")
    col = {name: table.column(name).to_numpy(zero_copy_only=False)
           for name in table.schema.names if name not in ("action_mask", "belief", "layout")}

    def first(bad: np.ndarray, what: Callable[[int], str]) -> None:
        if bad.any():
            t = int(np.flatnonzero(bad)[0])
            raise refusal(path, f"step {t}: {what(t)}")

    check_session(col, path, participant, synthetic)
    limits = (("start", graph.n_intentions, "supports"),
              ("assigned_intention", graph.n_intentions, "intentions"),
              ("intention", graph.n_intentions, "intentions"),
              ("state", graph.n_states, "states"), ("next_state", graph.n_states, "states"),
              ("robot_action", graph.n_actions, "actions"),
              ("human_action", graph.n_actions, "actions"),
              ("robot_last_human_action", graph.n_actions, "actions"),
              ("human_last_human_action", graph.n_actions, "actions"))
    for name, limit, what in limits:
        x = col[name].astype(np.int64)
        if ((x < 0) | (x >= limit)).any():
            t = int(np.flatnonzero((x < 0) | (x >= limit))[0])
            raise refusal(path, f"step {t}: {name} {x[t]} is outside [0, {limit}) (the "
                                f"{graph.name}'s {what})")
    for name in ("start", "assigned_intention"):
        x = col[name]
        if (x != x[0]).any():
            t = int(np.flatnonzero(x != x[0])[0])
            raise refusal(path, f"step {t}: {name} {x[t]} differs from step 0's {x[0]} (one "
                                f"episode has one {name})")
    s, s1 = col["state"].astype(np.int64), col["next_state"].astype(np.int64)
    a_r, a_h = col["robot_action"].astype(np.int64), col["human_action"].astype(np.int64)
    home = int(graph.support_state(int(col["start"][0]), 0))
    if s[0] != home:
        raise refusal(path, f"step 0: state {s[0]} is not the start support's state {home}")
    moved = graph.next_state[s, a_r, a_h]
    first(s1 != moved, lambda t: f"next_state {s1[t]}: the {graph.name} goes from state "
          f"{s[t]} with actions (robot {a_r[t]}, human {a_h[t]}) to {moved[t]}")
    first(np.append(False, s[1:] != s1[:-1]), lambda t:
          f"state {s[t]} is not step {t - 1}'s next state {s1[t - 1]}")
    aborted = graph.aborted[s, a_r, a_h].astype(bool)
    first(col["aborted"] != aborted, lambda t: f"aborted is {bool(col['aborted'][t])}; the "
          f"{graph.name} says {bool(aborted[t])} for state {s[t]} and actions "
          f"(robot {a_r[t]}, human {a_h[t]})")
    last_h = np.append(0, a_h[:-1])
    first(col["robot_last_human_action"] != last_h, lambda t: "robot_last_human_action "
          f"{col['robot_last_human_action'][t]} is not the human's previous action "
          f"{last_h[t]}")
    check_ends(col, path, n)
    _check_lists(table, path, graph, s)
    check_numbers(col, ("robot_reward", "human_reward", "t_shown", "t_action", "response_s"),
                   path)
    r_r, r_h = col["robot_reward"].astype(float), col["human_reward"].astype(float)
    first((r_r < -1.0) | (r_r > 0.0), lambda t: f"robot_reward is {r_r[t]}; every reward "
          "rule's rewards are in [-1, 0]")
    first(~np.isin(r_h, (-1.0, 0.0, 1.0)), lambda t: f"human_reward is {r_h[t]}; the goal "
          "reward is -1, 0 or +1")
    ms = col["client_response_ms"].astype(float)  # nulls are NaN
    first(np.isinf(ms) | (ms < 0), lambda t: f"client_response_ms is {ms[t]}")


def check_ends(col: dict[str, np.ndarray], path: Path, n: int) -> None:
    """The episode of ``n`` steps ends (terminated or truncated, not both) at its last step
    and only there (also the physical episodes', :mod:`hri_bench.data.physical`).
    """
    ends = col["terminated"].astype(bool) | col["truncated"].astype(bool)
    early = ends & (np.arange(n) < n - 1)
    if early.any():
        raise refusal(path, f"step {int(np.flatnonzero(early)[0])}: the episode ends "
                            "(terminated or truncated) before its last step")
    if col["terminated"][-1] == col["truncated"][-1]:
        raise refusal(path, f"step {n - 1}: the last step must be terminated or truncated, "
                            f"not {'both' if col['terminated'][-1] else 'neither'}")


def check_numbers(col: dict[str, np.ndarray], names: tuple[str, ...], path: Path) -> None:
    """The columns ``names`` hold a number (not NaN, not infinite) at every step."""
    for name in names:
        x = col[name].astype(float)
        if not np.isfinite(x).all():
            t = int(np.flatnonzero(~np.isfinite(x))[0])
            raise refusal(path, f"step {t}: {name} is {x[t]}, not a number")


def check_session(col: dict[str, np.ndarray], path: Path, participant: str,
                   synthetic: bool) -> None:
    """One episode of ``participant``'s session, steps 0, 1, ..."""
    who = col["participant"]
    if (who != participant).any():
        other = who[np.flatnonzero(who != participant)[0]]
        raise refusal(path, f"holds steps of participant {other!r}, in the folder of "
                            f"{participant!r} (a copied file?)")
    if (col["synthetic"] != synthetic).any():
        raise refusal(path, f"has rows with synthetic {not synthetic} in a "
                            f"{'synthetic' if synthetic else 'people'} dataset")
    for name in ("session_index", "episode"):
        if (col[name] != col[name][0]).any():
            raise refusal(path, f"holds more than one {name} "
                                f"({sorted(set(col[name].tolist()))[:5]})")
    if col["episode"][0] < 0 or col["session_index"][0] < 0:
        raise refusal(path, f"episode {col['episode'][0]} and session_index "
                            f"{col['session_index'][0]} must be >= 0")
    steps = col["step"]
    if (steps != np.arange(len(steps))).any():
        t = int(np.flatnonzero(steps != np.arange(len(steps)))[0])
        raise refusal(path, f"row {t} is step {steps[t]}; the rows are steps 0, 1, 2, ...")


def _check_lists(table: Any, path: Path, graph: TaskGraph, states: np.ndarray) -> None:
    """The action masks, beliefs and layout."""
    n_a, n_i = graph.n_actions, graph.n_intentions
    lengths, masks = list_column(table.column("action_mask"))
    if (lengths != n_a).any():
        t = int(np.flatnonzero(lengths != n_a)[0])
        raise refusal(path, f"step {t}: action_mask has {lengths[t]} entries, not {n_a}")
    wrong = (masks.reshape(-1, n_a) != graph.valid[states]).any(1)
    if wrong.any():
        t = int(np.flatnonzero(wrong)[0])
        raise refusal(path, f"step {t}: action_mask is not state {states[t]}'s valid actions "
                            f"{graph.valid[states[t]].astype(int).tolist()}")
    lengths, beliefs = list_column(table.column("belief"))
    if ((lengths != n_i) & (lengths != -1)).any():
        t = int(np.flatnonzero((lengths != n_i) & (lengths != -1))[0])
        raise refusal(path, f"step {t}: belief has {lengths[t]} entries, not {n_i} (one per "
                            "intention) or null")
    bad = ~np.isfinite(beliefs) | (beliefs < 0) | (beliefs > 1)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        t = int(np.repeat(np.arange(len(lengths)), np.maximum(lengths, 0))[k])
        raise refusal(path, f"step {t}: belief holds {beliefs[k]}, not a probability")
    lengths, layout = list_column(table.column("layout"))
    if (lengths % 2).any() or (lengths != lengths[0]).any() or not np.isfinite(layout).all():
        raise refusal(path, "layout must be one list of finite (x, y) pairs for the episode")
    if lengths[0] and (layout.reshape(len(lengths), -1) != layout[:lengths[0]]).any():
        raise refusal(path, "layout differs between steps (one episode has one layout)")
