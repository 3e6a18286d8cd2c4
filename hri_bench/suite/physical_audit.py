"""Checking a physical results file: what ``hri-bench validate`` and ``leaderboard`` do with it.

* :func:`validate_physical`: the format, the suite version and its hash (the tracks and the
  content of their populations), each run's human (the draw the suite seed fixes), every
  agent's per-episode figures present in the tracks' shapes, the references built in, and
  every statistic recomputed from the runs alone (:func:`hri_bench.suite.physical_results.
  compute`) equal to the file's. A file whose runs were edited and whose statistics were
  recomputed with the project's own functions passes this: only a replay catches it.
* :func:`replay_physical`: re-simulates ``k`` runs per track, drawn by a seed the verifier
  picks, of **every** agent of the file, the references included (a forged reference moves
  every normalised score), and compares each episode's figures with the file's. An agent
  that cannot be replayed here (a robot of your own whose module is not on the path, or
  whose code differs from the file's identity) is named; the caller then fails: a replay
  vouches for every agent of the file or for none.
* :func:`merge_physical`: valid files of one suite (version, hash, seeds, runs scale,
  tracks) merged into one document whose statistics are recomputed; files whose references'
  runs differ, or that hold the same agent with other runs, are refused together (which one
  is honest is for ``validate --replay`` to say).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Mapping
from dataclasses import asdict
from typing import Any, NamedTuple

import numpy as np

from hri_bench.run.physical import FIGURES, PhysicalUnit, simulate_unit
from hri_bench.suite import physical_results as pr
from hri_bench.suite.physical_running import is_custom, make_robot, physical_suite_hash
from hri_bench.suite.physical_tracks import (
    FLOOR,
    PHYSICAL_TRACKS,
    REFERENCE,
    PhysicalTrack,
    track_runs,
)
from hri_bench.suite.submission import compare_recomputed

__all__ = ["PhysicalMerge", "Replay", "is_physical", "merge_physical", "replay_physical",
           "validate_physical"]


def is_physical(doc: Any) -> bool:
    """Whether ``doc`` is a physical results document (by its ``format``)."""
    return isinstance(doc, dict) and doc.get("format") == pr.FORMAT


def _tracks(doc: Mapping[str, Any]) -> list[PhysicalTrack]:
    defined = PHYSICAL_TRACKS[doc["suite_version"]]
    return [defined[name] for name in doc["tracks"]]


def _structure(doc: Mapping[str, Any]) -> list[str]:
    """The file's settings against its suite version's: tracks, hash, references."""
    if doc.get("schema_version") != pr.SCHEMA_VERSION:
        return [f"schema_version {doc.get('schema_version')!r}: this hri-bench reads "
                f"{pr.SCHEMA_VERSION!r}"]
    version = doc.get("suite_version")
    if version not in PHYSICAL_TRACKS:
        return [f"unknown physical suite version {version!r}; known: "
                f"{', '.join(PHYSICAL_TRACKS)}"]
    problems = []
    tracks = doc.get("tracks")
    if not isinstance(tracks, dict) or not tracks:
        return ["no tracks"]
    for name, entry in tracks.items():
        defined = PHYSICAL_TRACKS[version].get(name)
        if defined is None:
            problems.append(f"track {name!r} is not a track of physical suite v{version}")
            continue
        recorded = {k: entry.get(k) for k in asdict(defined)} if isinstance(entry, dict) else {}
        if recorded != asdict(defined):
            problems.append(f"track {name!r}: its settings differ from suite v{version}'s")
        if entry.get("runs") != track_runs(defined, doc.get("runs_scale", 1.0)):
            problems.append(f"track {name!r}: {entry.get('runs')!r} runs where runs scale "
                            f"{doc.get('runs_scale')!r} gives "
                            f"{track_runs(defined, doc.get('runs_scale', 1.0))}")
    if problems:
        return problems
    if doc.get("suite_hash") != physical_suite_hash(version, _tracks(doc)):
        problems.append("suite_hash differs from the suite's (its tracks or their humans "
                        "were changed)")
    agents = doc.get("agents")
    if not isinstance(agents, dict):
        return [*problems, "no agents"]
    from baselines.physical import PHYSICAL_AGENTS  # noqa: PLC0415

    for name in (REFERENCE, FLOOR):
        entry = agents.get(name)
        if not isinstance(entry, dict) or (entry.get("identity") or {}).get("kind") != "builtin":
            problems.append(f"the reference {name!r} is missing or not the built-in one")
    for name, entry in agents.items():
        builtin = PHYSICAL_AGENTS.get(name) if not is_custom(name) else None
        if not is_custom(name) and builtin is None:
            problems.append(f"agent {name!r} is neither a built-in robot nor module:Class")
        elif builtin is not None and bool(entry.get("privileged")) != builtin.privileged:
            problems.append(f"agent {name!r}: privileged {entry.get('privileged')!r}, the "
                            f"built-in one's is {builtin.privileged}")
        elif builtin is None and entry.get("privileged"):
            problems.append(f"agent {name!r} is marked privileged: a robot of your own never "
                            "reads the simulation")
    return problems


def _runs(doc: Mapping[str, Any]) -> list[str]:
    """Each run's human is the suite seed's draw; every agent has every figure in shape."""
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    problems = []
    seeds = [str(s) for s in doc.get("seeds", [])]
    if sorted(doc["runs"]) != sorted(seeds) or not seeds:
        return [f"runs are recorded for seeds {sorted(doc['runs'])}, the file names {seeds}"]
    for seed, by_track in doc["runs"].items():
        if sorted(by_track) != sorted(doc["tracks"]):
            problems.append(f"seed {seed}: runs for tracks {sorted(by_track)}, the file names "
                            f"{sorted(doc['tracks'])}")
            continue
        for t in _tracks(doc):
            block = by_track[t.name]
            n = track_runs(t, doc["runs_scale"])
            pop = physical_population(t.population, t.graph)
            if block.get("humans") != [pop.member_index(int(seed), r) for r in range(n)]:
                problems.append(f"seed {seed}, track {t.name}: the runs' humans are not the "
                                "suite seed's draws")
            if sorted(block.get("agents", {})) != sorted(doc["agents"]):
                problems.append(f"seed {seed}, track {t.name}: runs of agents "
                                f"{sorted(block.get('agents', {}))}, the file names "
                                f"{sorted(doc['agents'])}")
                continue
            for agent, entry in block["agents"].items():
                for fig in FIGURES:
                    rows = entry.get(fig)
                    if (not isinstance(rows, list) or len(rows) != n
                            or any(not isinstance(r, list) or len(r) != t.episodes
                                   or any(e is not None and not isinstance(e, int | float)
                                          for e in r) for r in rows)):
                        problems.append(f"seed {seed}, track {t.name}, agent {agent!r}: "
                                        f"{fig!r} is not {n} runs x {t.episodes} episodes "
                                        "of numbers")
    return problems


def validate_physical(doc: Any) -> list[str]:
    """What is wrong with a physical results document; an empty list when it is valid
    (module docstring: what is checked, in order; a stage's problems stop the later ones).
    """
    if not is_physical(doc):
        return [f"not a physical results file (format {pr.FORMAT!r})"]
    try:
        problems = _structure(doc) or _runs(doc)
        if problems:
            return problems
        statistics, aggregate = pr.compute(doc)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        return [f"malformed: {type(exc).__name__}: {exc}"]
    for key, value in (("statistics", statistics), ("aggregate", aggregate)):
        compare_recomputed(key, doc.get(key), json.loads(json.dumps(value)), problems)
    return problems


class Replay(NamedTuple):
    """What :func:`replay_physical` found."""

    #: Every run replayed, ``agent seed/track/run`` (as :func:`hri_bench.suite.audit.replay`).
    checked: list[str]
    #: One line per replayed run whose figures differ from the file's.
    differ: list[str]
    #: Agents that could not be replayed here, and why.
    skipped: dict[str, str]


def _replayable(name: str, entry: Mapping[str, Any]) -> str | None:
    """Why agent ``name`` cannot be replayed here (None: it can)."""
    identity = entry.get("identity") or {}
    if identity.get("kind") == "builtin":
        from hri_bench.run.agents import package_version  # noqa: PLC0415

        here = package_version("hri-envs")
        return None if identity.get("version") == here else (
            f"recorded with hri-envs {identity.get('version')}, this is {here}")
    from hri_bench.run.agents import source_identity  # noqa: PLC0415
    from hri_envs.errors import ConfigError  # noqa: PLC0415

    try:
        found = source_identity(str(identity.get("module", name.split(":")[0])))
    except ConfigError as exc:
        return str(exc)
    if found["code_sha256"] != identity.get("code_sha256"):
        return "its code here differs from the file's (code_sha256)"
    return None


def replay_physical(doc: Mapping[str, Any], k: int, seed: int,
                    progress: Callable[[int, int], None] | None = None) -> Replay:
    """Re-simulate ``k`` runs per seed and track (drawn from ``seed``) of every agent.

    Args:
        doc: A valid physical results document (:func:`validate_physical`).
        k: Runs per track (at most the track's).
        seed: The verifier's seed of which runs are replayed.
        progress: Called with (done, total) units.
    """
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    skipped = {a: why for a, e in doc["agents"].items() if (why := _replayable(a, e))}
    plan = []
    for s, by_track in doc["runs"].items():
        for t in _tracks(doc):
            n = track_runs(t, doc["runs_scale"])
            runs = sorted(rng.choice(n, size=min(k, n), replace=False).tolist())
            humans = by_track[t.name]["humans"]
            for agent in doc["agents"]:
                if agent not in skipped:
                    plan.append((s, t, agent, runs, [humans[r] for r in runs]))
    checked: list[str] = []
    differ: list[str] = []
    for i, (s, t, agent, runs, members) in enumerate(plan):
        if progress:
            progress(i, len(plan))
        unit = PhysicalUnit(t.name, t.scenario, agent, t.population, tuple(members),
                            tuple(runs), t.episodes, int(s))
        pop = physical_population(t.population, t.graph)
        got = pr.round_runs(simulate_unit(unit, make_robot, pop.members))
        stored = doc["runs"][s][t.name]["agents"][agent]
        for j, r in enumerate(runs):
            checked.append(f"{agent} {s}/{t.name}/{r}")
            bad = [f for f in FIGURES if got[f][j] != stored[f][r]]
            if bad:
                differ.append(f"seed {s}, track {t.name}, agent {agent!r}, run {r}: "
                              f"{', '.join(bad)} differ (file {stored[bad[0]][r]}, replay "
                              f"{got[bad[0]][j]})")
    if progress:
        progress(len(plan), len(plan))
    return Replay(checked, differ, skipped)


class PhysicalMerge(NamedTuple):
    """What :func:`merge_physical` made."""

    #: The merged document (None: nothing could be merged).
    doc: dict[str, Any] | None
    #: The files merged, by name.
    merged: list[str]
    #: One line per file refused.
    refused: list[str]


def _digest(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()


def _suite_key(doc: Mapping[str, Any]) -> tuple[Any, ...]:
    return (doc["suite_version"], doc["suite_hash"], tuple(doc["seeds"]), doc["runs_scale"],
            tuple(doc["tracks"]))


def merge_physical(docs: Mapping[str, Mapping[str, Any]]) -> PhysicalMerge:
    """Merge valid physical results documents (by file name) of the first one's suite.

    A file of another suite, seeds, runs scale or tracks is refused. The references' runs
    must be the same in every file, and an agent in two files must have the same runs: files
    that disagree are refused together (module docstring). The merged document holds every
    agent of the files kept, with statistics recomputed over them all.
    """
    refused: list[str] = []
    if not docs:
        return PhysicalMerge(None, [], [])
    first = next(iter(docs.values()))
    same = {}
    for name, doc in docs.items():
        if _suite_key(doc) != _suite_key(first):
            refused.append(f"{name}: refused: another physical suite, seeds, runs scale or "
                           f"tracks than {next(iter(docs))}'s")
        else:
            same[name] = doc
    # Per agent, the digest of its runs in each file: any disagreement refuses those files.
    seen: dict[str, dict[str, list[str]]] = {}
    for name, doc in same.items():
        for agent in doc["agents"]:
            runs = {s: {t: b["agents"][agent] for t, b in by.items()}
                    for s, by in doc["runs"].items()}
            seen.setdefault(agent, {}).setdefault(_digest(runs), []).append(name)
    bad: dict[str, str] = {}
    for agent, by_digest in seen.items():
        if len(by_digest) > 1:
            files = sorted(f for names in by_digest.values() for f in names)
            for f in files:
                bad.setdefault(f, f"{f}: refused: agent {agent!r}'s runs differ between "
                                  f"{', '.join(files)} (run hri-bench validate --replay on "
                                  "each)")
    refused += [bad[f] for f in same if f in bad]
    kept = {f: d for f, d in same.items() if f not in bad}
    if not kept:
        return PhysicalMerge(None, [], refused)
    base = next(iter(kept.values()))
    merged: dict[str, Any] = {k: v for k, v in base.items()
                              if k not in ("agents", "runs", "statistics", "aggregate")}
    merged["agents"], merged["runs"] = {}, {}
    for doc in kept.values():
        for agent, entry in doc["agents"].items():
            merged["agents"].setdefault(agent, entry)
        for s, by in doc["runs"].items():
            for t, block in by.items():
                into = merged["runs"].setdefault(s, {}).setdefault(
                    t, {"humans": block["humans"], "agents": {}})
                for agent, entry in block["agents"].items():
                    into["agents"].setdefault(agent, entry)
    merged["merged_from"] = list(kept)
    merged["statistics"], merged["aggregate"] = pr.compute(merged)
    return PhysicalMerge(merged, list(kept), refused)

