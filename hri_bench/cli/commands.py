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

The parser is :mod:`hri_bench.cli.parser`'s and ``study`` is
:mod:`hri_bench.cli.study_command`'s; this module holds :func:`main`, which dispatches, and
the ``suite``, ``figures``, ``speed`` and ``demo`` subcommands.
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agents.learning import algorithm1, partner_mdp
from hri_bench.cli import people as cli_people
from hri_bench.cli import physical as cli_physical
from hri_bench.cli import results as cli_results
from hri_bench.cli.args import as_flags, cannot_write, config_error, resume_hint, split_imports
from hri_bench.cli.parser import STUDY_ARGUMENTS, build_parser
from hri_bench.cli.study_command import require_for_study, study
from hri_bench.people.play import play
from hri_bench.report.speed import measure, measure_physics
from hri_bench.run.study import UnitLostError
from hri_bench.run.studyio import StudyTerminated, stop_on_signals
from hri_bench.suite import default_agents, population_track, run_suite, select_tracks, track_config
from hri_bench.suite.resume import STATE, SuiteDir, suite_plan
from hri_envs.errors import BackendUnavailableError, ConfigError, MissingExtraError
from hri_envs.imports import import_modules, imported_modules, load_plugins
from hri_envs.task.scenarios import scenario_graph

__all__ = ["build_parser", "main"]


def _suite(args: argparse.Namespace, parser: argparse.ArgumentParser,
           argv: Sequence[str]) -> int:
    seeds = cli_results.suite_plan(args, parser)  # --config replays, --seeds
    executor = args.executor or ("process" if args.jobs > 1 else "serial")
    version = args.suite_version
    agents = args.agents or default_agents(version)
    try:
        tracks = select_tracks(args.tracks, version)
        first = track_config(tracks[0], agents, executor=executor, version=version)
        require_for_study(first, progress=not args.no_progress)  # before simulating
        for name in args.population:
            track_config(population_track(name, version), agents, executor=executor,
                         version=version)
    except ConfigError as exc:
        config_error(parser, exc, _SUITE_ARGUMENTS)
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
                config_error(parser, exc, _SUITE_ARGUMENTS)
            with folder:
                if folder.complete:
                    print(f"nothing to do: the suite in {args.out} is complete (suite.json, "
                          "results.json, leaderboard.md and the figures are in place)")
                    return 0
                docs = cli_results.run_suites(args, seeds, one, plan)
    except ConfigError as exc:  # a seed's folder of another suite (--resume)
        config_error(parser, exc, _SUITE_ARGUMENTS)
    except KeyboardInterrupt as exc:
        print(f"\nstopped; {_suite_kept(args.out)}. Resume with:\n  {resume_hint(argv)}",
              file=sys.stderr)
        return 143 if isinstance(exc, StudyTerminated) else 130
    except UnitLostError as exc:
        print(f"hri-bench: suite stopped: {as_flags(str(exc), STUDY_ARGUMENTS)}; "
              f"{_suite_kept(args.out)}; continue with: "
              f"{resume_hint(argv)}", file=sys.stderr)
        return 1
    except OSError as exc:
        return cannot_write(exc, args.out, argv, kept="the finished tracks and units are kept")
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
        return study(args, args.command_parser, argv)
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
