"""What a validated results file cannot prove by itself, checked: replayed runs and merges.

:func:`hri_bench.suite.submission.validate` recomputes every statistic from a file's runs, so it
catches a statistic edited by hand, but not runs that were never simulated: a file whose
rewards were raised and whose statistics were recomputed with the project's own code is
consistent. Two checks close that gap (docs/results.md, "What each check proves"):

* :func:`replay` (``hri-bench validate FILE --replay K``) re-simulates ``K`` randomly
  chosen runs of every agent whose code is installed here (a built-in agent of the same
  hri-envs version, a ``module:Class`` whose source files hash as recorded, a model file
  with the recorded sha256) and requires the same records, value for value;
* :func:`conflicts` (``hri-bench leaderboard``) refuses two files that hold different runs
  under the same suite hash, agent code identity and seed (one of them is not what that
  code gives), or different ``blind`` values or humans for the same suite, seed and track
  (a reference or a human list that is not the suite's; ``hri-bench validate`` recomputes
  ``blind``'s exact values and each run's human, so a file that forged them is refused on
  its own).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from hri_bench.run.study import simulate_runs
from hri_bench.suite.evidence import identity_key, replayable
from hri_bench.suite.submission import round_runs
from hri_bench.suite.tracks import TRACKS_BY_VERSION, track_config
from hri_envs.errors import ConfigError

__all__ = ["Conflict", "conflicts", "replay", "replayable"]

#: At most this many differing runs are named per conflict or replay.
SHOWN = 5


class Conflict(NamedTuple):
    """Two files that disagree on a run of the same (suite hash, agent code identity, seed,
    track, agent), and a line saying where.
    """

    files: tuple[str, str]
    text: str


def conflicts(docs: Mapping[str, Mapping[str, Any]]) -> list[Conflict]:
    """One :class:`Conflict` per disagreement of two files on a run of the same (suite hash,
    agent code identity, seed, track), naming the runs; an empty list when every shared run
    agrees.
    """
    seen: dict[tuple[str, str, str, str, str], tuple[str, Mapping[str, Any]]] = {}
    heads: dict[tuple[str, str, str], tuple[str, Mapping[str, Any]]] = {}
    out = []
    for fname, doc in docs.items():
        suite = doc["suite"]["hash"]
        for seed, by_track in doc["runs"].items():
            for track, block in by_track.items():
                head = {k: v for k, v in block.items() if k != "agents"}  # blind, humans
                other_head = heads.setdefault((suite, seed, track), (fname, head))
                if other_head[1] != head:
                    what = " and ".join(k for k in sorted(set(head) | set(other_head[1]))
                                        if head.get(k) != other_head[1].get(k))
                    out.append(Conflict((fname, other_head[0]), f"{fname} and {other_head[0]} "
                                        f"disagree on the {what} of seed {seed}, track "
                                        f"{track} (the same suite: the references and the "
                                        "humans met are the suite's, one file's are not)"))
                for agent, entry in block["agents"].items():
                    key = (suite, identity_key(doc["agents"].get(agent)), seed, track, agent)
                    if key not in seen:
                        seen[key] = (fname, entry)
                        continue
                    other, first = seen[key]
                    runs = differing_runs(first, entry)
                    if runs:
                        shown = ", ".join(map(str, runs[:SHOWN])) + (
                            f" (and {len(runs) - SHOWN} more)" if len(runs) > SHOWN else "")
                        out.append(Conflict((fname, other), f"{fname} and {other} disagree "
                                            f"on agent {agent!r} (same code identity) at "
                                            f"seed {seed}, track {track}: run(s) {shown}"))
    return out


def differing_runs(a: Mapping[str, Any], b: Mapping[str, Any]) -> list[int]:
    """The runs whose records differ between two per-run blocks of one agent (a key one
    block has and the other lacks: every run).
    """
    n = max(len(a.get("reward", [])), len(b.get("reward", [])))
    if set(a) != set(b):
        return list(range(n))
    bad: set[int] = set()
    for key in a:
        x, y = a[key], b[key]
        if len(x) != len(y):
            return list(range(n))
        bad |= {r for r, (u, v) in enumerate(zip(x, y, strict=True)) if u != v}
    return sorted(bad)


def replay(doc: Mapping[str, Any], k: int, seed: int,
           progress: bool = False) -> tuple[list[str], list[str], dict[str, str]]:
    """Re-simulate ``k`` runs of every replayable agent of a validated results document.

    Args:
        doc: A results document that :func:`hri_bench.suite.submission.validate` accepts.
        k: Runs per agent (drawn uniformly without replacement from every (seed, track,
            run) the agent has; all of them when it has fewer).
        seed: Seeds the draw.
        progress: Show a progress bar over the runs.

    Returns:
        ``(checked, problems, skipped)``: the runs replayed (``agent seed/track/run``), one
        line per run whose replay differs (naming the first differing record), and per
        agent that could not be replayed the reason.
    """
    if not (isinstance(k, int) and k >= 1):
        raise ConfigError(f"k must be a whole number >= 1 of runs to replay, got {k!r}",
                          field="replay")
    version = doc["suite"]["version"]
    tracks = TRACKS_BY_VERSION[version]
    rng = np.random.default_rng([int(seed), 0x5E])
    checked: list[str] = []
    problems: list[str] = []
    skipped: dict[str, str] = {}
    jobs = []
    for agent, identity in doc["agents"].items():
        why = replayable(agent, identity)
        if why is not None:
            skipped[agent] = why
            continue
        where = [(s, t, r) for s, by_track in doc["runs"].items()
                 for t, block in by_track.items() if agent in block["agents"]
                 for r in range(len(block["agents"][agent]["reward"]))]
        for i in rng.permutation(len(where))[:k]:
            jobs.append((agent, *where[int(i)]))
    bar: Any = jobs
    if progress:
        from tqdm.auto import tqdm  # the bench extra, only for the progress bar

        bar = tqdm(jobs, desc="replay", unit="run")
    for agent, s, t, r in bar:
        cfg = track_config(tracks[t], (agent,), runs_scale=float(doc["runs_scale"]),
                           seed=int(s), version=version)
        cfg = dataclasses.replace(cfg, agents=(agent,))
        fresh = round_runs(simulate_runs(cfg, agent, [r]))
        recorded = doc["runs"][s][t]["agents"][agent]
        checked.append(f"{agent} {s}/{t}/{r}")
        for key, values in fresh.items():
            if key not in recorded or recorded[key][r] != values[0]:
                problems.append(f"runs.{s}.{t}.agents.{agent}.{key}[{r}]: recorded "
                                f"{recorded.get(key, [None] * (r + 1))[r]!r}, replayed "
                                f"{values[0]!r}: these runs are not what the recorded code "
                                "gives")
                break
    return checked, problems, skipped
