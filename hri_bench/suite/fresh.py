"""``hri-bench validate FILE --fresh``: the verifier draws the seed and the humans.

A results file's runs are what its agents did at the suite's seed (public: 0 by default)
with the test split's frozen members (public too). An agent could be written for them: read
the schedule of the public seed to tell its runs apart, or carry a table of the frozen
humans. :func:`fresh_check` re-runs the file's agents on a seed the verifier draws
(``secrets``, from the operating system; printed only after the run) and on **fresh
humans**: for each population track, as many new members drawn from the same families'
parameter ranges (the split's components, a new generator seed; never the frozen members),
and compares each agent's headline with the submitted one (docs/results.md, "What each
check can and cannot prove").

The submitted and the fresh headline are two estimates of one agent's score on the
population; their difference has the interval ``d ± z·√(s² + f²)``, with ``s`` and ``f``
the two intervals' half-widths over 1.96 and ``z`` the normal quantile of
``1 - 0.05 / (2 · agents)`` (Bonferroni: an honest file fails with probability at most 5 %
however many agents it holds). An agent whose interval excludes 0 fails the check.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from statistics import NormalDist
from typing import Any

from hri_bench.run.study import run_study
from hri_bench.suite import results_v3
from hri_bench.suite.evidence import replayable
from hri_bench.suite.submission import SuiteRecorder
from hri_bench.suite.tracks import TRACKS_BY_VERSION, track_config
from hri_envs.errors import ConfigError
from hri_envs.humans.families import FAMILIES
from hri_envs.humans.splits import MIXTURES, MixtureSpec
from hri_envs.task.graph import TaskGraph

__all__ = ["FreshResult", "fresh_check", "fresh_population"]

#: The family-wise level of the check.
ALPHA = 0.05


def fresh_population(name: str, graph: TaskGraph, seed: int) -> str:
    """A population of new members from ``name``'s families and parameter ranges (its
    group's components, the same count, generator seed ``seed``) on ``graph``'s scenario,
    registered in this process under a new name, which is returned.
    """
    key = graph.name  # the mixtures are keyed by the scenario's name
    spec = MIXTURES[(name, key)]
    comps = tuple(c for c in spec.components
                  if spec.group is None or FAMILIES[c.family].group == spec.group)
    fresh = f"fresh-{seed}-{name}"
    MIXTURES[(fresh, key)] = MixtureSpec(
        fresh, key, spec.version, f"fresh humans of {name}'s families", spec.size,
        int(seed), comps, held_out=True)
    return fresh


@dataclasses.dataclass(frozen=True)
class FreshResult:
    """What :func:`fresh_check` found.

    Attributes:
        seed: The seed it drew (the study seed and the humans' generator).
        lines: Per agent: submitted and fresh headline, the difference with its interval.
        failed: The agents whose interval excludes 0.
        skipped: Agents that could not be re-run here, with the reason.
    """

    seed: int
    lines: list[str]
    failed: list[str]
    skipped: dict[str, str]


def _fresh_document(doc: Mapping[str, Any], seed: int, jobs: int) -> dict[str, Any]:
    version = doc["suite"]["version"]
    tracks = TRACKS_BY_VERSION[version]
    agents = [a for a in doc["agents"]]
    recorder = SuiteRecorder(seed, float(doc["runs_scale"]), version)
    for name in doc["suite"]["tracks"]:
        track = tracks[name]
        cfg = track_config(track, agents, runs_scale=float(doc["runs_scale"]), seed=seed,
                           version=version, jobs=jobs,
                           executor="process" if jobs > 1 else "serial")
        cfg = dataclasses.replace(cfg, agents=tuple(a for a in cfg.agents if a in agents))
        if cfg.population is not None:
            cfg = dataclasses.replace(cfg, population=fresh_population(
                cfg.population, cfg.graph, seed))
        recorder.add(track, run_study(cfg))
    fresh = recorder.document()
    assert fresh is not None
    return fresh


def _half(entry: Mapping[str, Any]) -> float:
    lo, hi = entry["ci95"]
    return max(hi - lo, 0.0) / (2 * 1.959964)


def fresh_check(doc: Mapping[str, Any], seed: int, jobs: int = 1) -> FreshResult:
    """Re-run ``doc``'s agents at ``seed`` on fresh humans and compare (module docstring).

    Raises:
        ConfigError: The file is not of suite v3 or v4 (it has no headline to compare), or
            has none.
    """
    if doc.get("schema_version") not in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4) \
            or doc["aggregate"].get("headline") is None:
        raise ConfigError("the fresh check compares headlines: give a results file of suite "
                          "v3 or v4 with a headline", field="fresh")
    skipped = {a: why for a, ident in doc["agents"].items()
               if (why := replayable(a, ident)) is not None}
    if skipped:
        return FreshResult(seed, [], [], skipped)
    fresh = _fresh_document(doc, seed, jobs)
    head, again = doc["aggregate"]["headline"]["agents"], fresh["aggregate"]["headline"]
    agents = [a for a in doc["aggregate"]["headline"]["order"] if a in again["agents"]]
    z = NormalDist().inv_cdf(1 - ALPHA / (2 * max(len(agents), 1)))
    lines, failed = [], []
    for a in agents:
        s, f = head[a], again["agents"][a]
        d = s["mean"] - f["mean"]
        margin = z * math.hypot(_half(s), _half(f))
        ok = abs(d) <= margin
        failed += [] if ok else [a]
        lines.append(f"{a}: submitted {s['mean']:.3f} [{s['ci95'][0]:.3f}, {s['ci95'][1]:.3f}], "
                     f"fresh {f['mean']:.3f} [{f['ci95'][0]:.3f}, {f['ci95'][1]:.3f}]; "
                     f"difference {d:.3f} [{d - margin:.3f}, {d + margin:.3f}]"
                     + ("" if ok else "  OUTSIDE: the submitted headline is not what this "
                        "agent gives on fresh humans and a seed it could not know"))
    return FreshResult(seed, lines, failed, {})
