"""The benchmark suite: a fixed, versioned set of tracks, one study each, and a leaderboard.

``hri-bench suite --out DIR`` runs every track of :data:`TRACKS` with
:func:`hri_bench.study.run_study` and writes

* ``DIR/suite.json``: per track its settings and, per agent, the mean and IQM of the
  reward and of the regret against ``blind`` with 95 % bootstrap CIs over runs (of each
  run's mean over its episodes, :mod:`hri_bench.stats`), the per-episode means with
  CIs, the wrong and passive decision rates, the truncation rate and the episodes to
  converge (:data:`CONVERGED`). No wall time: the file is identical whatever ``--jobs`` or
  ``--executor``;
* ``DIR/leaderboard.md``: per track, the agents sorted by mean regret, with CIs;
* ``DIR/<track>.png``: mean regret (or reward, where regret is not reported) per episode
  with 95 % CI error bars;
* ``DIR/suite_log.json``: wall times and how the suite was run;
* ``DIR/errors.log`` (only when an agent raised): each failed agent's traceback by track.
  The agent is left out of that track (its name is in the track's ``failed_agents``) and
  the other agents' results are written, as in ``hri-bench study``.

Regret is reported where the exact ``blind`` plan fits the track's humans (deterministic or
passive, :mod:`hri_bench.regret`); on tracks with Boltzmann humans it is "n/a". The
references ``blind`` and ``informed`` are added to tracks with one shared human (they
refuse humans drawn per run); on the drifting-human track regret still uses blind's exact
value per episode. See docs/benchmark.md, "Suite".
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench import provenance, stats
from hri_bench.agents import BUILTIN_AGENTS, REFERENCE_AGENTS
from hri_bench.atomic import atomic_writer
from hri_bench.regret import REFERENCES
from hri_bench.study import StudyConfig, StudyResult, regret_reference, run_study
from hri_bench.submission import SuiteRecorder, lead_section, task_section
from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import SCENARIOS, scenario_spec

__all__ = [
    "CONVERGED",
    "DEFAULT_AGENTS",
    "SUITE_VERSION",
    "TRACKS",
    "Track",
    "run_suite",
    "select_tracks",
    "track_config",
]

#: Version of the track set; changes whenever a track's settings or run count change.
SUITE_VERSION = "1"
#: The agents ranked by default (the references are added where they fit).
DEFAULT_AGENTS: tuple[str, ...] = BUILTIN_AGENTS
#: An agent has converged from the first episode after which its mean regret over runs
#: stays at or below this (reward units per episode).
CONVERGED = 0.05
#: Where the tracebacks of agents that raised go (in the suite's folder).
ERRORS_LOG = "errors.log"
#: Agents that must infer the intention (blind is their ceiling).
INTENTION_BLIND: tuple[str, ...] = ("learner", "imitator", "maxent", "passive")


@dataclass(frozen=True)
class Track:
    """One track: a study's settings besides the agents, seed and execution.

    Attributes:
        name: ``<scenario>-<kind>``.
        scenario: "hanger" or "wheel".
        description: One line for the leaderboard.
        runs: Runs per agent at ``--runs-scale 1``.
        settings: Keyword arguments of :class:`~hri_bench.study.StudyConfig`.
    """

    name: str
    scenario: str
    description: str
    runs: int
    settings: tuple[tuple[str, Any], ...] = ()

    @property
    def per_run_humans(self) -> bool:
        """Whether runs draw their own humans (then blind/informed cannot run)."""
        keys = dict(self.settings)
        return keys.get("population") is not None or keys.get("human_drift") is not None


def _tracks() -> tuple[Track, ...]:
    out = []
    for sc in SCENARIOS:
        drift = scenario_spec(sc).episodes // 2
        out += [
            Track(f"{sc}-paper", sc, "the paper's settings: deterministic human, default "
                  "preference", 500),
            Track(f"{sc}-passive", sc, "a passive (noisy) human: waits in a step with "
                  "probability 0.2", 500, (("human_passive", 0.2),)),
            Track(f"{sc}-drift", sc, f"a drifting human: switches to another preference "
                  f"after {drift} episodes", 500, (("human_drift", drift),)),
            Track(f"{sc}-turnback", sc, "a human who turns back halfway with probability "
                  "0.5 per episode", 500, (("turn_back", 0.5),)),
            Track(f"{sc}-heldout", sc, "the held-out population: any preference, Boltzmann "
                  "β in [2, 30], passive and turning-back rates drawn per run", 500,
                  (("population", "heldout"),)),
        ]
    return tuple(out)


#: The suite's tracks, by name (version :data:`SUITE_VERSION`).
TRACKS: dict[str, Track] = {t.name: t for t in _tracks()}


def select_tracks(names: str | Sequence[str] | None) -> list[Track]:
    """The tracks named (comma-separated or a list; None: all), in the suite's order.

    Raises:
        ConfigError: An unknown track name (the message lists the tracks).
    """
    if names is None:
        return list(TRACKS.values())
    wanted = [n.strip() for n in names.split(",")] if isinstance(names, str) else list(names)
    wanted = [n for n in wanted if n]
    unknown = [n for n in wanted if n not in TRACKS]
    if unknown or not wanted:
        raise ConfigError(f"unknown track(s) {', '.join(unknown) or '(none given)'}; "
                          f"allowed: {', '.join(TRACKS)}", field="tracks")
    return [t for t in TRACKS.values() if t.name in wanted]


def population_track(population: str) -> Track:
    """A track of one's own on a population (``recorded:DATASET``, a registered name of one
    scenario, ``module:Class`` is refused: its scenario is unknown); outside the versioned set.

    Raises:
        ConfigError: A name whose scenario cannot be told (``field="population"``).
    """
    from hri_bench.fit import is_recorded

    scenario = None
    if is_recorded(population):
        from hri_bench.datasets import open_dataset

        scenario = open_dataset(population.split(":", 1)[1], field="population").scenario
    if scenario is None:
        raise ConfigError(f"a suite track of its own takes a recorded population "
                          f"(recorded:DATASET or recorded-irl:DATASET), got {population!r}",
                          field="population")
    name = f"{scenario}-{population.replace(':', '-')}"
    return Track(name, scenario, f"humans fitted to recorded sessions ({population}); a track "
                 f"of its own, not part of suite v{SUITE_VERSION}", 500,
                 (("population", population),))


def _runs(track: Track, scale: float) -> int:
    return max(2, int(round(track.runs * scale)))


def track_config(track: Track, agents: Sequence[str], *, runs_scale: float = 1.0,
                 seed: int = 0, jobs: int = 1, executor: str = "serial") -> StudyConfig:
    """The study of a track: ``agents`` (references dropped) plus blind and informed where
    they fit, ``track.runs × runs_scale`` runs (at least 2).
    """
    ranked = tuple(a for a in agents if a not in REFERENCE_AGENTS)
    refs = () if track.per_run_humans else REFERENCE_AGENTS
    return StudyConfig(track.scenario, agents=ranked + tuple(refs),
                       runs=_runs(track, runs_scale), seed=seed, jobs=jobs,
                       executor=executor, **dict(track.settings))


def _ci(x: np.ndarray, statistic: str, seed: int) -> list[float | None]:
    return list(stats.bootstrap_ci(x, statistic, seed))


def _summary(x: np.ndarray, seed: int) -> dict[str, Any]:
    """Mean and IQM over runs of each run's episode mean, with 95 % CIs; per-episode means."""
    per_run = x.mean(1)
    per_ep = stats.per_episode(x, seed, iqm_ci=False)
    return {"mean": float(per_run.mean()), "ci95": _ci(per_run, "mean", seed),
            "iqm": float(stats.iqm(per_run)), "iqm_ci95": _ci(per_run, "iqm", seed),
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


def _fmt(x: float | None) -> str:
    return "–" if x is None else f"{x:.3f}"


def _with_ci(entry: dict[str, Any] | None, stat: str = "mean") -> str:
    if entry is None:
        return "n/a"
    lo, hi = entry[f"{stat}_ci95" if stat == "iqm" else "ci95"]
    return f"{_fmt(entry[stat])} [{_fmt(lo)}, {_fmt(hi)}]"


def _overview(doc: dict[str, Any]) -> list[str]:
    """One table over all tracks: mean regret [95 % CI] (reward, marked "r", where n/a)."""
    agents = list(doc["agents"]) + [a for a in ("oracle", "blind", "informed")
                                    if a not in doc["agents"]]
    agents = [a for a in agents if any(a in tr["agents"] for tr in doc["tracks"].values())]
    lines = ["## Overview", "", "Mean regret vs blind per episode [95 % CI]; where regret is "
             "n/a, the mean reward (marked r). — : the agent does not run on the track; raised: "
             "it failed there (errors.log).", "",
             "| track | " + " | ".join(f"`{a}`" for a in agents) + " |",
             "|---|" + "---|" * len(agents)]
    for name, tr in doc["tracks"].items():
        cells = []
        for a in agents:
            entry = tr["agents"].get(a)
            if a in tr["failed_agents"]:
                cells.append("raised")
            elif entry is None:
                cells.append("—")
            elif tr["regret_reported"]:
                cells.append(_with_ci(entry["regret"]))
            else:
                cells.append("r " + _with_ci(entry["reward"]))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def leaderboard(doc: dict[str, Any], lead: str = "") -> str:
    """The ``leaderboard.md`` text of a ``suite.json`` document; ``lead`` (the aggregate
    across tracks, :func:`hri_bench.submission.lead_section`) comes first, after the title.
    """
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
    if lead:
        lines += [lead]
    lines += _overview(doc)
    for name, tr in doc["tracks"].items():
        lines += [f"## {name}", "", f"{tr['description']} ({tr['runs']} runs × "
                  f"{tr['episodes']} episodes).", ""]
        if not tr["regret_reported"]:
            lines += [f"Regret n/a: {tr['regret'].removeprefix('not reported: ')}.", ""]
        if tr["failed_agents"]:
            lines += ["Raised, no results (tracebacks in errors.log): "
                      + ", ".join(f"`{a}`" for a in tr["failed_agents"]) + ".", ""]
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
            label = f"`{agent}`" + (" (ref.)" if agent in REFERENCES else "")
            lines.append(f"| {label} | {_with_ci(a['regret'])} | {_with_ci(a['regret'], 'iqm')}"
                         f" | {_with_ci(a['reward'])} | {a['wrong_rate']:.3f} | "
                         f"{a['passive_rate']:.3f} | {a['truncation_rate']:.1%} | {conv_text} |")
        lines.append("")
    return "\n".join(lines)


def track_figure(name: str, entry: dict[str, Any], path: Path) -> Path:
    """Mean regret (or reward) per episode with 95 % CI error bars, one line per agent."""
    from matplotlib.ticker import MaxNLocator

    from hri_bench import plots

    metric = "regret" if entry["regret_reported"] else "reward"
    fig, ax = plots.new_figure(figsize=(6.0, 3.6))
    for i, (agent, a) in enumerate(entry["agents"].items()):
        pe = a[metric]["per_episode"]
        mean = np.asarray(pe["mean"], dtype=float)
        low, high = np.array([[np.nan if v is None else v for v in c] for c in pe["ci95"]],
                             dtype=float).T
        yerr = np.nan_to_num(np.clip(np.stack([mean - low, high - mean]), 0.0, None))
        x = np.arange(1, len(mean) + 1) + 0.06 * (i - len(entry["agents"]) / 2)
        ax.errorbar(x, mean, yerr=yerr, color=plots.COLORS.get(agent),
                    label=plots.LABELS.get(agent, agent), linewidth=1.4, elinewidth=0.8,
                    capsize=2, linestyle="--" if agent in REFERENCES else "-")
    ax.set_xlabel("episode")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("regret vs blind per episode" if metric == "regret"
                  else "robot cooperation reward per episode")
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
    agents: Sequence[str] = DEFAULT_AGENTS,
    tracks: str | Sequence[str] | None = None,
    runs_scale: float = 1.0,
    seed: int = 0,
    jobs: int = 1,
    executor: str = "serial",
    progress: bool = False,
    populations: Sequence[str] = (),
) -> dict[str, Any]:
    """Run the suite's tracks and write its files into ``out``; return suite.json's document.

    Every track's configuration is built (and so validated) before any simulation. An
    agent that raises (or calls ``sys.exit``) is left out of that track and recorded: the
    track's ``failed_agents`` and ``DIR/errors.log``; the other agents run on.

    Args:
        out: Output directory (created).
        agents: Agents to rank (see :mod:`hri_bench.agents`, e.g. "mypkg.mod:MyAgent").
        tracks: Track names (comma-separated or a list); None: all of :data:`TRACKS`.
        runs_scale: Multiplies every track's run count (at least 2 runs), > 0.
        seed: Base seed of every study and bootstrap.
        jobs: Worker processes per study (passed to :func:`run_study`).
        executor: "serial", "process" or "ray".
        progress: Show a tqdm progress bar over tracks.
        populations: Populations to add a track of their own for, after the chosen tracks
            (:func:`population_track`, e.g. ``recorded:hanger-people-v0``).

    Raises:
        ConfigError: Unknown track, bad agents, bad runs_scale (before any simulation).
    """
    if not (isinstance(runs_scale, int | float) and math.isfinite(runs_scale)
            and runs_scale > 0):
        raise ConfigError(f"runs_scale must be a number > 0, got {runs_scale!r}",
                          field="runs_scale")
    chosen = select_tracks(tracks) + [population_track(p) for p in populations]
    configs = [track_config(t, agents, runs_scale=runs_scale, seed=seed, jobs=jobs,
                            executor=executor) for t in chosen]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ranked = [a for a in agents if a not in REFERENCE_AGENTS]
    doc: dict[str, Any] = {"suite_version": SUITE_VERSION, "seed": seed,
                           "runs_scale": runs_scale, "agents": ranked,
                           "converged_threshold": CONVERGED,
                           "references": dict(REFERENCES), "tracks": {}}
    walls: dict[str, float] = {}
    t0 = time.perf_counter()
    iterator: Any = zip(chosen, configs, strict=True)
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(list(iterator), desc="suite", unit="track")
    failures: dict[str, dict[str, str]] = {}
    recorder = SuiteRecorder(seed, runs_scale)  # results.json (hri_bench/submission.py)
    for track, cfg in iterator:
        t = time.perf_counter()
        result = run_study(cfg, keep_going=True)
        if result.failures:
            failures[track.name] = result.failures
        entry = track_summary(track, result)
        recorder.add(track, result)
        doc["tracks"][track.name] = entry
        track_figure(track.name, entry, out / f"{track.name}.png")
        walls[track.name] = round(time.perf_counter() - t, 2)
    errors = out / ERRORS_LOG
    if failures:
        with atomic_writer(errors) as f:
            for track_name, by_agent in failures.items():
                for agent, text in by_agent.items():
                    f.write(f"track {track_name}: agent {agent!r} raised:\n{text}\n")
    else:
        errors.unlink(missing_ok=True)  # from an earlier suite in the same folder
    results = recorder.document()
    doc["provenance"] = {"software": provenance.software(),
                         "agents": {a: provenance.agent_identity(a) for a in agents}}
    lead = "" if results is None else lead_section(results) + "\n" + task_section(results)
    with atomic_writer(out / "leaderboard.md") as f:
        f.write(leaderboard(doc, lead) + "\n")
    recorder.write(out, results)
    with atomic_writer(out / "suite.json") as f:
        f.write(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    log = {"suite_version": SUITE_VERSION, "jobs": jobs, "executor": executor,
           "wall_time_s": round(time.perf_counter() - t0, 2), "tracks_wall_time_s": walls,
           "load_average": list(os.getloadavg()), "cpus": os.cpu_count()}
    with atomic_writer(out / "suite_log.json") as f:
        f.write(json.dumps(log, indent=1) + "\n")
    return doc
