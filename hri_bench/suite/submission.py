"""Results files others can submit: build one from a suite, validate one, merge many.

A results file (``results.json``, written by ``hri-bench suite``; format in
docs/results.md and the JSON schema :data:`SCHEMA_PATH`) holds the suite's version and
content hash, what made the numbers (agents' code identity, package versions, env ids,
population hashes), every run's results per track and seed, and the statistics computed
from them. :func:`validate` checks a file against the schema and the installed suite and
recomputes every statistic from the per-run data; :func:`merge` pools validated files into
one leaderboard.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import stat
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.core.atomic import atomic_writer
from hri_bench.report import aggregate as agg
from hri_bench.run import metrics, provenance
from hri_bench.run.agents import agent_name_problem, agent_settings
from hri_bench.run.runner import TASK_METRICS
from hri_bench.run.study import regret_reference
from hri_bench.suite import results_v3
from hri_bench.suite.evidence import agent_roles, blind_errors, role_errors
from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.tracks import SUITE_VERSIONS, TRACKS_BY_VERSION, track_config
from hri_envs.envs.backends import BACKENDS
from hri_envs.errors import ConfigError

__all__ = ["FORMAT", "MAX_DEPTH", "SCHEMA_PATH", "SCHEMA_VERSION", "build",
           "compare_recomputed", "compute", "lead_section", "load", "merge", "profile_figure",
           "profile_span", "read_json", "track_runs", "validate"]

FORMAT = "hri-bench-results"
#: Version of the results file's layout (the schema); a change gets a new one.
SCHEMA_VERSION = "1"
#: The JSON schema of a results file.
SCHEMA_PATH = Path(__file__).with_name("results.schema.json")
#: Per-run values are written rounded to this many decimals; the statistics are computed
#: from the rounded values, so a reader recomputes them exactly.
DECIMALS = 6
#: Relative tolerance of the validator's comparison (the statistics are recomputed with the
#: same code and seeds, so only platform rounding may differ).
RTOL = 1e-9
#: The largest results file read (a full suite with a few agents has ~10 MB).
MAX_BYTES = 512 * 2**20


def _round(x: np.ndarray) -> list[Any]:
    return np.round(np.asarray(x, dtype=float), DECIMALS).tolist()


def track_runs(result: Any, blind: np.ndarray | None,
               humans: Sequence[int] | None = None) -> dict[str, Any]:
    """The per-run block of one track of one seed, from a :class:`StudyResult`.

    ``reward`` and ``truncated`` per (run, episode); the task metrics
    (:data:`~hri_bench.run.runner.TASK_METRICS`) as each run's mean over its episodes (the
    belief ones only for agents exposing a belief); ``blind`` per (run, episode) or None;
    with ``humans`` (suite v3) each run's human (:func:`hri_bench.suite.results_v3.run_humans`).
    """
    agents = {name: round_runs(m) for name, m in result.metrics.items()}
    block: dict[str, Any] = {"blind": None if blind is None else _round(blind)}
    if humans is not None:
        block["humans"] = [int(h) for h in humans]
    block["agents"] = agents
    return block


def round_runs(m: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """One agent's per-run records as a results file holds them: ``reward`` rounded to
    :data:`DECIMALS`, ``truncated`` as 0/1, the task metrics as each run's mean over its
    episodes, rounded (left out where all NaN: an agent without a belief).
    """
    entry: dict[str, Any] = {"reward": _round(m["reward"]),
                             "truncated": np.asarray(m["truncated"], dtype=int).tolist()}
    for k in TASK_METRICS:
        x = np.asarray(m.get(k, np.full(m["reward"].shape, np.nan)), dtype=float)
        if not np.all(np.isnan(x)):
            entry[k] = _round(x.mean(1))
    return entry


def _arrays(entry: Mapping[str, Any]) -> dict[str, np.ndarray]:
    return {k: np.asarray(v, dtype=float) for k, v in entry.items()}


def compute(doc: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(statistics, aggregate)`` of a results document, from its ``runs`` alone.

    ``statistics[seed][track][agent]`` is :func:`hri_bench.run.metrics.agent_metrics` with the
    bootstrap seeded by the suite seed; ``aggregate`` is :func:`hri_bench.report.aggregate.
    aggregate` of the run scores over every seed, seeded by the first seed. A suite v3
    document (``schema_version`` "2") has its own: :func:`hri_bench.suite.results_v3.compute`.
    """
    if doc.get("schema_version") in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4):
        return results_v3.compute(doc)
    threshold = float(doc["threshold"])
    tracks = doc.get("tracks", {})
    statistics: dict[str, Any] = {}
    scores: dict[str, dict[str, dict[str, np.ndarray]]] = {}
    for seed, by_track in doc["runs"].items():
        statistics[seed], scores[seed] = {}, {}
        for track, block in by_track.items():
            blind = None if block["blind"] is None else np.asarray(block["blind"], dtype=float)
            statistics[seed][track] = {}
            scores[seed][track] = {}
            drift = tracks.get(track, {}).get("settings", {}).get("human_drift")
            for agent, entry in block["agents"].items():
                arrays = _arrays(entry)
                statistics[seed][track][agent] = metrics.agent_metrics(arrays, blind, int(seed),
                                                                       threshold, drift)
                scores[seed][track][agent] = arrays["reward"].mean(1)
    agents = list(doc["agents"])
    seed0 = int(next(iter(doc["runs"]), 0))
    return statistics, agg.aggregate(scores, agents, seed0)


def build(*, suite_version: str, suite_hash: str, track_hashes: Mapping[str, str],
          seeds: Sequence[int], runs_scale: float, agents: Sequence[str],
          tracks: Mapping[str, Any], runs: Mapping[str, Mapping[str, Any]],
          threshold: float = metrics.LEARNED) -> dict[str, Any]:
    """A complete results document (per-run data, provenance, statistics, aggregate).

    Args:
        suite_version: The suite's version.
        suite_hash: :func:`hri_bench.run.provenance.suite_hash` of its tracks.
        track_hashes: :func:`~hri_bench.run.provenance.track_hash` of each track run.
        seeds: The suite seeds, in order.
        runs_scale: The suite's ``--runs-scale``.
        agents: Every agent of the results (ranked ones and references), in order.
        tracks: Per track: ``scenario``, ``runs``, ``episodes``, ``settings``, ``env_ids``,
            ``population``, ``agent_configs``, ``regret``.
        runs: ``runs[seed][track]`` from :func:`track_runs`.
        threshold: :data:`hri_bench.run.metrics.LEARNED`.
    """
    doc: dict[str, Any] = {
        "format": FORMAT, "schema_version": schema_version(suite_version),
        "suite": {"version": suite_version, "hash": suite_hash, "tracks": dict(track_hashes)},
        "submission": {"name": None, "lab": None, "contact": None, "url": None,
                       "notes": None},
        "seeds": [int(s) for s in seeds], "runs_scale": runs_scale, "threshold": threshold,
        "software": provenance.software(),
        "agents": {a: provenance.agent_identity(a) for a in agents},
        "tracks": dict(tracks),
        "runs": {str(s): dict(runs[str(s)]) for s in seeds},
    }
    if doc["schema_version"] == results_v3.SCHEMA_V4:
        doc["roles"] = agent_roles(agents)
    doc["statistics"], doc["aggregate"] = compute(doc)
    return doc


def schema_version(suite_version: str) -> str:
    """The results file's layout for a suite version: "1" (v1, v2), "2" (v3: the humans
    each run met, :mod:`hri_bench.suite.results_v3`).
    """
    if suite_version in ("1", "2"):
        return SCHEMA_VERSION
    return results_v3.SCHEMA_VERSION if suite_version == "3" else results_v3.SCHEMA_V4


#: The deepest nesting of JSON arrays and objects read (a results file nests 7 deep, a
#: summary.json 6): deeper documents are refused before any recursive check meets them.
MAX_DEPTH = 64


class _DuplicateKey(ValueError):
    pass


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    doc = dict(pairs)
    if len(doc) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise _DuplicateKey(f"the key {key!r} appears twice in one JSON object")
            seen.add(key)
    return doc


def _depth_exceeds(doc: Any, limit: int) -> bool:
    """Whether ``doc`` nests arrays and objects more than ``limit`` deep (no recursion)."""
    if not isinstance(doc, dict | list):
        return False
    stack = [(doc, 1)]
    while stack:
        node, depth = stack.pop()
        items = node.values() if isinstance(node, dict) else node
        for child in items:
            if isinstance(child, dict | list):
                if depth + 1 > limit:
                    return True
                stack.append((child, depth + 1))
    return False


def read_json(path: str | Path, *, max_bytes: int | None = None, what: str = "results file",
              constants: bool = False) -> Any:
    """The JSON document of a regular file (``.gz``: gzip-compressed), refused early
    (a :class:`ConfigError`, ``field="file"``, whose message names ``path`` and says why)
    when it is not a regular file (a FIFO, ``/dev/zero``, a folder: nothing is read), is
    larger than ``max_bytes`` (compressed, or decompressed: the gzip stream is decompressed
    only up to that size), nests deeper than :data:`MAX_DEPTH`, repeats a key within an
    object, or (unless ``constants``) holds NaN or Infinity. ``max_bytes`` defaults to
    :data:`MAX_BYTES`.
    """
    path = Path(path)
    max_bytes = MAX_BYTES if max_bytes is None else max_bytes
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO without a writer: no wait
    except OSError as exc:
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})",
                          field="file") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ConfigError(f"{path}: not a regular file (a FIFO, device or folder); give "
                              f"a {what}", field="file")
        with os.fdopen(fd, "rb", closefd=False) as f:
            raw = f.read(max_bytes + 1)
    except OSError as exc:
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})",
                          field="file") from None
    finally:
        os.close(fd)
    if len(raw) > max_bytes:
        raise ConfigError(f"{path}: larger than {max_bytes // 2**20} MiB", field="file")
    text: bytes | bytearray = _gunzip(path, raw, max_bytes) if path.suffix == ".gz" else raw
    deep = ConfigError(f"{path}: its JSON nests deeper than {MAX_DEPTH} levels; not a {what}",
                       field="file")
    try:
        doc = json.loads(text, object_pairs_hook=_no_duplicates,
                         parse_constant=None if constants else _refuse_constant)
    except RecursionError:
        raise deep from None
    except _DuplicateKey as exc:
        raise ConfigError(f"{path}: {exc}; not a {what}", field="file") from None
    except (json.JSONDecodeError, UnicodeDecodeError, ValueError) as exc:
        raise ConfigError(f"{path}: not JSON ({exc}); not a {what}", field="file") from None
    if _depth_exceeds(doc, MAX_DEPTH):
        raise deep
    return doc


def _gunzip(path: Path, raw: bytes, max_bytes: int) -> bytearray:
    """Decompress gzip ``raw`` (every member), a MiB at a time, to at most ``max_bytes``: a
    stream that would give more is refused as soon as that much is out, so a small bomb costs
    no more memory than the largest file allowed.
    """
    out = bytearray()
    d = zlib.decompressobj(16 + zlib.MAX_WBITS)
    pending = raw
    try:
        while pending:
            out += d.decompress(pending, 2**20)
            if len(out) > max_bytes:
                raise ConfigError(f"{path}: decompresses to more than "
                                  f"{max_bytes // 2**20} MiB", field="file")
            pending = d.unconsumed_tail
            if d.eof:  # another gzip member may follow
                pending = d.unused_data.lstrip(b"\0")
                d = zlib.decompressobj(16 + zlib.MAX_WBITS)
            elif not pending:
                raise ConfigError(f"{path}: cannot be read (a truncated gzip stream)",
                                  field="file")
    except zlib.error as exc:
        raise ConfigError(f"{path}: cannot be read (not gzip: {exc})", field="file") from None
    return out


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def load(path: str | Path) -> Any:
    """A results file's JSON (``.json`` or gzip-compressed ``.json.gz``), read with
    :func:`read_json`.

    Raises:
        ConfigError: It is not a regular file, cannot be read, is larger than
            :data:`MAX_BYTES` (compressed or not), nests too deep, repeats a key or is not
            JSON.
    """
    return read_json(path)


def _schema_errors(doc: Any) -> list[str]:
    import jsonschema  # the bench extra, only when validating

    schema = json.loads(SCHEMA_PATH.read_text())
    validator = jsonschema.Draft202012Validator(schema)
    out = []
    for err in sorted(validator.iter_errors(doc), key=lambda e: list(map(str, e.path))):
        where = "/".join(str(p) for p in err.absolute_path) or "(top level)"
        out.append(f"schema: at {where}: {err.message[:300]}")
    return out


def _name_errors(doc: Mapping[str, Any]) -> list[str]:
    """Agent names no leaderboard can show as given (:func:`~hri_bench.run.agents.
    agent_name_problem`: ``|``, line breaks, HTML), in ``agents`` and every run's block.
    """
    named = [("agents", name) for name in doc["agents"]]
    named += [(f"runs.{seed}.{track}.agents", name) for seed, tracks in doc["runs"].items()
              for track, block in tracks.items() for name in block["agents"]]
    errors = []
    for where, name in named:
        problem = agent_name_problem(name)
        if problem is not None:
            errors.append(f"{where}: {problem}")
    return errors


def _suite_errors(doc: Mapping[str, Any]) -> list[str]:
    """The suite's version and hashes, each track's runs and episodes, every array's shape."""
    errors = []
    suite = doc["suite"]
    version = suite["version"]
    if version not in SUITE_VERSIONS:
        errors.append(f"suite.version is {version!r}; this hri-bench knows suite versions "
                      f"{', '.join(SUITE_VERSIONS)}: validate with the hri-envs release that "
                      "ran it")
        return errors
    TRACKS = TRACKS_BY_VERSION[version]  # noqa: N806
    expected = provenance.suite_hash(version, list(TRACKS.values()))
    if suite["hash"] != expected:
        errors.append(f"suite.hash is {suite['hash'][:16]}…, suite v{version}'s is "
                      f"{expected[:16]}…: the tracks differ from the published suite")
    for name, h in suite["tracks"].items():
        if name not in TRACKS:
            errors.append(f"suite.tracks: {name!r} is not a track of suite v{version}")
        elif h != provenance.track_hash(TRACKS[name]):
            errors.append(f"suite.tracks.{name}: hash {h[:16]}… is not the track's "
                          f"({provenance.track_hash(TRACKS[name])[:16]}…)")
    if errors:
        return errors
    scale = doc["runs_scale"]
    for name in suite["tracks"]:
        if name not in doc["tracks"]:
            errors.append(f"tracks: {name!r} is missing")
            continue
        cfg = track_config(TRACKS[name], ("passive",), runs_scale=scale, version=version)
        tr = doc["tracks"][name]
        if (tr["runs"], tr["episodes"]) != (cfg.runs, cfg.n_episodes):
            errors.append(f"tracks.{name}: {tr['runs']} runs × {tr['episodes']} episodes; "
                          f"the track has {cfg.runs} × {cfg.n_episodes} at runs scale {scale}")
        expected = json.loads(json.dumps(cfg.settings()))  # as JSON reads it back
        for key, value in expected.items():
            if key not in ("seed", "agents") and tr["settings"].get(key) != value:
                errors.append(f"tracks.{name}.settings.{key} is {tr['settings'].get(key)!r}; "
                              f"the track's is {value!r}")
        v3 = doc["schema_version"] in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4)
        if v3 and tr.get("members") != json.loads(json.dumps(results_v3.members(cfg))):
            errors.append(f"tracks.{name}.members: not the humans of the track's population")
        if v3 and tr.get("headline") != getattr(TRACKS[name], "headline", False):
            errors.append(f"tracks.{name}.headline is {tr.get('headline')!r}; the track's is "
                          f"{getattr(TRACKS[name], 'headline', False)!r}")
        for seed in doc["runs"]:
            block = doc["runs"][seed].get(name)
            if block is None:
                errors.append(f"runs.{seed}: track {name!r} is missing")
                continue
            errors += _shape_errors(f"runs.{seed}.{name}", block, cfg.runs, cfg.n_episodes,
                                    cfg.max_steps)
            if v3 and block.get("humans") != results_v3.run_humans(
                    dataclasses.replace(cfg, seed=int(seed))):
                errors.append(f"runs.{seed}.{name}.humans: not the humans the suite's runs "
                              f"meet at seed {seed}")
            elif not v3 and "humans" in block:
                errors.append(f"runs.{seed}.{name}.humans: only suite v3 records them")
    for seed in doc["runs"]:
        for name in doc["runs"][seed]:
            if name not in suite["tracks"]:
                errors.append(f"runs.{seed}: track {name!r} is not in suite.tracks")
    if sorted(doc["runs"]) != sorted(str(s) for s in doc["seeds"]):
        errors.append(f"runs has seeds {sorted(doc['runs'])}, seeds lists {doc['seeds']}")
    return errors


def _shape_errors(where: str, block: Mapping[str, Any], runs: int, episodes: int,
                  max_steps: int = 100) -> list[str]:
    errors = []
    per_episode = [("blind", block["blind"])] if block["blind"] is not None else []
    for agent, entry in block["agents"].items():
        per_episode += [(f"agents.{agent}.reward", entry["reward"]),
                        (f"agents.{agent}.truncated", entry["truncated"])]
        for k in TASK_METRICS:
            if k in entry and len(entry[k]) != runs:
                errors.append(f"{where}.agents.{agent}.{k}: {len(entry[k])} runs, the track "
                              f"has {runs}")
    for key, rows in per_episode:
        if key.endswith(".reward") or key == "blind":
            flat = [v for r in rows for v in r]
            if flat and not all(-max_steps <= v <= 0 for v in flat):
                bad = min(flat) if min(flat) < -max_steps else max(flat)
                errors.append(f"{where}.{key}: an episode reward of {bad!r}; an episode "
                              f"earns between -{max_steps} (every step -1) and 0")
        if len(rows) != runs:
            errors.append(f"{where}.{key}: {len(rows)} runs, the track has {runs} (missing "
                          "runs)" if len(rows) < runs else f"{where}.{key}: {len(rows)} runs, "
                          f"the track has {runs}")
        elif any(len(r) != episodes for r in rows):
            bad = next(i for i, r in enumerate(rows) if len(r) != episodes)
            errors.append(f"{where}.{key}: run {bad} has {len(rows[bad])} episodes, the track "
                          f"has {episodes}")
    return errors


def compare_recomputed(path: str, recorded: Any, recomputed: Any, out: list[str]) -> None:
    """Append one line per value of ``recorded`` (a results file's statistics) that differs
    from ``recomputed`` (the same computed from its runs), at most 50.
    """
    if len(out) >= 50:
        return
    if isinstance(recomputed, Mapping):
        if not isinstance(recorded, Mapping):
            out.append(f"{path}: recorded {_short(recorded)}, recomputed an object")
            return
        for k in sorted(set(recomputed) | set(recorded)):
            if k not in recorded:
                out.append(f"{path}.{k}: missing (recomputed {_short(recomputed[k])})")
            elif k not in recomputed:
                out.append(f"{path}.{k}: recorded {_short(recorded[k])}, not a statistic "
                           "of the per-run data")
            else:
                compare_recomputed(f"{path}.{k}", recorded[k], recomputed[k], out)
    elif isinstance(recomputed, list):
        if not isinstance(recorded, list) or len(recorded) != len(recomputed):
            out.append(f"{path}: recorded {_short(recorded)}, recomputed {_short(recomputed)}")
            return
        for i, (a, b) in enumerate(zip(recorded, recomputed, strict=True)):
            compare_recomputed(f"{path}[{i}]", a, b, out)
    elif isinstance(recomputed, float) and isinstance(recorded, int | float) and not \
            isinstance(recorded, bool):
        if not math.isclose(float(recorded), recomputed, rel_tol=RTOL, abs_tol=1e-12):
            out.append(f"{path}: recorded {recorded!r}, recomputed from the runs "
                       f"{recomputed!r}")
    elif recorded != recomputed:
        out.append(f"{path}: recorded {_short(recorded)}, recomputed {_short(recomputed)}")


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def validate(doc: Any) -> list[str]:
    """What is wrong with a results document; an empty list when it is valid.

    Checks, in order (a stage's errors stop the later stages): the JSON schema; the suite
    version, its content hash and each track's; each track's runs × episodes at the file's
    runs scale and every per-run array's shape (missing runs); then every statistic and
    the aggregate recomputed from the per-run data.
    """
    errors = _schema_errors(doc)
    if errors:
        return errors
    errors = _name_errors(doc)
    if errors:
        return errors
    errors = _suite_errors(doc)
    if doc["schema_version"] == results_v3.SCHEMA_V4:
        errors += role_errors(doc)
    if errors:
        return errors
    errors = blind_errors(doc)
    if errors:
        return errors
    statistics, aggregate = compute(doc)
    mismatches: list[str] = []
    compare_recomputed("statistics", doc["statistics"], statistics, mismatches)
    compare_recomputed("aggregate", doc["aggregate"], aggregate, mismatches)
    return mismatches


# --------------------------------------------------------------------------- leaderboards
#: Agents that see the intention (privileged): marked in the leaderboard's lead.
SEES = {"oracle": " (sees ι)", "informed": " (ref., sees ι)"}


def lead_section(doc: Mapping[str, Any]) -> str:
    """The leaderboard's lead: cross-track IQM [95 % stratified bootstrap CI], the seed
    spread, and the probability of improvement of every pair of agents.
    """
    aggregate = doc["aggregate"]
    block = aggregate["agents"]
    order = sorted(block, key=lambda a: (-block[a]["iqm"], a))
    seeds = ", ".join(str(s) for s in doc["seeds"])
    lines = ["## Across tracks", "",
             f"Score: {aggregate['score']}. IQM and mean over every run of every track the "
             "agent ran on, with 95 % stratified bootstrap CIs (each track's runs resampled "
             f"on their own); suite seeds {seeds}, seed spread = the IQM of each seed alone "
             "(standard deviation, min–max). Sorted by IQM.", "",
             "| agent | IQM [95 % CI] | mean [95 % CI] | seed sd (min–max) | tracks | runs |",
             "|---|---|---|---|---|---|"]
    for a in order:
        e = block[a]
        lines.append(f"| {code(a)}{SEES.get(a, '')} | {with_ci(e, 'iqm')} | {with_ci(e)} | "
                     f"{number(e['seed_std'])} ({number(e['seed_min'])}–{number(e['seed_max'])}) | "
                     f"{len(e['tracks'])} | {e['runs']} |")
    partial = aggregate.get("partial") or {}
    if partial:
        lines += ["", "Not aggregated (no runs on every track; see the tracks' tables): "
                  + "; ".join(f"{code(a)} ({len(t)} track(s))"
                              for a, t in partial.items()) + "."]
    poi = aggregate["probability_of_improvement"]
    lines += ["", "Probability of improvement: row agent's run scores higher than column "
              "agent's on the same track (ties one half), averaged over tracks and seeds.", "",
              "| P(row > column) | " + " | ".join(code(a) for a in order)
              + " |", "|---|" + "---|" * len(order)]
    for a in order:
        cells = ["·" if a == b else number(poi[a][b], 2) for b in order]
        lines.append(f"| {code(a)} | " + " | ".join(cells) + " |")
    return "\n".join([*lines, ""])


def task_section(doc: Mapping[str, Any]) -> str:
    """Per track (first seed): learning speed, asymptote, identification, calibration,
    effort, each mean [95 % CI].
    """
    seed = next(iter(doc["statistics"]))
    lines = ["## The task's metrics", "",
             f"Seed {seed}. Learned at: the first episode from which a run's regret stays "
             f"≤ {doc['threshold']} (episodes + 1: never); re-adapted after: the same "
             "counted from the drifting human's switch; asymptote: mean regret (reward "
             "where regret is n/a, marked r) of the last quarter of the episodes; MAP steps: "
             "decisions until the belief's most likely intention is right for good; "
             "log-loss and Brier of the belief (agents exposing one); counteract / idle / "
             "alone: the human's motions against a robot motion, waits with nothing moving, "
             "actions while the robot waited, per episode. Means [95 % CI] over runs.", ""]
    if doc.get("schema_version") in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4):
        lines[2:2] = ["Suite v3: regret is measured against each track's reachable reference "
                      "(blind's exact values on the anchor, else qmdp's mean reward on the same "
                      "human in the same episode), so learning speed and asymptote are defined "
                      "on every track.", ""]
    for track, by_agent in doc["statistics"][seed].items():
        if "normalisation" in by_agent:  # suite v3: regret against the reachable reference
            by_agent = by_agent["agents"]
        lines += [f"### The task's metrics on {escape(track)}", "",
                  "| agent | learned at | re-adapted after | asymptote | MAP steps | log-loss | "
                  "Brier | counteract | idle | alone |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for agent, s in by_agent.items():
            def cell(key: str, s: Mapping[str, Any] = s) -> str:
                return "–" if s.get(key) is None else with_ci(s[key])
            asym = cell("asymptote_regret") if s["asymptote_regret"] is not None else \
                "r " + cell("asymptote_reward")
            lines.append(f"| {code(agent)} | {cell('learning_episodes')} | "
                         f"{cell('readapt_episodes')} | {asym} | "
                         f"{cell('map_steps')} | {cell('log_loss')} | {cell('brier')} | "
                         f"{cell('counteract')} | {cell('human_idle')} | "
                         f"{cell('human_alone')} |")
        lines.append("")
    return "\n".join(lines)


def profile_figure(doc: Mapping[str, Any], path: Path) -> Path:
    """The performance profiles (fraction of runs scoring above τ) as a figure.

    The grid spans every run score, and a few runs far below the rest (an episode cut off
    at the step limit costs up to −100) would squeeze every curve against the right edge:
    the x axis spans the scores most runs have, from the lowest τ at which some agent's
    fraction drops below 95 % to the highest at which some agent's is still above 5 %
    (:func:`profile_span`), and its label says how far the scores reach beyond.
    """
    from hri_bench.core import plots  # matplotlib: the bench extra

    prof = doc["aggregate"]["profiles"]
    fig, ax = plots.new_figure(figsize=(6.0, 3.6))
    for agent, ys in prof["fraction_above"].items():
        color, dashes = plots.agent_style(agent)  # one colour and line per agent everywhere
        ax.plot(prof["tau"], ys, label=plots.LABELS.get(agent, agent), color=color,
                linestyle=dashes, linewidth=1.5)
    label = "τ: run score (mean episode reward)"
    ax.set_ylabel("fraction of runs scoring > τ")
    ax.set_ylim(-0.02, 1.02)
    span = profile_span(prof)
    if span is not None:
        ax.set_xlim(*span)
        lo, hi = prof["tau"][0], prof["tau"][-1]
        if lo < span[0] or hi > span[1]:
            label += (f"\nshown where the fractions lie in {PROFILE_TAIL:.0%}–"
                      f"{1 - PROFILE_TAIL:.0%}; the runs' scores reach {lo:.3g} … {hi:.3g}")
    ax.set_xlabel(label)
    if prof["fraction_above"]:  # every agent may be partial (a failure on a track)
        ax.legend(fontsize=7, loc="lower left")
    ax.set_title("Performance profiles across tracks")
    return plots.save_figure(fig, path)


#: The share of every agent's runs :func:`profile_figure` may leave off either end.
PROFILE_TAIL = 0.05


def profile_span(prof: Mapping[str, Any], low: float = PROFILE_TAIL
                 ) -> tuple[float, float] | None:
    """The τ range of a profiles block where the curves change: from one grid step below the
    first τ at which some agent's fraction is below ``1 - low`` to one step above the last
    at which some agent's is above ``low``; None without agents or grid.
    """
    tau = np.asarray(prof["tau"], dtype=float)
    if tau.size < 2 or not prof["fraction_above"]:
        return None
    fractions = np.asarray(list(prof["fraction_above"].values()), dtype=float)  # (agents, τ)
    falling = np.flatnonzero((fractions < 1 - low).any(0))
    rising = np.flatnonzero((fractions > low).any(0))
    first = max(int(falling[0]) - 1, 0) if falling.size else 0
    last = min(int(rising[-1]) + 1, tau.size - 1) if rising.size else tau.size - 1
    if last <= first:
        first, last = 0, tau.size - 1
    return float(tau[first]), float(tau[last])


def merge(docs: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """Pool validated results files (by name) into one document's runs and aggregate.

    Built-in agents with the same code identity are one agent (their runs of different
    seeds pooled; the same seed's runs are taken once); other agents are named
    ``agent@file`` when two files name different code alike. Returns the merged document
    (``runs``, ``seeds``, ``agents``, ``statistics``, ``aggregate``, ``threshold``).
    """
    runs: dict[str, dict[str, Any]] = {}
    agents: dict[str, Any] = {}
    renamed: dict[tuple[str, str], str] = {}
    for fname, doc in docs.items():
        rename: dict[str, str] = {}
        for agent, ident in doc["agents"].items():
            key = agent
            if key in agents and agents[key] != ident:
                key = f"{agent}@{fname}"
            agents.setdefault(key, ident)
            rename[agent] = renamed[(fname, agent)] = key
        for seed, by_track in doc["runs"].items():
            for track, block in by_track.items():
                head = {k: v for k, v in block.items() if k != "agents"}  # blind, humans
                slot = runs.setdefault(seed, {}).setdefault(track, {**head, "agents": {}})
                for agent, entry in block["agents"].items():
                    slot["agents"].setdefault(rename[agent], entry)
    first = next(iter(docs.values()))
    tracks = {t: spec for d in docs.values() for t, spec in d["tracks"].items()}
    merged: dict[str, Any] = {"schema_version": first["schema_version"],
                              "seeds": sorted(int(s) for s in runs), "runs": runs,
                              "tracks": tracks,
                              "agents": agents, "threshold": first["threshold"]}
    if "roles" in first:
        merged["roles"] = {renamed[(f, a)]: role for f, d in docs.items()
                           for a, role in d.get("roles", {}).items()}
    merged["statistics"], merged["aggregate"] = compute(merged)
    return merged


class SuiteRecorder:
    """Collects a suite's per-run data track by track and writes its results file.

    :func:`hri_bench.suite.running.run_suite` calls :meth:`add` after each track's study, then
    :meth:`document` and :func:`write_results`; tracks outside the versioned suite (a
    population's own) are left out of the results file (they cannot be validated against
    the suite).
    """

    def __init__(self, seed: int, runs_scale: float, version: str) -> None:
        self.seed, self.runs_scale, self.version = seed, runs_scale, version
        self.tracks: dict[str, Any] = {}
        self.runs: dict[str, Any] = {}
        self.hashes: dict[str, str] = {}
        self.agents: list[str] = []

    def add(self, track: Any, result: Any) -> None:
        """Record one track's :class:`~hri_bench.core.results.StudyResult`."""
        if TRACKS_BY_VERSION[self.version].get(track.name) != track:
            return
        cfg = result.config
        spec = cfg.spec
        env_ids = {"gymnasium": spec.panda_id if BACKENDS[cfg.backend].physical
                   else spec.gym_id,
                   "pettingzoo": spec.pettingzoo_module}
        blind, note = regret_reference(result)
        v3 = self.version not in ("1", "2")
        self.hashes[track.name] = provenance.track_hash(track)
        self.runs[track.name] = track_runs(result, blind,
                                           results_v3.run_humans(cfg) if v3 else None)
        self.tracks[track.name] = {
            "scenario": cfg.scenario, "runs": cfg.runs, "episodes": cfg.n_episodes,
            "settings": {k: v for k, v in cfg.settings().items() if k != "seed"},  # in seeds
            "env_ids": env_ids,
            "population": cfg.population_info(), "regret": note,
            "agent_configs": {a: agent_settings(a, cfg.spec, cfg.waiting_reward,
                                                dict(cfg.learner)) for a in cfg.agents}}
        if v3:
            self.tracks[track.name].update(headline=track.headline,
                                           members=results_v3.members(cfg))
        self.agents += [a for a in result.metrics if a not in self.agents]

    def document(self) -> dict[str, Any] | None:
        """The results document (None when no track of the suite was run)."""
        if not self.runs:
            return None
        tracks = list(TRACKS_BY_VERSION[self.version].values())
        return build(suite_version=self.version,
                     suite_hash=provenance.suite_hash(self.version, tracks),
                     track_hashes=self.hashes, seeds=[self.seed], runs_scale=self.runs_scale,
                     agents=self.agents, tracks=self.tracks,
                     runs={str(self.seed): self.runs})


def write_results(out: Path, doc: Mapping[str, Any]) -> list[Path]:
    """``results.json`` (compact: one line) and ``profiles.png`` (suite v3:
    ``ranking.png``) in ``out``.
    """
    path = Path(out) / "results.json"
    with atomic_writer(path) as f:
        f.write(json.dumps(doc, separators=(",", ":"), allow_nan=False) + "\n")
    if doc.get("schema_version") in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4):
        return [path, results_v3.ranking_figure(doc, Path(out) / "ranking.png")]
    return [path, profile_figure(doc, Path(out) / "profiles.png")]


def combine(docs: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """One results document from the documents of the same suite run with several seeds."""
    first = docs[0]
    for d in docs[1:]:
        for key in ("suite", "runs_scale", "threshold", "agents", "tracks"):
            if d[key] != first[key]:
                raise ConfigError(f"results of different {key} cannot be combined",
                                  field="seeds")
    runs = {s: by_track for d in docs for s, by_track in d["runs"].items()}
    return build(suite_version=first["suite"]["version"], suite_hash=first["suite"]["hash"],
                 track_hashes=first["suite"]["tracks"],
                 seeds=[s for d in docs for s in d["seeds"]], runs_scale=first["runs_scale"],
                 agents=list(first["agents"]), tracks=first["tracks"], runs=runs,
                 threshold=first["threshold"])
