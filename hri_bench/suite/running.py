"""Running the suite: every track's study, ``suite.json``'s summaries, the leaderboards.

``hri-bench suite --out DIR`` runs every track of the version (:mod:`hri_bench.suite.tracks`)
with :func:`hri_bench.run.study.run_study` and writes

* ``DIR/suite.json``: per track its settings and, per agent, the mean and IQM of the
  reward and of the regret against ``blind`` with 95 % bootstrap CIs over runs (of each
  run's mean over its episodes, :mod:`hri_bench.core.stats`), the per-episode means with
  CIs, the wrong and passive decision rates, the truncation rate and the episodes to
  converge (:data:`CONVERGED`). No wall time: the file is identical whatever ``--jobs`` or
  ``--executor``;
* ``DIR/leaderboard.md``: per track, the agents sorted by mean regret, with CIs;
* ``DIR/results.json``: the results file (:mod:`hri_bench.suite.submission`);
* ``DIR/<track>.png``: mean regret (or reward, where regret is not reported) per episode
  with 95 % CI error bars;
* ``DIR/suite_log.json``: wall times and how the suite was run;
* ``DIR/errors.log`` (only when an agent raised): each failed agent's traceback by track.
  The agent is left out of that track (its name is in the track's ``failed_agents``) and
  the other agents' results are written, as in ``hri-bench study``.

Regret is reported where the exact ``blind`` plan fits the track's humans (deterministic or
passive, :mod:`hri_bench.run.regret`); on tracks with Boltzmann humans it is "n/a". The
references ``blind`` and ``informed`` are added to tracks with one shared human (they
refuse humans drawn per run); on the drifting-human track regret still uses blind's exact
value per episode. See docs/benchmark.md, "Suite".
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.core import stats
from hri_bench.core.atomic import atomic_writer
from hri_bench.run import metrics, provenance
from hri_bench.run.agents import PLANNING_REFERENCES, REFERENCE_AGENTS, agent_privilege
from hri_bench.run.regret import ALL_REFERENCES, REFERENCES, reference_summary
from hri_bench.run.study import (
    StudyResult,
    UnitLostError,
    _units,
    regret_reference,
    run_study,
)
from hri_bench.suite import results_v3, results_v4
from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.resume import SUITE_LOG, TrackStore, complete_suite, suite_plan
from hri_bench.suite.submission import SuiteRecorder, lead_section, task_section, write_results
from hri_bench.suite.tracks import (
    ALPHA,
    DELTA,
    DELTA_V3,
    FLOOR,
    INTENTION_BLIND,
    INTENTION_BLIND_V3,
    LATEST,
    MAX_BLOCKS,
    MAX_RUNS,
    MAX_RUNS_V3,
    MIN_BLOCKS,
    MIN_RUNS,
    MIN_RUNS_V3,
    POWER,
    Track,
    check_version,
    default_agents,
    detectable_v3,
    population_track,
    select_tracks,
    track_config,
)
from hri_envs.errors import ConfigError

__all__ = [
    "CONVERGED",
    "ERRORS_LOG",
    "episodes_to_converge",
    "leaderboard",
    "leaderboard_v2",
    "leaderboard_v3",
    "leaderboard_v4",
    "run_suite",
    "track_figure",
    "track_summary",
    "track_summary_v2",
    "track_summary_v3",
]

#: An agent has converged from the first episode after which its mean regret over runs
#: stays at or below this (reward units per episode).
CONVERGED = 0.05
#: Where the tracebacks of agents that raised go (in the suite's folder).
ERRORS_LOG = "errors.log"


def _summary(x: np.ndarray, seed: int) -> dict[str, Any]:
    """Mean and IQM over runs of each run's episode mean, with 95 % CIs
    (:func:`hri_bench.run.metrics.summary` without the median); per-episode means.
    """
    per_ep = stats.per_episode(x, seed, iqm_ci=False)
    return {**metrics.summary(x.mean(1), seed, median=False),
            "per_episode": {"mean": per_ep["mean"], "ci95": per_ep["ci95"]}}


def episodes_to_converge(regret: np.ndarray, threshold: float = CONVERGED) -> int | None:
    """The first episode (1-based) from which the mean regret over runs stays ≤ threshold.

    Args:
        regret: (runs, episodes) regret against blind.
        threshold: The tolerance, reward units per episode.

    Returns:
        The episode, or None when the last episode's mean regret is above the threshold.
    """
    above = np.flatnonzero(regret.mean(0) > threshold + 1e-12)
    if len(above) == 0:
        return 1
    last = int(above[-1]) + 1  # 1-based episode of the last excursion
    return None if last == regret.shape[1] else last + 1


def track_summary(track: Track, result: StudyResult) -> dict[str, Any]:
    """The ``suite.json`` entry of a track."""
    cfg = result.config
    blind, note = regret_reference(result)
    agents: dict[str, Any] = {}
    for name, m in result.metrics.items():
        entry: dict[str, Any] = {"reward": _summary(m["reward"], cfg.seed)}
        if blind is not None:
            regret = blind - m["reward"]
            entry["regret"] = _summary(regret, cfg.seed)
            entry["episodes_to_converge"] = episodes_to_converge(regret)
        else:
            entry["regret"] = None
            entry["episodes_to_converge"] = None
        entry.update(wrong_rate=float(m["wrong"].mean()), passive_rate=float(m["passive"].mean()),
                     truncation_rate=float(m["truncated"].mean()))
        agents[name] = entry
    return {"description": track.description, "scenario": track.scenario,
            "runs": cfg.runs, "episodes": cfg.n_episodes,
            "settings": cfg.settings(), "regret": note,
            "regret_reported": blind is not None, "agents": agents,
            "failed_agents": sorted(result.failures)}


def track_summary_v2(track: Track, result: StudyResult) -> dict[str, Any]:
    """A v2 ``suite.json`` entry: v1's, plus the reference, the gaps, the population and
    the power analysis.
    """
    entry = track_summary(track, result)
    ref = reference_summary(result)
    cfg = result.config
    for name, gaps in ref.pop("gaps").items():
        entry["agents"][name]["gap_to_upper"] = gaps["to_upper"]
        entry["agents"][name]["gap_to_lower"] = gaps["to_lower"]
    entry["reference"] = ref
    entry["population"] = cfg.population_info()
    entry["headline"] = track.headline
    entry["stable_preference"] = track.stable
    sd = track.pilot_sd
    entry["power"] = {
        "delta": DELTA, "power": POWER, "alpha": ALPHA, "pilot_sd": sd,
        "runs_needed": None if not sd else stats.runs_for_difference(sd, DELTA, power=POWER,
                                                                     alpha=ALPHA),
        "runs": cfg.runs,
        "detectable": None if not sd else round(stats.detectable_difference(
            sd, cfg.runs, power=POWER, alpha=ALPHA), 4)}
    return entry


def track_summary_v3(track: Track, result: StudyResult) -> dict[str, Any]:
    """A v3 ``suite.json`` entry: v2's, with v3's power analysis (humans, runs per human,
    the pilot's two spreads, the difference detected and whether it meets
    :data:`DELTA_V3`) in place of v2's.
    """
    entry = track_summary_v2(track, result)
    humans = getattr(track, "humans", 1)
    between, within = getattr(track, "pilot_between", 0.0), getattr(track, "pilot_within", 0.0)
    runs = result.config.runs
    humans = min(humans, runs)  # a runs scale below 1 meets fewer of them
    blocks = max(1, runs // humans)
    found = detectable_v3(between, within, humans, blocks)  # one human: blocks == runs
    entry["power"] = {"delta": DELTA_V3, "power": POWER, "alpha": ALPHA, "humans": humans,
                      "runs_per_human": blocks, "pilot_between": between,
                      "pilot_within": within, "detectable": found,
                      "met": bool(found <= DELTA_V3)}
    return entry


def _cells(tr: dict[str, Any], agents: list[str], value: Any) -> list[str]:
    """A leaderboard row's cells: ``value(entry)`` per agent, "raised" where it failed on the
    track, "—" where it does not run there.
    """
    return ["raised" if a in tr["failed_agents"] else "—" if tr["agents"].get(a) is None
            else value(tr["agents"][a]) for a in agents]


def _overview(doc: dict[str, Any]) -> list[str]:
    """One table over all tracks: mean regret [95 % CI] (reward, marked "r", where n/a)."""
    agents = list(doc["agents"]) + [a for a in ("oracle", "blind", "informed")
                                    if a not in doc["agents"]]
    agents = [a for a in agents if any(a in tr["agents"] for tr in doc["tracks"].values())]
    lines = ["## Overview", "", "Mean regret vs blind per episode [95 % CI]; where regret is "
             "n/a, the mean reward (marked r). — : the agent does not run on the track; raised: "
             "it failed there (errors.log).", "",
             "| track | " + " | ".join(code(a) for a in agents) + " |",
             "|---|" + "---|" * len(agents)]
    for name, tr in doc["tracks"].items():
        cells = _cells(tr, agents, (lambda e: with_ci(e["regret"])) if tr["regret_reported"]
                       else (lambda e: "r " + with_ci(e["reward"])))
        lines.append(f"| {escape(name)} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def leaderboard(doc: dict[str, Any]) -> str:
    """The ``leaderboard.md`` text of a v1 ``suite.json`` document."""
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Regret = blind's exact "
             "expected episode reward minus the agent's, per episode; mean and IQM over runs "
             "of each run's mean over its episodes, with 95 % bootstrap CIs. Lower regret is "
             "better; agents are sorted by mean regret (by reward where regret is n/a).", "",
             "References: `informed` is the information bound (the exact optimum for a robot "
             "that sees the intention); `blind` is the ceiling for intention-blind robots "
             "(regret 0 by definition in expectation); `oracle` is the paper's heuristic "
             "(sees the intention, not optimal: no bound). Regret is n/a where the human is "
             "Boltzmann (the held-out population): the exact blind plan does not fit it.",
             ""]
    lines += _overview(doc)
    for name, tr in doc["tracks"].items():
        lines += [f"## {escape(name)}", "", f"{escape(tr['description'])} ({tr['runs']} runs × "
                  f"{tr['episodes']} episodes).", ""]
        if not tr["regret_reported"]:
            lines += [f"Regret n/a: {escape(tr['regret'].removeprefix('not reported: '))}.",
                      ""]
        if tr["failed_agents"]:
            lines += ["Raised, no results (tracebacks in errors.log): "
                      + ", ".join(code(a) for a in tr["failed_agents"]) + ".", ""]
        lines += ["| agent | regret mean [95 % CI] | regret IQM [95 % CI] | "
                  "reward mean [95 % CI] | wrong | passive | truncated | converged at |",
                  "|---|---|---|---|---|---|---|---|"]

        def key(item: tuple[str, Any]) -> tuple[float, str]:
            a = item[1]
            v = a["regret"]["mean"] if a["regret"] is not None else -a["reward"]["mean"]
            return (v, item[0])

        for agent, a in sorted(tr["agents"].items(), key=key):
            conv = a["episodes_to_converge"]
            conv_text = "n/a" if a["regret"] is None else "never" if conv is None else str(conv)
            label = code(agent) + (" (ref.)" if agent in REFERENCES else "")
            lines.append(f"| {label} | {with_ci(a['regret'])} | {with_ci(a['regret'], 'iqm')}"
                         f" | {with_ci(a['reward'])} | {a['wrong_rate']:.3f} | "
                         f"{a['passive_rate']:.3f} | {a['truncation_rate']:.1%} | {conv_text} |")
        lines.append("")
    return "\n".join(lines)


def _reference_cell(tr: dict[str, Any]) -> str:
    ref = tr["reference"]
    if ref["kind"] == "exact":
        return f"exact: blind {number(ref['lower_reward'])}, informed {number(ref['upper_reward'])}"
    if ref["kind"] == "bracket":
        return (f"bracket: blind in [{number(ref['lower_reward'])} (qmdp), "
                f"{number(ref['upper_reward'])} (informed)]")
    return ref["kind"]


def leaderboard_v2(doc: dict[str, Any]) -> str:
    """The ``leaderboard.md`` text of a v2 ``suite.json`` document."""
    ranked = [a for a in doc["agents"] if any(a in tr["agents"] for tr in doc["tracks"].values())]
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Headline: the frozen "
             "**test** split (the evaluation set; population hashes below). Every track has a "
             "reference: `blind` **exact** where it fits (the paper tracks), else a labelled "
             "**bracket** on it: `qmdp` below (a feasible intention-blind policy that knows "
             "the human's model; simulated) and `informed` above (the exact optimum that sees "
             "the intention; no robot expects more). Cells: an agent's **gap to the upper "
             "bound** (`informed`): the mean over runs of informed's run-mean reward per "
             "episode minus the agent's (paired runs: same humans, same schedules), with its "
             "95 % bootstrap CI; lower is better. Runs per track: enough to detect "
             f"{doc['power']['delta']} per episode at {doc['power']['power']:.0%} power "
             f"(α = {doc['power']['alpha']}), from a pilot's spread, within "
             f"[{doc['power']['min_runs']}, {doc['power']['max_runs']}].", "",
             "## Overview: gap to the upper bound (informed) per episode [95 % CI]", "",
             "| track | reference | " + " | ".join(code(a) for a in ranked) + " |",
             "|---|---|" + "---|" * len(ranked)]
    for name, tr in doc["tracks"].items():
        cells = _cells(tr, ranked, lambda e: with_ci(e["gap_to_upper"]))
        label = f"**{escape(name)}**" if tr["headline"] else escape(name)
        lines.append(f"| {label} | {_reference_cell(tr)} | " + " | ".join(cells) + " |")
    lines.append("")
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)


def _track_section(name: str, tr: dict[str, Any]) -> list[str]:
    """A v2 or v3 leaderboard's section of one track: its humans, power, reference and a
    table of the agents by mean reward with their gaps to both ends.
    """
    pop = tr["population"]
    pop_text = ("" if pop is None else f" Population {code(pop['name'])}." if pop["hash"] is None
                else f" Population {code(pop['name'])} v{pop['version']} ({pop['members']} "
                f"members), hash `{pop['hash'][:16]}`.")
    power = tr["power"]
    if "pilot_sd" in power:  # v2
        power_text = ("" if power["pilot_sd"] is None else
                      f" Pilot spread {power['pilot_sd']:.3f}: {power['runs_needed']} runs "
                      f"needed for {power['delta']}; {power['runs']} run, which detect "
                      f"{power['detectable']}.")
    else:
        power_text = (f" Power: {power['humans']} human(s) × {power['runs_per_human']} runs "
                      f"detect a normalised difference of {power['detectable']} at "
                      f"{power['power']:.0%} ({'meets' if power['met'] else 'MISSES'} the "
                      f"target {power['delta']}).")
    ref = tr["reference"]
    lines = [f"## {escape(name)}", "", f"{escape(tr['description'])} ({tr['runs']} runs × "
             f"{tr['episodes']} episodes).{pop_text}{power_text}", "",
             f"Reference: {_reference_cell(tr)}. {escape(ref['note'].capitalize())}.", ""]
    if tr["failed_agents"]:
        lines += ["Raised, no results (tracebacks in errors.log): "
                  + ", ".join(code(a) for a in tr["failed_agents"]) + ".", ""]
    lower = "regret vs blind (exact)" if ref["kind"] == "exact" else "gap to qmdp (lower)"
    lines += [f"| agent | reward mean [95 % CI] | gap to informed (upper) | {lower} | "
              "wrong | passive | truncated |", "|---|---|---|---|---|---|---|"]

    def key(item: tuple[str, Any]) -> tuple[float, str]:
        return (-item[1]["reward"]["mean"], item[0])

    for agent, a in sorted(tr["agents"].items(), key=key):
        label = code(agent) + (" (ref.)" if agent in ALL_REFERENCES else "")
        lines.append(f"| {label} | {with_ci(a['reward'])} | {with_ci(a['gap_to_upper'])} | "
                     f"{with_ci(a['gap_to_lower'])} | {a['wrong_rate']:.3f} | "
                     f"{a['passive_rate']:.3f} | {a['truncation_rate']:.1%} |")
    lines.append("")
    return lines


def leaderboard_v3(doc: dict[str, Any], results: dict[str, Any] | None) -> str:
    """The ``leaderboard.md`` text of a v3 suite: the headline and pairs
    (:func:`hri_bench.suite.results_v3.lead_section`), where learners fail, the tracks that miss
    their power target, the task's metrics, then a section per track.
    """
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Headline: the frozen test "
             "split v2 (160 different humans per scenario, none a train or validation human), "
             "one track per group of humans, each normalised to its reachable reference "
             "(docs/results.md, \"Ranking (suite v3)\").", ""]
    if results is not None:
        lines += [results_v3.lead_section(results), results_v3.failure_section(results)]
    missed = [f"{n} (detects {tr['power']['detectable']})" for n, tr in doc["tracks"].items()
              if not tr["power"]["met"]]
    target = (f"Power target: a normalised difference of {DELTA_V3} at {POWER:.0%} "
              f"(α = {ALPHA}), with the two-stage spread a pilot on the validation-v2 split "
              f"measured; at most {MAX_BLOCKS} runs per human.")
    lines += ["## Power", "", target + (" Tracks that miss it: " + "; ".join(missed) + "."
                                        if missed else " Every track meets it."), ""]
    if results is not None:
        lines.append(task_section(results))
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)


def leaderboard_v4(doc: dict[str, Any], results: dict[str, Any] | None) -> str:
    """The ``leaderboard.md`` text of a v4 suite: v3's (:func:`leaderboard_v3`) with the
    learners ranked apart from the references, shared ranks and the references' noise in
    the intervals (:func:`hri_bench.suite.results_v4.lead_section`).
    """
    text = leaderboard_v3(doc, None)
    head, rest = text.split("\n## Power", 1)
    head = head.replace("the frozen test split v2 (160 different humans per scenario, none a "
                        "train or validation human)", "the frozen test split v3 (160 humans "
                        "per scenario, none the same as another or as a train or validation "
                        "human by behaviour, docs/humans.md)").replace(
        "\"Ranking (suite v3)\"", "\"Ranking (suite v4)\"")
    parts = [head.rstrip("\n"), ""]
    if results is not None:
        refs = [a for a, r in results.get("roles", {}).items() if r["reference"]]
        parts += [results_v4.lead_section(results),
                  results_v3.failure_section(results, refs)]
    power = rest.split("\n## ", 1)[0].rstrip("\n").replace("validation-v2", "validation-v3")
    lines = [*parts, "## Power" + power, ""]
    if results is not None:
        lines.append(task_section(results))
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)


#: How far beyond the middle of the curves :func:`track_figure`'s axis reaches, in units of
#: their interquartile spread (Tukey's fences); curves beyond are clipped, and the figure
#: says which and how far they go.
FENCE = 3.0


def axis_range(entry: dict[str, Any]) -> tuple[tuple[float, float] | None, dict[str, float]]:
    """The y range of a track's figure and the agents whose curve leaves it, with their most
    extreme per-episode mean: the range spans every curve unless some lie beyond
    :data:`FENCE` interquartile spreads of all the curves' points (an agent whose episodes
    run to the step limit, −20 where the others stay within −2 of 0); None: no clipping.
    """
    metric = "regret" if entry["regret_reported"] else "reward"
    curves = {a: np.asarray(e[metric]["per_episode"]["mean"], dtype=float)
              for a, e in entry["agents"].items()}
    points = np.concatenate([c[np.isfinite(c)] for c in curves.values()] or [np.zeros(0)])
    if points.size < 4:
        return None, {}
    q1, q3 = np.percentile(points, [25, 75])
    spread = max(q3 - q1, 1e-9)
    low, high = q1 - FENCE * spread, q3 + FENCE * spread
    out = {}
    for a, c in curves.items():
        c = c[np.isfinite(c)]
        if c.size and (c.min() < low or c.max() > high):
            out[a] = float(c.min() if c.min() < low else c.max())
    if not out:
        return None, {}
    inside = points[(points >= low) & (points <= high)]
    pad = 0.08 * max(float(inside.max() - inside.min()), 1e-6)
    return (float(inside.min()) - pad, float(inside.max()) + pad), out


def track_figure(name: str, entry: dict[str, Any], path: Path, clip: bool = False) -> Path:
    """Mean regret (or reward) per episode with 95 % CI error bars, one line per agent; with
    ``clip`` (suite v4; v1 to v3 draw as they did), an agent far below (or above) the rest
    is clipped and named (:func:`axis_range`).
    """
    from matplotlib.ticker import MaxNLocator  # matplotlib: the bench extra, when drawing

    from hri_bench.core import plots  # matplotlib, as above

    metric = "regret" if entry["regret_reported"] else "reward"
    fig, ax = plots.new_figure(figsize=(6.0, 3.6))
    for i, (agent, a) in enumerate(entry["agents"].items()):
        pe = a[metric]["per_episode"]
        mean = np.asarray(pe["mean"], dtype=float)
        low, high = np.array([[np.nan if v is None else v for v in c] for c in pe["ci95"]],
                             dtype=float).T
        yerr = np.nan_to_num(np.clip(np.stack([mean - low, high - mean]), 0.0, None))
        x = np.arange(1, len(mean) + 1) + 0.06 * (i - len(entry["agents"]) / 2)
        color, dashes = plots.agent_style(agent)  # one colour and line per agent everywhere
        ax.errorbar(x, mean, yerr=yerr, color=color, label=plots.LABELS.get(agent, agent),
                    linewidth=1.4, elinewidth=0.8, capsize=2, linestyle=dashes)
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    label = ("regret vs blind per episode" if metric == "regret"
             else "robot cooperation reward per episode")
    limits, clipped = axis_range(entry) if clip else (None, {})
    if limits is not None:
        ax.set_ylim(*limits)
        label += "\naxis clipped; off it: " + ", ".join(
            f"{plots.LABELS.get(a, a)} ({v:.3g})" for a, v in clipped.items())
    if limits is not None:
        ax.set_ylabel(label, fontsize=8)
    else:
        ax.set_ylabel(label)
    if metric == "regret":
        ax.axhline(0.0, color="black", linewidth=0.6)
    ax.set_title(f"{name}: {entry['description']}", fontsize=8)
    if entry["agents"]:  # every agent may have raised on the track
        ax.legend(fontsize=7, ncol=2)
    plots.save_figure(fig, path)
    return path


def run_suite(
    out: str | os.PathLike[str],
    *,
    agents: Sequence[str] | None = None,
    tracks: str | Sequence[str] | None = None,
    runs_scale: float = 1.0,
    seed: int = 0,
    jobs: int = 1,
    executor: str = "serial",
    progress: bool = False,
    populations: Sequence[str] = (),
    version: str = LATEST,
    resume: bool = False,
    unit_time_limit: float | None = None,
    imports: Sequence[str] = (),
) -> dict[str, Any]:
    """Run the suite's tracks and write its files into ``out``; return suite.json's document.

    Every track's configuration is built (and so validated) before any simulation. An
    agent that raises (or calls ``sys.exit``) is left out of that track and recorded: the
    track's ``failed_agents`` and ``DIR/errors.log``; the other agents run on. The work
    in progress is kept in ``out/.suite`` (:class:`~hri_bench.suite.resume.TrackStore`)
    until every file is written.

    Args:
        out: Output directory (created).
        agents: Agents to rank (see :mod:`hri_bench.run.agents`, e.g. "mypkg.mod:MyAgent");
            None: the version's defaults (:func:`~hri_bench.suite.tracks.default_agents`).
        tracks: Track names (comma-separated or a list); None: all of the version's tracks
            (:data:`~hri_bench.suite.tracks.TRACKS_BY_VERSION`).
        runs_scale: Multiplies every track's run count (at least 2 runs), > 0.
        seed: Base seed of every study and bootstrap.
        jobs: Worker processes per study (passed to :func:`run_study`).
        executor: "serial", "process" or "ray".
        progress: Show a tqdm progress bar over tracks.
        populations: Populations to add a track of their own for, after the chosen tracks
            (:func:`~hri_bench.suite.tracks.population_track`, e.g.
            ``recorded:hanger-people-v0``).
        version: The suite version (:data:`~hri_bench.suite.tracks.SUITE_VERSIONS`; default
            :data:`~hri_bench.suite.tracks.LATEST`).
        resume: Continue the suite interrupted in ``out`` (its finished tracks and units
            are not run again; the files are byte-identical to an uninterrupted run's), or
            return the document of the complete suite ``out`` holds; without it, what an
            interrupted suite left in ``out/.suite`` is removed first.
        unit_time_limit: The most wall seconds one unit of work may take
            (:attr:`~hri_bench.run.study.StudyConfig.unit_time_limit`; None: the backend's
            default).
        imports: Modules whose registrations the suite uses (an agent of your own by
            name, a population's family): imported in every process that runs a track,
            recorded in ``suite.json`` and every track's settings
            (:attr:`~hri_bench.run.study.StudyConfig.imports`).

    Raises:
        ConfigError: Unknown track, bad agents, bad runs_scale (before any simulation);
            ``resume`` on a folder of another suite (``field="out"``).
        UnitLostError: A unit's worker died or it ran past the time limit (the finished
            tracks and units are kept for ``resume``).
    """
    if not (isinstance(runs_scale, int | float) and math.isfinite(runs_scale)
            and runs_scale > 0):
        raise ConfigError(f"runs_scale must be a number > 0, got {runs_scale!r}",
                          field="runs_scale")
    version = check_version(version)
    if agents is None:
        agents = default_agents(version)
    versioned = select_tracks(tracks, version)
    chosen = versioned + [population_track(p, version) for p in populations]
    configs = [dataclasses.replace(
        track_config(t, agents, runs_scale=runs_scale, seed=seed, jobs=jobs,
                     executor=executor, version=version), unit_time_limit=unit_time_limit,
        imports=tuple(imports))
               for t in chosen]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plan = suite_plan(version, agents, [t.name for t in versioned], populations, runs_scale,
                      [seed])
    if resume:
        complete = complete_suite(out, plan)
        if complete is not None:
            return complete
    store = TrackStore(out, plan, resume=resume)
    doc = _suite_header(version, seed, runs_scale, agents)
    if imports:  # before the tracks (left out when none: the files of earlier suites)
        doc["imports"] = list(imports)
        doc["tracks"] = doc.pop("tracks")
    t0 = time.perf_counter()
    recorder = SuiteRecorder(seed, runs_scale, version)  # results.json (submission.py)
    walls, failures = _run_tracks(chosen, configs, doc, recorder, store, progress)
    _write_errors(out, failures)
    results = recorder.document()  # v1's suite.json and leaderboard.md stay as they were
    _add_power_and_provenance(doc, version, agents)
    with atomic_writer(out / "leaderboard.md") as f:
        f.write(_leaderboard_text(doc, results) + "\n")
    if results is not None:
        write_results(out, results)
    with atomic_writer(out / "suite.json") as f:
        f.write(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    log = {"suite_version": version, "jobs": jobs, "executor": executor,
           "wall_time_s": round(time.perf_counter() - t0, 2), "tracks_wall_time_s": walls,
           "load_average": list(os.getloadavg()), "cpus": os.cpu_count(), "plan": plan}
    with atomic_writer(out / SUITE_LOG) as f:
        f.write(json.dumps(log, indent=1) + "\n")
    store.finish()
    return doc


def _suite_header(version: str, seed: int, runs_scale: float, agents: Sequence[str]
                  ) -> dict[str, Any]:
    """``suite.json``'s document before its tracks: the version's ranked agents,
    references and (v2, v3) the agents that must infer the intention and v2's power.
    """
    if version == "1":
        ranked = [a for a in agents if a not in REFERENCE_AGENTS]
        return {"suite_version": version, "seed": seed, "runs_scale": runs_scale,
                "agents": ranked, "converged_threshold": CONVERGED,
                "references": dict(REFERENCES), "tracks": {}}
    ranked = [a for a in agents if a not in PLANNING_REFERENCES]
    if version not in ("2", "3"):  # v4: what each agent declares, an agent of one's own too
        every = list(dict.fromkeys([*agents, *ALL_REFERENCES, FLOOR]))
        sees = {a: agent_privilege(a) for a in every}
        ranked = [a for a in agents if not sees[a].reference]
        blind_ones = [a for a in every if not sees[a].sees_intention]
        references = {**ALL_REFERENCES, **{a: "sees the intention" if p.sees_intention else
                                           "knows the human's model"
                                           for a, p in sees.items()
                                           if p.reference and a not in ALL_REFERENCES}}
    else:
        blind_ones = list(INTENTION_BLIND if version == "2" else INTENTION_BLIND_V3)
        references = dict(ALL_REFERENCES)
    return {"suite_version": version, "seed": seed, "runs_scale": runs_scale,
            "agents": ranked, "converged_threshold": CONVERGED,
            "references": references,
            "intention_blind": blind_ones,
            "power": {"delta": DELTA, "power": POWER, "alpha": ALPHA,
                      "min_runs": MIN_RUNS, "max_runs": MAX_RUNS,
                      "pilot": "benchmarks/suite_power.py: seed 1000, 256 runs per track"},
            "tracks": {}}


def _run_tracks(chosen: Sequence[Track], configs: Sequence[Any], doc: dict[str, Any],
                recorder: SuiteRecorder, store: TrackStore, progress: bool
                ) -> tuple[dict[str, float], dict[str, dict[str, str]]]:
    """Run each track's study (an agent that raises is left out), summarise it into
    ``doc["tracks"]``, record it for ``results.json`` and draw its figure; returns the wall
    times and the tracebacks by track and agent. A track that ``store`` holds as finished
    is not run again; each finished unit and track is kept there.
    """
    version = doc["suite_version"]
    summarise = {"1": track_summary, "2": track_summary_v2}.get(version, track_summary_v3)
    walls: dict[str, float] = {}
    failures: dict[str, dict[str, str]] = {}
    iterator: Any = enumerate(zip(chosen, configs, strict=True))
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(list(iterator), desc="suite", unit="track")
    for k, (track, cfg) in iterator:
        finished = store.finished(k, track, cfg)
        if finished is None:
            t = time.perf_counter()
            units = _units(cfg)

            def keep(i: int, res: Any, k: int = k, track: Track = track,
                     units: list[Any] = units) -> None:
                store.save_unit(k, track, i, units[i], res)

            try:
                result = run_study(cfg, keep_going=True,
                                   done=store.units_done(k, track, units), on_result=keep)
            except UnitLostError as exc:
                raise UnitLostError(exc.agent, exc.runs, exc.reason,
                                    f"track {track.name}") from None
            wall = round(time.perf_counter() - t, 2)
            store.save(k, track, result, wall)
        else:
            result, wall = finished
        if result.failures:
            failures[track.name] = result.failures
        entry = summarise(track, result)
        recorder.add(track, result)
        doc["tracks"][track.name] = entry
        track_figure(track.name, entry, store.out / f"{track.name}.png",
                     clip=version not in ("1", "2", "3"))
        walls[track.name] = wall
    return walls, failures


def _write_errors(out: Path, failures: dict[str, dict[str, str]]) -> None:
    """``errors.log`` with each failed agent's traceback by track; none when none failed."""
    errors = out / ERRORS_LOG
    if failures:
        with atomic_writer(errors) as f:
            for track_name, by_agent in failures.items():
                for agent, text in by_agent.items():
                    f.write(f"track {track_name}: agent {agent!r} raised:\n{text}\n")
    else:
        errors.unlink(missing_ok=True)  # from an earlier suite in the same folder


def _add_power_and_provenance(doc: dict[str, Any], version: str,
                              agents: Sequence[str]) -> None:
    """v3's power analysis and floor; from v2 on, the software and the agents' code
    identities.
    """
    if version not in ("1", "2"):
        doc["power"] = {"delta": DELTA_V3, "power": POWER, "alpha": ALPHA,
                        "blocks": [MIN_BLOCKS, MAX_BLOCKS], "runs": [MIN_RUNS_V3, MAX_RUNS_V3],
                        "pilot": "benchmarks/suite_power.py --version 3: the validation-v2 "
                                 "split, seed 1000"}
        doc["floor"] = FLOOR
    if version != "1":
        doc["provenance"] = {"software": provenance.software(),
                             "agents": {a: provenance.agent_identity(a) for a in agents}}


def _leaderboard_text(doc: dict[str, Any], results: dict[str, Any] | None) -> str:
    """``leaderboard.md`` of the version: v1's, v2's with the aggregate across tracks
    leading (docs/results.md), or v3's.
    """
    version = doc["suite_version"]
    if version == "1":
        return leaderboard(doc)
    if version == "2":
        board = leaderboard_v2(doc)
        if results is not None:  # the aggregate across tracks leads (docs/results.md)
            cut = board.find("\n## ") + 1 or len(board)
            board = (board[:cut] + lead_section(results) + "\n" + task_section(results) + "\n"
                     + board[cut:])
        return board
    if version == "3":
        return leaderboard_v3(doc, results)
    return leaderboard_v4(doc, results)
