"""``hri-bench``: reproduce the paper's studies and figures, measure speed, play the human.

Subcommands (after any ``--import MODULE``, which imports your own registrations first)::

    hri-bench study {hanger,wheel} --out DIR [options]   one study: summary, CSV, plots
    hri-bench figures --out DIR [--runs N] [--jobs J]     the paper's figures (Figs. 4, 8, 10-12)
    hri-bench speed [--json]                              env and Learner throughput
    hri-bench play {hanger,wheel}                         you are the human, in the terminal
    hri-bench serve {hanger,wheel} [--data DIR]           you are the human, in a browser
    hri-bench dataset list|show|export|record|fit ...     recorded sessions (docs/people.md)
    hri-bench replay DATASET [--participant P]            a recorded session, step by step
    hri-bench demo --out DIR                              the main job of ``make demo``

Bad arguments exit with code 2 and a message naming the argument and what is allowed.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from agents.config import default_config
from agents.learning import algorithm1, partner_mdp
from hri_bench.cli import people as cli_people
from hri_bench.cli import physical as cli_physical
from hri_bench.cli import results as cli_results
from hri_bench.cli.args import as_flags, bounded, resume_hint, split_imports, whole
from hri_bench.people.play import play
from hri_bench.report.speed import measure, measure_physics
from hri_bench.run.agents import (
    AGENTS,
    DEFAULT_STUDY_AGENTS,
    SB3_PREFIX,
    jaxppo_path,
    validate_agent_name,
)
from hri_bench.run.humans import population_changes
from hri_bench.run.regret import REFERENCES
from hri_bench.run.study import (
    EXECUTION_FIELDS,
    EXECUTORS,
    UNIT_TIME_LIMIT,
    StudyConfig,
    UnitLostError,
    graph_for,
)
from hri_bench.run.studyio import UNITS, StudyDir, StudyTerminated, run_in, stop_on_signals
from hri_bench.suite import (
    DEFAULT_AGENTS,
    DEFAULT_AGENTS_V2,
    DEFAULT_AGENTS_V3,
    LATEST,
    SUITE_VERSIONS,
    default_agents,
    population_track,
    run_suite,
    select_tracks,
    track_config,
)
from hri_bench.suite.resume import STATE, SuiteDir, suite_plan
from hri_bench.suite.submission import read_json
from hri_envs.envs.backends import BACKENDS, check_backend
from hri_envs.errors import (
    BackendUnavailableError,
    ConfigError,
    LearnerStateError,
    MissingExtraError,
)
from hri_envs.humans.families import FAMILIES
from hri_envs.humans.populations import POPULATIONS
from hri_envs.humans.splits import MIXTURES
from hri_envs.imports import PLUGIN_GROUP, import_modules, imported_modules, load_plugins
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.scenarios import SCENARIOS, scenario_graph

__all__ = ["build_parser", "main"]

#: Every schedule name: "random" and the scenarios' fixed schedules.
_SCHEDULES = ("random", *dict.fromkeys(k for s in SCENARIOS.values() for k in s.schedules))


def _human_param(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"give NAME=VALUE (e.g. k=3), got {text!r}")
    return name.strip(), value.strip()


def _agents(text: str) -> tuple[str, ...]:
    names = tuple(a.strip() for a in text.split(",") if a.strip())
    if not names:
        raise argparse.ArgumentTypeError("give at least one agent")
    for n in names:
        try:
            validate_agent_name(n)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc
    return names


_positive = bounded(int, "a whole number >= 1", lambda v: v >= 1)


def _world_counts(text: str) -> tuple[int, ...]:
    """``--physics-worlds``: comma-separated whole numbers >= 1."""
    return tuple(_positive(w.strip()) for w in text.split(","))


_seed = whole
_seconds = bounded(float, "a number of seconds > 0, or inf", lambda v: v > 0)
_probability = bounded(float, "a probability in [0, 1]", lambda v: 0.0 <= v <= 1.0)
_r0 = bounded(float, "a number in (-1, 0)", lambda v: -1.0 < v < 0.0)
_rationality = bounded(float, "a number > 0 or inf", lambda v: v > 0)

#: ``--learner-*`` options: LearnerConfig field -> (flag, metavar, help). Values are checked
#: by :class:`agents.config.LearnerConfig`; its errors name the flag.
_LEARNER_FLAGS: dict[str, tuple[str, type, str]] = {
    "beta": ("--learner-beta", float, "β, intention bias of the Bayes filter, in (0, 1]"),
    "robot_temperature": ("--learner-robot-temperature", float, "τ_R of the robot's soft-max"),
    "human_temperature": ("--learner-human-temperature", float, "τ_H of the human estimate"),
    "eta": ("--learner-eta", float, "η, the robot's relative probability bound, in [0, 1]"),
    "learning_rate": ("--learner-learning-rate", float, "λ, the ME-IRL step size"),
    "gamma": ("--learner-gamma", float, "γ of every Q-iteration, in [0, 1)"),
    "r0": ("--learner-r0", float, "r0 in the Learner's robot reward (default: --r0)"),
    "initial_preference": ("--learner-initial-preference", str,
                           "start the human model from this preference (paper Sect. 7)"),
}

#: The ``study`` argument each :class:`~hri_bench.run.study.StudyConfig` field comes from
#: (a :class:`~hri_envs.errors.ConfigError` names the field in its ``field`` attribute).
_STUDY_ARGUMENTS = {
    "scenario": "scenario",
    "agents": "--agents",
    "runs": "--runs",
    "episodes": "--episodes",
    "schedule": "--schedule",
    "preference": "--preference",
    "r0": "--r0",
    "human_passive": "--human-passive",
    "turn_back": "--turn-back",
    "seed": "--seed",
    "jobs": "--jobs",
    "executor": "--executor",
    "ray_address": "--ray-address",
    "backend": "--backend",
    "max_steps": "--max-steps",
    "human_rationality": "--human-rationality",
    "population": "--population",
    "human_drift": "--human-drift",
    "reward": "--reward",
    "physics_preset": "--physics-preset",
    "human_params": "--human-param",
    "unit_time_limit": "--unit-time-limit",
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="hri-bench",
        description="Benchmark cooperative learners on the paper's human-robot carrying studies.",
    )
    parser.add_argument("--import", dest="imports", action="append", default=[],
                        metavar="MODULE",
                        help="import MODULE first, so that the scenarios, families, reward "
                             "rules and agents it registers count (repeatable; before the "
                             "command; recorded in summary.json and suite.json, so that "
                             "--config replays it); installed packages' entry points of the "
                             f"group {PLUGIN_GROUP!r} are imported too (docs/extending.md)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _study_parser(sub)
    _figures_parser(sub)
    _speed_parser(sub)
    _play_parser(sub)
    _suite_parser(sub)
    cli_results.add_parsers(sub)
    cli_people.add_parsers(sub)
    _demo_parser(sub)
    return parser


def _study_parser(sub: Any) -> None:
    """The ``study`` command (docs/benchmark.md, "hri-bench study")."""
    study = sub.add_parser("study", help="run one study and write summary.json, CSV and plots",
                           description="Run one study: several agents, many independent runs.")
    _study_task_flags(study)
    _study_run_flags(study)
    _study_human_flags(study)
    _study_learner_flags(study)
    _study_output_flags(study)
    study.set_defaults(command_parser=study)  # reports errors found after parsing


def _study_task_flags(study: argparse.ArgumentParser) -> None:
    """The task: scenario, agents, runs, episodes, schedule, the scripted human."""
    study.add_argument("scenario", choices=SCENARIOS, nargs="?",
                       help="the task (may be left out with --config)")
    study.add_argument("--agents", type=_agents, default=DEFAULT_STUDY_AGENTS,
                       help="comma-separated, from " + ",".join(AGENTS) + ", sb3:PATH, "
                            "jaxppo[:PATH] or module:Class (default: the paper's "
                            + ",".join(DEFAULT_STUDY_AGENTS) + ")")
    study.add_argument("--runs", type=_positive, default=100, help="runs per agent (default 100)")
    study.add_argument("--episodes", type=_positive, default=None,
                       help="episodes per run (default: "
                            + ", ".join(f"{n} {s.episodes}" for n, s in SCENARIOS.items())
                            + "".join(f", {n} {k} {len(rows)}" for n, s in SCENARIOS.items()
                                      for k, rows in s.schedules.items()) + ")")
    study.add_argument("--schedule", choices=_SCHEDULES, default="random",
                       help="random start/goal per episode, or a fixed one ("
                            + ", ".join(f"{k}: the {n}'s" for n, s in SCENARIOS.items()
                                        for k in s.schedules) + ", the user study's Table 2)")
    study.add_argument("--preference", default=None,
                       help="the scripted human's preference ("
                            + "; ".join(f"{n}: {', '.join(s.preferences[:2])}"
                                        + (", ..." if len(s.preferences) > 2 else "")
                                        for n, s in SCENARIOS.items())
                            + "; 'all' cycles over all; default: "
                            + ", ".join(f"{n} {s.default_preference}"
                                        for n, s in SCENARIOS.items()) + ")")
    study.add_argument("--r0", type=_r0, default=None,
                       help="robot reward for waiting while the human acts, in (-1, 0) "
                            "(default: "
                            + ", ".join(f"{n} {s.r0}" for n, s in SCENARIOS.items()) + ")")
    study.add_argument("--human-passive", type=_probability, default=0.0,
                       help="probability that the human waits in a step (default 0)")
    study.add_argument("--turn-back", type=_probability, default=0.0,
                       help="probability per episode that the human turns back halfway")


def _study_run_flags(study: argparse.ArgumentParser) -> None:
    """Seed, execution, backend, step limit and reward rule."""
    study.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    study.add_argument("--jobs", type=_positive, default=1, help="parallel workers (default 1)")
    study.add_argument("--executor", choices=EXECUTORS, default=None,
                       help="serial, process (default when --jobs > 1) or ray")
    study.add_argument("--ray-address", default=None, help="Ray cluster address (executor ray)")
    _time_limit_flag(study)
    study.add_argument("--backend", choices=BACKENDS, default="graph",
                       help="graph (abstract task graph), mujoco (simulated Panda, MuJoCo's C "
                            "library, one run at a time; slow: about 0.2 s per step) or mjwarp "
                            "(the same physics on MuJoCo Warp, every run of a unit in its own "
                            "world at once; the 'mjwarp' extra; docs/physics.md)")
    study.add_argument("--physics-preset", default=None,
                       help="named physics options of the backend (mujoco: "
                            + ", ".join(BACKENDS["mujoco"].presets) + "; docs/physics.md)")
    study.add_argument("--max-steps", type=_positive, default=100,
                       help="step limit per episode (default 100)")
    study.add_argument("--reward", choices=tuple(REWARD_RULES), default="paper",
                       help="reward rule (default paper): "
                            + "; ".join(f"{n}: {r.description}" for n, r in REWARD_RULES.items()))


def _time_limit_flag(parser: argparse.ArgumentParser) -> None:
    """``--unit-time-limit`` (``study`` and ``suite``)."""
    parser.add_argument("--unit-time-limit", type=_seconds, default=None,
                        metavar="S",
                        help="the most wall seconds one unit of work (an agent's chunk of "
                             "runs: at most 1,000 episodes, or one run on mujoco) may take; "
                             "a unit over it, like a worker process that dies, stops the "
                             "study with an error naming it, its finished units kept for "
                             f"--resume (default {UNIT_TIME_LIMIT:g}, none on mjwarp, whose "
                             "speed is its device's; inf: no limit)")


def _study_human_flags(study: argparse.ArgumentParser) -> None:
    """Humans other than the scripted one: Boltzmann, a population, a drift."""
    study.add_argument("--human-rationality", type=_rationality, default=float("inf"),
                       metavar="BETA",
                       help="Boltzmann human: samples softmax(BETA * Q_pref) (docs/benchmark.md);"
                            " inf (default) = the deterministic scripted human")
    study.add_argument("--population", default=None, metavar="NAME",
                       help="draw each run's human from a population: "
                            + ", ".join(f"{n}{' (held out)' if p.held_out else ''}"
                                        for n, p in POPULATIONS.items())
                            + "; a split or a part of one ("
                            + ", ".join(dict.fromkeys(n for n, _ in MIXTURES)) + "); a family ("
                            + ", ".join(FAMILIES) + "); recorded:DATASET or "
                            "recorded-irl:DATASET (a model fitted to recorded sessions); "
                            "module:Class (your own)")
    study.add_argument("--human-param", type=_human_param, action="append", default=None,
                       dest="human_params", metavar="NAME=VALUE",
                       help="a parameter of the family given as --population (repeatable), "
                            "e.g. --population impatient --human-param k=3")
    study.add_argument("--human-drift", type=_positive, default=None, metavar="K",
                       help="the human switches to another preference after K episodes")


def _study_learner_flags(study: argparse.ArgumentParser) -> None:
    """The ``--learner-*`` changes to the Learner's configuration."""
    for field_name, (flag, kind, text) in _LEARNER_FLAGS.items():
        study.add_argument(flag, type=kind, default=None, dest=f"learner_{field_name}",
                           metavar="P" if kind is str else "X", help=text)
    study.add_argument("--learner-no-passive-prior", action="store_true",
                       help="the Learner's bounded soft-max without the passive baseline "
                            "(paper Sect. 7)")


def _study_output_flags(study: argparse.ArgumentParser) -> None:
    """Where the study goes, and replaying or resuming one."""
    study.add_argument("--out", required=True, type=Path,
                       help="output directory (new or empty, unless --resume or --overwrite)")
    study.add_argument("--resume", action="store_true",
                       help="continue the interrupted study in --out (same settings and --jobs)")
    study.add_argument("--overwrite", action="store_true",
                       help="start afresh in a non-empty --out (replaces the study's files)")
    study.add_argument("--config", type=Path, default=None,
                       help="re-run the study a summary.json describes (its 'settings'); "
                            "only --out, --jobs, --executor, --ray-address, --resume, "
                            "--overwrite and --no-progress may be given with it")
    study.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def _figures_parser(sub: Any) -> None:
    """The ``figures`` command."""
    figs = sub.add_parser("figures", help="reproduce the paper's figures as PNGs",
                          description="Run the studies behind Figs. 4, 8, 10a-c, 11 and 12.")
    figs.add_argument("--out", required=True, type=Path, help="output directory")
    figs.add_argument("--runs", type=_positive, default=100, help="runs per study (default 100)")
    figs.add_argument("--jobs", type=_positive, default=1, help="worker processes (default 1)")
    figs.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    figs.add_argument("--only", default=None,
                      help="comma-separated subset of fig10a,fig10b,fig10c,fig11,fig12,fig8,fig4")
    figs.add_argument("--wheel-episodes", type=_positive, default=20,
                      help="episodes per wheel run (default 20)")


def _speed_parser(sub: Any) -> None:
    """The ``speed`` command."""
    speed = sub.add_parser("speed", help="measure env and Learner throughput",
                           description="Measure parallel_env_steps_per_s, vector_env_steps_per_s "
                                       "(1024 envs), learner_update_ms (wheel) and "
                                       "learner_update_batched_ms_per_run (100 runs), "
                                       "hanger_study_s (9 preferences x 100 runs x 8 episodes, "
                                       "Learner only) and machine_ms (a fixed numpy workload "
                                       "to compare machines by).")
    speed.add_argument("--json", action="store_true", help="end with one JSON line")
    speed.add_argument("--jobs", type=_positive, default=1,
                       help="worker processes for the hanger study (default 1)")
    speed.add_argument("--size", choices=("full", "tiny"), default="full",
                       help="full: the published figures (default); tiny: a smoke test in "
                            "seconds whose figures are not comparable")
    speed.add_argument("--no-jax", action="store_true",
                       help="skip the JAX env and PPO training figures (measured when the "
                            "jax extra is installed)")
    speed.add_argument("--physics", action="store_true",
                       help="add the physics figures (not in the default run: minutes on a "
                            "CPU): world-steps/s and real-time factor of MuJoCo Warp for 1, "
                            "64, 1,024 and 4,096 worlds on Warp's device (named), beside "
                            "MuJoCo's C library; the first run on a machine also compiles "
                            "Warp's kernels (about 1.5 min, then cached)")
    speed.add_argument("--physics-worlds", type=_world_counts, default=None,
                       help="comma-separated numbers of worlds for --physics (default "
                            "1,64,1024,4096)")


def _play_parser(sub: Any) -> None:
    """The ``play`` command."""
    game = sub.add_parser(
        "play", help="play the human in the terminal against the Learner",
        description="You are the human, the Learner is the robot and learns between "
                    "episodes. Each step shows the state, the robot's belief over your goal "
                    "and the action it chose, and lists your valid actions numbered from 1 "
                    "(as the keys of hri-bench serve's page); type a number, or q to stop "
                    "(the end of input, Ctrl-D, stops too). Your goal is yours alone: choose "
                    "a support and carry the object there.")
    game.add_argument("scenario", choices=SCENARIOS, help="the task")
    game.add_argument("--episodes", type=_positive, default=3,
                      help="episodes to play, each from a random start support (default 3)")
    game.add_argument("--seed", type=_seed, default=0,
                      help="seed of the starts and of the robot, >= 0 (default 0)")


def _demo_parser(sub: Any) -> None:
    """The ``demo`` command (``make demo``)."""
    demo = sub.add_parser(
        "demo", help="the main job (make demo): the paper's figures at full size, then what next",
        description="The main job of make demo: the studies behind the paper's figures that "
                    "hri-bench figures draws (Figs. 4, 8, 10a-c, 11 and 12) at full size, 100 "
                    "runs per study and 20 wheel episodes (hri-bench figures --runs 100), "
                    "written as PNGs into --out; then the commands to try next. The first run "
                    "after installing also compiles the Learner's kernels (about a minute, "
                    "once). Fig. 6 needs the physics: examples/physics_table2.py.")
    demo.add_argument("--out", type=Path, default=Path("out/demo"),
                      help="output directory (default out/demo)")
    demo.add_argument("--jobs", type=_positive, default=2,
                      help="worker processes (default 2)")


def _suite_parser(sub: Any) -> None:
    """The ``suite`` command's flags (docs/benchmark.md, "Suite")."""
    suite = sub.add_parser("suite", help="run the versioned benchmark suite and a leaderboard",
                           description="Run every track of the benchmark suite (one study "
                           "each) and write suite.json, leaderboard.md and one figure per "
                           "track.")
    suite.add_argument("--out", required=True, type=Path,
                       help="output directory (new or empty, unless --resume or --overwrite)")
    suite.add_argument("--physical", action="store_true",
                       help="the physical suite instead (robots that feel the human on the "
                            "continuous envs; its flags: hri-bench suite --physical --help)")
    suite.add_argument("--resume", action="store_true",
                       help="continue the suite interrupted in --out (same settings): tracks "
                            "and units already finished are not run again")
    suite.add_argument("--overwrite", action="store_true",
                       help="start afresh in a non-empty --out (removes only the suite's own "
                            "files: its outputs, every track's figure, seed-S folders)")
    suite.add_argument("--suite-version", choices=SUITE_VERSIONS, default=LATEST,
                       help=f"the track set (default {LATEST}: the test split v2's four groups "
                            "of humans as headline tracks, normalised to the reachable "
                            "reference; 2: the test split with a reference or bracket on every "
                            "track; 1: the first ten tracks; 1 and 2 as they were)")
    suite.add_argument("--jobs", type=_positive, default=1,
                       help="parallel workers per track (default 1)")
    suite.add_argument("--agents", type=_agents, default=None,
                       help="agents to rank, comma-separated, e.g. learner,mypkg.mod:MyAgent "
                            f"(default v3: {','.join(DEFAULT_AGENTS_V3)}; v2: "
                            f"{','.join(DEFAULT_AGENTS_V2)}; v1: {','.join(DEFAULT_AGENTS)}; "
                            "the references and the floor are added where they fit)")
    suite.add_argument("--executor", choices=EXECUTORS, default=None,
                       help="serial, process (default with --jobs > 1) or ray")
    suite.add_argument("--runs-scale", type=bounded(float, "a number > 0",
                                                     lambda v: math.isfinite(v) and v > 0),
                       default=1.0, help="multiply every track's runs (default 1)")
    suite.add_argument("--tracks", default=None,
                       help="comma-separated track names (default: all)")
    suite.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    suite.add_argument("--population", action="append", default=[], metavar="NAME",
                       help="add a track of its own on a recorded population "
                            "(recorded:DATASET or recorded-irl:DATASET; repeatable)")
    _time_limit_flag(suite)
    suite.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    cli_results.add_suite_flags(suite)  # --config, --seeds (docs/results.md)
    suite.set_defaults(command_parser=suite)


def _suite(args: argparse.Namespace, parser: argparse.ArgumentParser,
           argv: Sequence[str]) -> int:
    seeds = cli_results.suite_plan(args, parser)  # --config replays, --seeds
    executor = args.executor or ("process" if args.jobs > 1 else "serial")
    version = args.suite_version
    agents = args.agents or default_agents(version)
    try:
        tracks = select_tracks(args.tracks, version)
        first = track_config(tracks[0], agents, executor=executor, version=version)
        _require_for_study(first, progress=not args.no_progress)  # before simulating
        for name in args.population:
            track_config(population_track(name, version), agents, executor=executor,
                         version=version)
    except ConfigError as exc:
        _config_error(parser, exc, _SUITE_ARGUMENTS)
    plan = suite_plan(version, agents, [t.name for t in tracks], args.population,
                      args.runs_scale, seeds)
    t0 = time.perf_counter()

    def one(out: Path, seed: int) -> dict[str, Any]:
        return run_suite(out, agents=agents, tracks=args.tracks, version=version,
                         runs_scale=args.runs_scale, seed=seed, jobs=args.jobs,
                         executor=executor, progress=not args.no_progress,
                         populations=args.population, resume=args.resume,
                         unit_time_limit=args.unit_time_limit, imports=imported_modules())

    try:
        with stop_on_signals():  # from the lock on: Ctrl-C keeps the finished work
            try:
                folder = SuiteDir(args.out, plan, resume=args.resume, overwrite=args.overwrite)
            except ConfigError as exc:
                _config_error(parser, exc, _SUITE_ARGUMENTS)
            with folder:
                if folder.complete:
                    print(f"nothing to do: the suite in {args.out} is complete (suite.json, "
                          "results.json, leaderboard.md and the figures are in place)")
                    return 0
                docs = cli_results.run_suites(args, seeds, one, plan)
    except ConfigError as exc:  # a seed's folder of another suite (--resume)
        _config_error(parser, exc, _SUITE_ARGUMENTS)
    except KeyboardInterrupt as exc:
        print(f"\nstopped; {_suite_kept(args.out)}. Resume with:\n  {resume_hint(argv)}",
              file=sys.stderr)
        return 143 if isinstance(exc, StudyTerminated) else 130
    except UnitLostError as exc:
        print(f"hri-bench: suite stopped: {as_flags(str(exc), _STUDY_ARGUMENTS)}; "
              f"{_suite_kept(args.out)}; continue with: "
              f"{resume_hint(argv)}", file=sys.stderr)
        return 1
    except OSError as exc:
        return _cannot_write(exc, args.out, argv, kept="the finished tracks and units are kept")
    doc = docs[0]
    times = f" × {len(docs)} seeds" if len(docs) > 1 else ""
    print(f"suite v{doc['suite_version']}: {len(doc['tracks'])} tracks{times} in "
          f"{time.perf_counter() - t0:.1f} s (--jobs {args.jobs}, {executor})")
    print(f"wrote {args.out / 'suite.json'}, {args.out / 'results.json'}, "
          f"{args.out / 'leaderboard.md'} and one figure per track")
    board = args.out / "leaderboard.md"
    print(f"\nThe ranking, from the top of {board}:\n\n"
          + ranking_excerpt(board.read_text(encoding="utf-8")))
    failed = sorted({a for d in docs for tr in d["tracks"].values() for a in tr["failed_agents"]})
    if failed:
        print(f"agent(s) {', '.join(failed)} raised; no results for them on the tracks where "
              f"they did; tracebacks in {args.out / 'errors.log'}", file=sys.stderr)
        return 1
    return 0


def ranking_excerpt(leaderboard: str) -> str:
    """The ranking at the top of a ``leaderboard.md``: its first table (suite v3 and v4: the
    ranked agents; v1 and v2: the overview across tracks) and, where a section of references
    follows it (v4), that section's heading and table.
    """
    lines = leaderboard.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith("|")), len(lines))
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")),
               len(lines))
    out = lines[start:end]
    heading = next((i for i in range(end, len(lines)) if lines[i].startswith("#")), None)
    if heading is not None and "reference" in lines[heading].lower():
        first = next((i for i in range(heading, len(lines)) if lines[i].startswith("|")),
                     len(lines))
        last = next((i for i in range(first, len(lines)) if not lines[i].startswith("|")),
                    len(lines))
        out += ["", lines[heading].lstrip("# "), "", *lines[first:last]]
    return "\n".join(out)


def _suite_kept(out: Path) -> str:
    """What an interrupted suite keeps in ``out`` (and its seeds' folders), in words."""
    states = [p for p in Path(out).glob(f"**/{STATE}") if p.is_dir()]
    tracks = sum(1 for s in states for p in s.glob("*.json") if p.name != "plan.json")
    units = sum(1 for s in states for _ in s.glob("*/*.npz"))
    return (f"{tracks} finished track(s) and {units} finished unit(s) kept in "
            f"{Path(out) / STATE}")


#: The ``suite`` argument a :class:`ConfigError`'s field comes from (a track's runs are
#: its own times ``--runs-scale``).
_SUITE_ARGUMENTS = {"tracks": "--tracks", "agents": "--agents", "runs": "--runs-scale",
                    "population": "--population",
                    "seed": "--seed", "jobs": "--jobs", "out": "--out",
                    "suite_version": "--suite-version"}


def _config_error(parser: argparse.ArgumentParser, exc: ConfigError,
                  arguments: dict[str, str]) -> None:
    """Exit with status 2 like argparse does, naming the argument the bad field came from;
    a backend whose extra is missing is reported by :func:`main` in one line (status 1).
    """
    if isinstance(exc, BackendUnavailableError):
        raise exc
    argument = arguments.get(exc.field or "")
    text = as_flags(str(exc), arguments)
    parser.error(f"argument {argument}: {text}" if argument else text)


def _learner_changes(args: argparse.Namespace, parser: argparse.ArgumentParser
                     ) -> dict[str, Any]:
    """The ``--learner-*`` flags given, checked against the scenario's LearnerConfig."""
    learner: dict[str, Any] = {f: getattr(args, f"learner_{f}") for f in _LEARNER_FLAGS
                               if getattr(args, f"learner_{f}") is not None}
    if args.learner_no_passive_prior:
        learner["passive_prior"] = False
    try:
        default_config(args.scenario, **learner)
    except ConfigError as exc:
        flags = {f: flag for f, (flag, _, _) in _LEARNER_FLAGS.items()}
        _config_error(parser, exc, {**flags, "passive_prior": "--learner-no-passive-prior"})
    return learner


def _study_config(args: argparse.Namespace, parser: argparse.ArgumentParser,
                  executor: str) -> Any:
    """The :class:`StudyConfig` from the flags, or from ``--config`` (a summary.json)."""
    execution = {"jobs": args.jobs, "executor": executor, "ray_address": args.ray_address,
                 "unit_time_limit": args.unit_time_limit}
    if args.config is None:
        if args.scenario is None:
            parser.error("the following arguments are required: scenario (or --config)")
        learner = _learner_changes(args, parser)
        return StudyConfig(
            args.scenario, agents=args.agents, runs=args.runs, episodes=args.episodes,
            schedule=args.schedule, preference=args.preference, r0=args.r0,
            human_passive=args.human_passive, turn_back=args.turn_back, seed=args.seed,
            backend=args.backend, max_steps=args.max_steps,
            human_rationality=args.human_rationality, population=args.population,
            human_drift=args.human_drift, learner=tuple(sorted(learner.items())),
            reward=args.reward, physics_preset=args.physics_preset,
            human_params=tuple(args.human_params or ()), imports=imported_modules(),
            **execution,
        )
    given = [flag for field, flag in _STUDY_ARGUMENTS.items()
             if field not in EXECUTION_FIELDS and field != "scenario"
             and getattr(args, field) != parser.get_default(field)]
    given += [flag for field, (flag, _, _) in _LEARNER_FLAGS.items()
              if getattr(args, f"learner_{field}") is not None]
    given += ["--learner-no-passive-prior"] * bool(args.learner_no_passive_prior)
    if given:
        parser.error(f"argument --config: it replays the recorded settings; drop "
                     f"{', '.join(given)} (or edit the file's 'settings')")
    doc = _read_study_config(args.config, parser)
    settings = dict(doc["settings"])
    if args.scenario is not None and args.scenario != settings.get("scenario"):
        parser.error(f"argument scenario: {args.config} describes a "
                     f"{settings.get('scenario')!r} study; leave the scenario out")
    try:
        cfg = StudyConfig.from_settings(settings, **execution)
        # a custom agent edited since: from the document read above (once, within the limit)
        cli_results.warn_code_changes(doc.get("agent_configs"), cfg.agents)
        for line in population_changes(doc.get("population_info"), cfg.population_info()):
            print(f"hri-bench study: warning: {line}", file=sys.stderr)  # recordings changed
        return cfg
    except ConfigError as exc:
        if exc.field in EXECUTION_FIELDS:  # from the flags, not from the file
            raise
        parser.error(f"argument --config: {args.config}: {exc} (in its 'settings')")


#: The largest ``--config`` file read (a summary.json of 10,000 episodes has a few MB).
MAX_CONFIG_BYTES = 64 * 2**20


def _read_study_config(path: Path, parser: argparse.ArgumentParser) -> dict[str, Any]:
    """A summary.json given as ``--config``, with a ``settings`` object; exit 2 otherwise.

    Read with :func:`hri_bench.suite.submission.read_json`: a regular file of at most
    :data:`MAX_CONFIG_BYTES` (``/dev/zero`` and a FIFO are refused, not read), not nested
    too deeply, without a key twice in an object.
    """
    def refuse(why: str) -> NoReturn:
        parser.error(f"argument --config: {why}; give the summary.json of an hri-bench "
                     "study (it has a 'settings' object)")

    try:
        doc = read_json(path, max_bytes=MAX_CONFIG_BYTES, what="summary.json", constants=True)
    except ConfigError as exc:
        refuse(str(exc))
    if not isinstance(doc, dict) or not isinstance(doc.get("settings"), dict):
        refuse(f"{path}: no 'settings' object")
    return doc


def _require_for_study(cfg: Any, *, progress: bool) -> None:
    """Fail before any simulation if an extra the study will need is missing, or an
    ``sb3:`` model or ``jaxppo:`` checkpoint cannot be loaded (a :class:`ConfigError` with
    ``field="agents"``).
    """
    check_backend(cfg.backend)
    MissingExtraError.require(["matplotlib", *(["tqdm"] if progress else [])],
                              "writing a study's plots")
    if cfg.executor == "ray":
        MissingExtraError.require(["ray"], "executor 'ray'")
    if any(a.startswith(SB3_PREFIX) for a in cfg.agents):
        MissingExtraError.require(["stable_baselines3", "sb3_contrib", "torch"],
                                  "an 'sb3:' agent")
        from agents.sb3 import SB3BatchAgent  # torch: the rl extra, only for an sb3: agent

        for name in cfg.agents:  # a model that cannot be loaded is bad input: exit 2
            if name.startswith(SB3_PREFIX):
                try:
                    SB3BatchAgent(name[len(SB3_PREFIX):], 1, graph=graph_for(cfg.scenario))
                except ConfigError as exc:
                    raise ConfigError(f"agent {name!r}: {exc}", field="agents") from None
    if any(jaxppo_path(a) is not None for a in cfg.agents):
        MissingExtraError.require(["jax", "optax"], "a 'jaxppo' agent")
        from agents.jax_ppo.agent import load_checked  # jax: the jax extra, only for jaxppo

        for name in cfg.agents:  # a checkpoint that cannot be loaded is bad input: exit 2
            path = jaxppo_path(name)
            if path is not None:
                try:
                    load_checked(path, graph_for(cfg.scenario))
                except (ConfigError, LearnerStateError) as exc:
                    raise ConfigError(f"agent {name!r}: {exc}", field="agents") from None


def _study(args: argparse.Namespace, parser: argparse.ArgumentParser,
           argv: Sequence[str]) -> int:
    executor = args.executor or ("process" if args.jobs > 1 else "serial")
    arguments = {**_STUDY_ARGUMENTS, "out": "--out", "resume": "--resume"}
    try:
        cfg = _study_config(args, parser, executor)
        _require_for_study(cfg, progress=not args.no_progress)
    except ConfigError as exc:
        _config_error(parser, exc, arguments)
    try:
        # From the lock on: the folder's checks remove a killed study's leftovers.
        with stop_on_signals():
            try:
                folder = StudyDir(args.out, cfg, resume=args.resume, overwrite=args.overwrite)
            except ConfigError as exc:
                _config_error(parser, exc, arguments)
            with folder:
                run = run_in(folder, progress=not args.no_progress)
    except KeyboardInterrupt as exc:
        units = Path(args.out) / UNITS
        kept = len(list(units.glob("*.npz")))
        print(f"\nstopped; {kept} finished unit(s) kept in {units}. Resume with:\n"
              f"  {resume_hint(argv)}", file=sys.stderr)
        return 143 if isinstance(exc, StudyTerminated) else 130
    except UnitLostError as exc:
        kept = len(list((Path(args.out) / UNITS).glob("*.npz")))
        print(f"hri-bench: study stopped: {as_flags(str(exc), _STUDY_ARGUMENTS)}; {kept} "
              f"finished unit(s) kept in "
              f"{Path(args.out) / UNITS}; continue with: {resume_hint(argv)}",
              file=sys.stderr)
        return 1
    except OSError as exc:
        return _cannot_write(exc, args.out, argv)
    if run.result is None:
        print(f"nothing to do: the study in {args.out} is complete (summary.json, episodes.csv "
              "and the plots are in place)")
        return 0
    _print_study(run.result, Path(args.out), run.paths)
    if run.errors is not None:
        print(f"agent(s) {', '.join(run.result.failures)} raised; no results for them; "
              f"tracebacks in {run.errors}", file=sys.stderr)
        return 1
    return 0


def _cannot_write(exc: OSError, out: Path, argv: Sequence[str], *,
                  kept: str = "the finished units are kept") -> int:
    """Report a file that cannot be written (a full disk, say) in one line; exit status 1."""
    reason = exc.strerror or str(exc)
    print(f"hri-bench: cannot write {exc.filename or out}: {reason}; {kept}; once it can be "
          f"written, continue with: {resume_hint(argv)}", file=sys.stderr)
    return 1


def _print_study(result: Any, out: Path, paths: Sequence[Path]) -> None:
    """The study's table of rewards and regret, and the files written."""
    cfg = result.config
    print(f"{cfg.scenario} study: {len(cfg.agents)} agents x {cfg.runs} runs x "
          f"{cfg.n_episodes} episodes in {result.wall_time_s:.1f} s")
    summary = json.loads((out / "summary.json").read_text())  # its regret
    print(f"  {'agent':12s} {'first':>7s} {'last':>7s} {'mean':>7s} {'median':>7s} "
          f"{'truncated':>9s} {'regret':>7s}")
    for name, m in result.metrics.items():
        r = m["reward"]
        per_episode = summary["agents"][name].get("regret", {}).get("mean")
        regret = "    n/a" if per_episode is None else f"{np.mean(per_episode):7.3f}"
        role = f"  ({REFERENCES[name]})" if name in REFERENCES else ""
        print(f"  {name:12s} {r[:, 0].mean():7.2f} {r[:, -1].mean():7.2f} {r.mean():7.2f} "
              f"{np.median(r):7.2f} {m['truncated'].mean():9.1%} {regret}{role}")
    print(f"  regret vs blind: {summary['regret']}")
    print("wrote " + ", ".join(str(p) for p in paths))


def _figures(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from hri_bench.report.figures import FIGURES, make_figures  # matplotlib: the bench extra

    only = FIGURES if args.only is None else tuple(f.strip() for f in args.only.split(","))
    bad = [f for f in only if f not in FIGURES]
    if bad:
        parser.error(f"--only: unknown figure(s) {', '.join(bad)}; allowed: {', '.join(FIGURES)}")
    t0 = time.perf_counter()
    paths = make_figures(args.out, runs=args.runs, jobs=args.jobs,
                         executor="process" if args.jobs > 1 else "serial", seed=args.seed,
                         only=only, wheel_episodes=args.wheel_episodes,
                         progress=sys.stderr.isatty())
    print(f"figures in {time.perf_counter() - t0:.1f} s: " + ", ".join(str(p) for p in paths))
    return 0


def _speed(args: argparse.Namespace) -> int:
    figures = measure(jobs=args.jobs, size=args.size, jax=not args.no_jax)
    if args.physics:
        figures.update(measure_physics(size=args.size, worlds=args.physics_worlds))
    targets = {"jax": "", "jax_device": "the device JAX ran on",
               "jax_env_envs": "envs stepped together (jit + vmap)",
               "jax_env_steps_per_s": "the vector env's workload, JAX env (jit + vmap)",
               "jax_env_steps_per_s_by_envs": "per number of envs",
               "jax_env_vs_vector_env": "target >= 5 (the vector env of this run)",
               "jax_ppo_train_steps_per_s": "target >= 100,000 (recurrent PPO, end to end)",
               "parallel_env_steps_per_s": "target >= 300,000",
               "vector_env_steps_per_s": "target >= 20,000,000",
               "learner_update_ms": "target <= 0.3",
               "learner_update_batched_ms_per_run": "target <= 0.05",
               "hanger_study_s": "target <= 1", "machine_ms": "the fixed numpy workload",
               "learner_threads": "threads sharing a batched update (HRI_ENVS_THREADS)",
               "physics_c_world_steps_per_s": "MuJoCo's C library, one world (the C backend)",
               "physics_c_realtime_factor": "simulated s per wall s, C backend",
               "continuous_hanger_env_rtf_cpu": "hanger continuous env, simulated s per CPU s",
               "continuous_hanger_raw_rtf_cpu": "raw mj_step of its states, likewise",
               "continuous_hanger_env_over_raw": "env / raw (goal >= 0.5)",
               "continuous_wheel_env_rtf_cpu": "wheel continuous env, simulated s per CPU s",
               "continuous_wheel_raw_rtf_cpu": "raw mj_step of its states, likewise",
               "continuous_wheel_env_over_raw": "env / raw (goal >= 0.5)",
               "physics_warp": "",
               "physics_warp_device": "Warp's device",
               "physics_warp_world_steps_per_s_by_worlds":
                   "per number of worlds; goal >= 1,000,000 on one datacentre GPU",
               "physics_warp_realtime_factor_by_worlds": "all worlds' simulated s per wall s",
               "physics_warp_setup_s": "build, place, first period (compiles once per machine)",
               "physics_warp_kernel_cache": "Warp's kernel cache"}
    for key, value in figures.items():
        shown = f"{value:>14,.4f}" if isinstance(value, float) else f"{value!s:>14}"
        print(f"{key:34s} {shown}   {targets[key]}".rstrip())
    if args.json:
        print(json.dumps(figures))
    return 0


def _demo(args: argparse.Namespace) -> int:
    from hri_bench.report.figures import make_figures  # matplotlib: the bench extra

    t0 = time.perf_counter()
    print("hri-bench demo: the wheel studies (Fig. 10a-c, 100 runs x 20 episodes), the Learner's "
          "policies (Figs. 11-12) and the hanger studies (Figs. 4 and 8)", flush=True)
    if partner_mdp.jit_enabled():  # else the numpy path: nothing to compile
        # as serve does: the first run after installing compiles them (numba keeps them on
        # disk), a minute or more that would otherwise pass in silence before the first study
        print("loading the Learner's compiled kernels (the first time after installing they "
              "are compiled: a minute or more, once)", flush=True)
        algorithm1.preload()
        print(f"kernels ready in {time.perf_counter() - t0:.0f} s; simulating", flush=True)
    paths = make_figures(args.out, runs=100, jobs=args.jobs,
                         executor="process" if args.jobs > 1 else "serial", wheel_episodes=20,
                         progress=sys.stderr.isatty())
    print(f"done in {time.perf_counter() - t0:.0f} s; plots:")
    for p in paths:
        print(f"  {p}")
    print(next_steps(args.out))
    return 0


def next_steps(out: Path) -> str:
    """What ``hri-bench demo --out OUT`` (``make demo``: ``out/demo``) suggests next; every
    command runs as printed from the checkout, and what it writes goes into ``OUT`` (not
    where the README's tour writes).
    """
    at = shlex.quote(str(out))
    return f"""
What to try next, from this folder (README.md 'A tour', docs/benchmark.md):
  .venv/bin/hri-bench study wheel --runs 20 --out {at}/wheel   # one study: summary, CSV, plots
  .venv/bin/hri-bench study wheel --human-passive 0.2 --runs 20 --out {at}/passive
  .venv/bin/hri-bench suite --out {at}/suite --jobs 2          # the benchmark's leaderboard
  .venv/bin/hri-bench play hanger                             # you are the human
  .venv/bin/python examples/custom_learner.py                 # your own agent, benchmarked
  .venv/bin/python examples/train_maskable_ppo.py             # needs the rl extra (below)
  .venv/bin/python examples/physics_table2.py --runs 1        # needs the mujoco extra (below)
Extras: .venv/bin/pip install -c constraints.txt -e '.[rl]'  (or '.[mujoco]', '.[ray]')"""


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hri-bench`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        load_plugins()
    except ConfigError as exc:  # an installed package's: not the command's arguments
        print(f"hri-bench: {exc}", file=sys.stderr)
        return 1
    try:
        import_modules(split_imports(argv)[0], field="--import")
    except ConfigError as exc:
        build_parser().error(f"argument --import: {exc}")
    parser = build_parser()
    for word in argv:  # Python 3.11's argparse reads "--jobs=--" as an empty list
        if word.startswith("--") and word.endswith("=--"):
            parser.error(f"argument {word[:-3]}: expected one argument, got '--'")
    if cli_physical.wants_physical(argv):  # its own flags: hri_bench/cli/physical.py
        return cli_physical.main(argv)
    args = parser.parse_args(argv)
    try:
        return _dispatch(args, parser, argv)
    except (MissingExtraError, BackendUnavailableError) as exc:
        print(f"hri-bench: {exc}", file=sys.stderr)
        return 1
    except ModuleNotFoundError as exc:
        missing = MissingExtraError.from_import(exc, f"hri-bench {args.command}")
        if missing is None:
            raise
        print(f"hri-bench: {missing}", file=sys.stderr)
        return 1
    except OSError as exc:  # a full disk or a bad output path no command reported itself
        where = f" {exc.filename}" if exc.filename else ""
        print(f"hri-bench {args.command}: cannot write or read{where}: "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 1


def _dispatch(args: argparse.Namespace, parser: argparse.ArgumentParser,
              argv: Sequence[str]) -> int:
    if args.command in ("figures", "demo"):
        MissingExtraError.require(["matplotlib", "tqdm"], f"hri-bench {args.command}")
    if args.command == "study":
        return _study(args, args.command_parser, argv)
    if args.command == "figures":
        return _figures(args, parser)
    if args.command == "suite":
        return _suite(args, args.command_parser, argv)
    if args.command == "speed":
        return _speed(args)
    if args.command in ("validate", "leaderboard"):
        return cli_results.run(args)
    if args.command in ("serve", "dataset", "replay"):
        return cli_people.run(args)
    if args.command == "play":
        play(scenario_graph(args.scenario), episodes=args.episodes, seed=args.seed)
        return 0
    return _demo(args)


if __name__ == "__main__":
    sys.exit(main())
