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
value per episode. See docs/benchmark.md, "Suite". The track summaries and the leaderboards'
text are :mod:`hri_bench.suite.leaderboards`'s.
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

from hri_bench.core.atomic import atomic_writer
from hri_bench.run import provenance
from hri_bench.run.agents import PLANNING_REFERENCES, REFERENCE_AGENTS, agent_privilege
from hri_bench.run.regret import ALL_REFERENCES, REFERENCES
from hri_bench.run.study import (
    UnitLostError,
    run_study,
    study_units,
)
from hri_bench.suite.leaderboards import (
    CONVERGED,
    leaderboard,
    leaderboard_v2,
    leaderboard_v3,
    leaderboard_v4,
    track_summary,
    track_summary_v2,
    track_summary_v3,
)
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
    population_track,
    select_tracks,
    track_config,
)
from hri_envs.errors import ConfigError

__all__ = ["ERRORS_LOG", "axis_range", "run_suite", "track_figure"]

#: Where the tracebacks of agents that raised go (in the suite's folder).
ERRORS_LOG = "errors.log"


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
    _check_runs_scale(runs_scale)
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
    _write_log(out, {"suite_version": version, "jobs": jobs, "executor": executor}, t0, walls,
               plan)
    store.finish()
    return doc


def _check_runs_scale(runs_scale: Any) -> None:
    """Raise ConfigError unless ``runs_scale`` is a finite number > 0."""
    if not (isinstance(runs_scale, int | float) and math.isfinite(runs_scale)
            and runs_scale > 0):
        raise ConfigError(f"runs_scale must be a number > 0, got {runs_scale!r}",
                          field="runs_scale")


def _write_log(out: Path, how: dict[str, Any], t0: float, walls: Any, plan: Any) -> None:
    """Write ``suite_log.json``: how the suite was run (``how``), the wall times since
    ``t0`` and of each track, the load, the cores and the suite's plan.
    """
    log = {**how, "wall_time_s": round(time.perf_counter() - t0, 2), "tracks_wall_time_s": walls,
           "load_average": list(os.getloadavg()), "cpus": os.cpu_count(), "plan": plan}
    with atomic_writer(out / SUITE_LOG) as f:
        f.write(json.dumps(log, indent=1) + "\n")


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
            units = study_units(cfg)

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
