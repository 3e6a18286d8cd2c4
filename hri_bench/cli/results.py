"""``hri-bench validate``, ``hri-bench leaderboard`` and the suite's ``--config`` and
``--seeds`` (docs/results.md).

Kept apart from :mod:`hri_bench.cli.commands`, which calls :func:`add_parsers`,
:func:`add_suite_flags`, :func:`suite_plan` and :func:`run_suites`.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import secrets
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hri_bench.cli.args import bounded, whole
from hri_bench.core.atomic import atomic_writer
from hri_bench.run.agents import PLANNING_REFERENCES, validate_agent_name
from hri_bench.run.folders import LOCK, FolderLock, check_out
from hri_bench.run.provenance import code_changes
from hri_bench.suite import audit, results_v3, results_v4, resume, submission
from hri_bench.suite.merged import HEADING, merged_leaderboard
from hri_bench.suite.physical_results import FORMAT as PHYSICAL_FORMAT
from hri_bench.suite.tracks import SUITE_VERSIONS, TRACKS_BY_VERSION
from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.imports import import_modules

__all__ = ["add_parsers", "add_suite_flags", "leaderboard", "run", "run_suites", "suite_plan",
           "warn_code_changes",
           "validate"]

#: The suite flags ``--config`` may be combined with (they change no number).
EXECUTION_FLAGS = ("out", "jobs", "executor", "no_progress", "resume", "overwrite",
                   "unit_time_limit")


def add_parsers(sub: Any) -> None:
    """The ``validate`` and ``leaderboard`` subcommands."""
    val = sub.add_parser("validate", help="check a results file against the schema and the "
                         "suite, recomputing every statistic",
                         description="Check a results file (results.json of hri-bench suite) "
                         "against the results schema and the installed suite's version and "
                         "hashes, and recompute every statistic from its per-run data. Exit "
                         "0 when valid, 1 with one line per problem otherwise.")
    val.add_argument("file", type=Path, help="results.json (or .json.gz)")
    val.add_argument("--replay", type=whole, default=0, metavar="K",
                     help="also re-simulate K randomly chosen runs of every agent whose code "
                          "is installed here (built-in agents of this hri-envs version, "
                          "module:Class with the recorded source hash) and require the "
                          "recorded values exactly (default 0: no replay)")
    val.add_argument("--replay-seed", type=whole, default=None, metavar="S",
                     help="seed of the runs --replay picks (default: a fresh one, printed)")
    val.add_argument("--fresh", action="store_true",
                     help="also re-run the file's agents (suite v3, v4) on a seed this "
                          "command draws and fresh humans of the test families, and fail "
                          "where an agent's headline differs from the submitted one beyond "
                          "their intervals (the seed is printed after the run)")
    val.add_argument("--fresh-seed", type=whole, default=None, metavar="S",
                     help="the seed of --fresh (default: drawn from the operating system); "
                          "to repeat a check")
    val.add_argument("--jobs", type=bounded(int, "a whole number >= 1", lambda v: v >= 1),
                     default=1, help="worker processes of --fresh (default 1)")
    val.set_defaults(command_parser=val)
    lb = sub.add_parser("leaderboard", help="merge validated results files into a leaderboard",
                        description="Validate every results file in DIR (*.json, *.json.gz; "
                        "other JSON files, such as a suite's suite.json, are skipped), merge "
                        "the valid ones and write leaderboard.md and profiles.png "
                        "(ranking.png for suite v3).")
    lb.add_argument("dir", type=Path, help="folder of results files")
    lb.add_argument("--out", type=Path, default=None,
                    help="output folder (default: DIR/merged; new, empty, or one an earlier "
                         "leaderboard wrote)")
    lb.set_defaults(command_parser=lb)


def add_suite_flags(suite: argparse.ArgumentParser) -> None:
    """The suite's ``--config`` (replay) and ``--seeds`` flags."""
    suite.add_argument("--config", type=Path, default=None, metavar="FILE",
                       help="replay the suite a suite.json or results.json describes (only "
                            "--out, --jobs, --executor, --unit-time-limit, --resume, "
                            "--overwrite and --no-progress may be given with it)")
    suite.add_argument("--seeds", default=None, metavar="S1,S2,...",
                       help="run the suite once per seed (in DIR/seed-S) and aggregate over "
                            "them with the seed-to-seed spread (instead of --seed)")


def _seeds(text: str, parser: argparse.ArgumentParser) -> list[int]:
    try:
        seeds = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        parser.error(f"argument --seeds: expected whole numbers >= 0 separated by commas, got "
                     f"{text!r}")
    if not seeds or any(s < 0 for s in seeds) or len(set(seeds)) != len(seeds):
        parser.error(f"argument --seeds: expected distinct whole numbers >= 0 separated by "
                     f"commas, got {text!r}")
    return seeds


def _read_config(path: Path, parser: argparse.ArgumentParser) -> dict[str, Any]:
    """version, agents, tracks, populations, runs_scale, seeds and recorded identities."""
    try:
        doc = submission.load(path)
    except ConfigError as exc:
        parser.error(f"argument --config: {exc}")
    if not isinstance(doc, dict):
        parser.error(f"argument --config: {path}: not a suite.json or results.json")
    try:
        if doc.get("format") == submission.FORMAT:
            version = doc["suite"]["version"]
            agents = [a for a in doc["agents"] if a not in PLANNING_REFERENCES]
            tracks = list(doc["suite"]["tracks"])
            plan = {"agents": agents, "tracks": tracks, "populations": [],
                    "runs_scale": doc["runs_scale"], "seeds": _listed(doc["seeds"]),
                    "identities": doc["agents"], "version": version,
                    "imports": _recorded_imports(doc)}
        else:
            version = doc["suite_version"]
            known = TRACKS_BY_VERSION.get(version, {})
            identities = doc.get("provenance", {}).get("agents")
            beside = path.with_name("results.json")
            if identities is None and beside.is_file():  # v1's suite.json has none
                identities = submission.load(beside).get("agents")
            plan = {"agents": _listed(doc["agents"]),
                    "tracks": [t for t in doc["tracks"] if t in known],
                    "populations": [tr["settings"]["population"]
                                    for t, tr in doc["tracks"].items() if t not in known],
                    "runs_scale": doc["runs_scale"],
                    "seeds": _listed(doc["seeds"] if "seeds" in doc else [doc["seed"]]),
                    "identities": identities or {}, "version": version,
                    "imports": _recorded_imports(doc)}
    except (KeyError, TypeError, AttributeError, ConfigError) as exc:
        parser.error(f"argument --config: {path}: not a suite.json or results.json (missing "
                     f"{exc})")
    if not isinstance(plan["version"], str) or plan["version"] not in SUITE_VERSIONS:
        parser.error(f"argument --config: {path}: suite version {plan['version']!r} is not "
                     f"one of {', '.join(SUITE_VERSIONS)}")
    _check_plan(plan, path, parser)
    return plan


def _recorded_imports(doc: dict[str, Any]) -> Any:
    """The modules a suite.json or results.json records as imported for their registrations
    (its ``imports``, and its tracks' settings'), in order; what is not a list is kept as it
    is, for :func:`_check_plan` to name.
    """
    found = doc.get("imports", [])
    if not isinstance(found, list):
        return found
    found = list(found)
    for track in (doc.get("tracks") or {}).values():
        recorded = (track.get("settings") or {}).get("imports", [])
        if not isinstance(recorded, list):
            return recorded
        found += [m for m in recorded if m not in found]
    return found


def _listed(value: Any) -> Any:
    """``value`` if it is a list; anything else is kept as it is, for :func:`_check_plan` to
    name (``list("ab")`` would read a string as two names).
    """
    return list(value) if isinstance(value, list | tuple) else value


def _names(value: Any) -> bool:
    """A list of distinct non-empty strings."""
    return (isinstance(value, list) and all(isinstance(v, str) and v for v in value)
            and len(set(value)) == len(value))


def _check_plan(plan: dict[str, Any], path: Path, parser: argparse.ArgumentParser) -> None:
    """Exit 2 naming the setting of a ``--config`` file that the matching flag would refuse
    (``seeds`` [0, 0], ``agents`` [], ``seeds`` ["a"], ``runs_scale`` 0, ...).
    """
    def bad(setting: str, flag: str, allowed: str) -> None:
        parser.error(f"argument --config: {path}: its {setting} {plan[setting]!r}: expected "
                     f"{allowed} (as {flag})")

    if not (_names(plan["agents"]) and plan["agents"]):
        bad("agents", "--agents", "a non-empty list of distinct agent names")
    if not (_names(plan["tracks"]) and plan["tracks"]):
        bad("tracks", "--tracks", "a non-empty list of distinct track names of the version")
    if not _names(plan["populations"]):
        bad("populations", "--population", "a list of distinct population names")
    scale = plan["runs_scale"]
    if not (isinstance(scale, int | float) and not isinstance(scale, bool)
            and math.isfinite(scale) and scale > 0):
        bad("runs_scale", "--runs-scale", "a number > 0")
    seeds = plan["seeds"]
    if not (isinstance(seeds, list) and seeds
            and all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in seeds)
            and len(set(seeds)) == len(seeds)):
        bad("seeds", "--seeds", "distinct whole numbers >= 0")
    if not isinstance(plan["identities"], dict):
        bad("identities", "--config", "the agents' code identities (an object)")
    if not _names(plan["imports"]):
        bad("imports", "--import", "a list of distinct module names")


def suite_plan(args: argparse.Namespace, parser: argparse.ArgumentParser) -> list[int]:
    """Apply ``--config`` (replay: the file's agents, tracks, scale and seeds; warn on stderr
    when an agent's code differs from the recorded one) and ``--seeds``; the seeds to run.
    """
    if args.config is None:
        return _seeds(args.seeds, parser) if args.seeds is not None else [args.seed]
    given = [f"--{k.replace('_', '-')}" for k, v in vars(args).items()
             if k not in (*EXECUTION_FLAGS, "config", "command", "command_parser", "imports")
             and v != parser.get_default(k)]
    if given:
        parser.error(f"argument --config: it replays the recorded suite; drop {', '.join(given)}")
    plan = _read_config(args.config, parser)
    try:  # what the suite's agents and populations were registered by
        import_modules(plan["imports"])
    except ConfigError as exc:
        parser.error(f"argument --config: {args.config}: {exc}")
    for agent in plan["agents"]:  # a custom agent that no longer imports: exit 2 here
        try:
            validate_agent_name(agent)
        except ConfigError as exc:
            parser.error(f"argument --config: {args.config}: {exc}")
    for line in code_changes(plan["identities"], plan["agents"]):
        print(f"hri-bench suite: warning: {line}", file=sys.stderr)
    args.agents, args.tracks = tuple(plan["agents"]), ",".join(plan["tracks"])
    args.suite_version = plan["version"]
    args.population, args.runs_scale = plan["populations"], plan["runs_scale"]
    args.seed = plan["seeds"][0]
    return [int(s) for s in plan["seeds"]]


def run_suites(args: argparse.Namespace, seeds: list[int], run_one: Callable[..., Any],
               plan: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Run the suite once per seed; with several, each in ``out/seed-S``, then the combined
    ``results.json``, ``leaderboard.md``, ``profiles.png`` and ``suite.json`` in ``out``, and
    last ``suite_log.json`` with ``plan`` (:func:`hri_bench.suite.resume.suite_plan`; the
    plan is kept in ``out/.suite`` meanwhile, for ``--resume``).
    """
    if len(seeds) == 1:
        return [run_one(args.out, seed=seeds[0])]
    state = args.out / resume.STATE
    t0 = time.perf_counter()
    if plan is not None and not (state / "plan.json").is_file():
        state.mkdir(parents=True, exist_ok=True)
        with atomic_writer(state / "plan.json") as f:
            json.dump(plan, f, indent=1)
    docs = [run_one(args.out / f"seed-{s}", seed=s) for s in seeds]
    parts = [args.out / f"seed-{s}" / "results.json" for s in seeds]
    if all(p.is_file() for p in parts):
        results = submission.combine([submission.load(p) for p in parts])
        submission.write_results(args.out, results)
        with atomic_writer(args.out / "leaderboard.md") as f:
            f.write(f"# hri-envs benchmark suite v{results['suite']['version']}, seeds "
                    f"{', '.join(map(str, seeds))}\n\nPer seed: `seed-S/leaderboard.md`.\n\n"
                    + _lead(results) + "\n" + submission.task_section(results) + "\n")
        with atomic_writer(args.out / "suite.json") as f:
            f.write(json.dumps({"suite_version": docs[0]["suite_version"], "seeds": seeds,
                                "runs_scale": docs[0]["runs_scale"],
                                "agents": docs[0]["agents"],
                                **({"imports": docs[0]["imports"]}
                                   if docs[0].get("imports") else {}),
                                "tracks": {n: {"settings": t["settings"]}
                                           for n, t in docs[0]["tracks"].items()},
                                "provenance": docs[0].get("provenance", {})}, indent=1)
                    + "\n")
    if plan is not None:
        with atomic_writer(args.out / resume.SUITE_LOG) as f:
            f.write(json.dumps({"seeds": seeds, "wall_time_s": round(time.perf_counter() - t0, 2),
                                "plan": plan}, indent=1) + "\n")
        shutil.rmtree(state, ignore_errors=True)
    return docs


def _lead(results: dict[str, Any]) -> str:
    """The lead of a leaderboard over several seeds: the version's headline (v3, v4) or the
    aggregate across tracks (v1, v2).
    """
    if results["schema_version"] == results_v3.SCHEMA_V4:
        refs = [a for a, r in results["roles"].items() if r["reference"]]
        return (results_v4.lead_section(results) + "\n"
                + results_v3.failure_section(results, refs))
    if results["schema_version"] == results_v3.SCHEMA_VERSION:
        return results_v3.lead_section(results) + "\n" + results_v3.failure_section(results)
    return submission.lead_section(results)


def warn_code_changes(recorded: Any, agents: Any) -> None:
    """Warn on stderr for each agent of a study's ``--config`` (a summary.json) whose code
    differs from the identity ``recorded`` (the file's ``agent_configs``, as the caller read
    it; anything but an object: nothing recorded).
    """
    for line in code_changes(recorded if isinstance(recorded, dict) else {}, agents):
        print(f"hri-bench study: warning: {line}", file=sys.stderr)


def validate(path: Path, replay: int = 0, replay_seed: int | None = None,
             fresh: bool = False, fresh_seed: int | None = None, jobs: int = 1) -> int:
    """``hri-bench validate FILE [--replay K] [--fresh]``: 0 when valid (every replayed run
    identical, every agent's fresh headline within its interval); 1 with one line per
    problem. A physical suite's file is checked by :mod:`hri_bench.suite.physical_audit`
    (no ``--fresh`` for it), any other by :mod:`hri_bench.suite.submission` and
    :mod:`hri_bench.suite.audit`.
    """
    try:
        doc = submission.load(path)
        physical = isinstance(doc, dict) and doc.get("format") == PHYSICAL_FORMAT
        if physical:
            from hri_bench.suite.physical_audit import validate_physical  # noqa: PLC0415

            problems = validate_physical(doc)
        else:
            problems = submission.validate(doc)
    except ConfigError as exc:
        print(f"hri-bench validate: {exc}", file=sys.stderr)
        return 1
    if problems:
        print(f"{path}: INVALID ({len(problems)} problem(s)):", file=sys.stderr)
        for line in problems:
            print(f"  {line}", file=sys.stderr)
        return 1
    print(f"{path}: valid " + ("physical results (suite version and hash, the runs' humans"
                               if physical else "(schema, suite version and hashes")
          + ", every statistic recomputed)")
    if fresh and physical:
        print("hri-bench validate: --fresh is not available for physical results files; "
              "--replay K re-simulates their runs", file=sys.stderr)
        return 1
    if replay:
        seed = secrets.randbelow(2**31) if replay_seed is None else replay_seed
        if physical:
            from hri_bench.suite.physical_audit import replay_physical  # noqa: PLC0415

            checked, bad, skipped = replay_physical(doc, replay, seed)
        else:
            checked, bad, skipped = audit.replay(doc, replay, seed,
                                                 progress=sys.stderr.isatty())
        for agent, why in skipped.items():
            print(f"  not replayed: agent {agent!r}: {why}")
        if skipped or not checked:
            print(f"{path}: REPLAY INCOMPLETE: {len(checked)} run(s) replayed; "
                  + (f"agent(s) {', '.join(map(repr, skipped))} could not be: a replay "
                     "vouches for every agent of the file or fails" if skipped
                     else "nothing could be replayed"), file=sys.stderr)
            return 1
        if bad:
            print(f"{path}: REPLAY FAILED ({len(bad)} of {len(checked)} run(s) differ; "
                  f"--replay-seed {seed}):", file=sys.stderr)
            for line in bad:
                print(f"  {line}", file=sys.stderr)
            return 1
        print(f"{path}: {len(checked)} replayed run(s) identical, the references' included "
              f"(--replay {replay} --replay-seed {seed})")
    if fresh:
        return _fresh(path, doc, fresh_seed, jobs)
    return 0


def _fresh(path: Path, doc: Any, seed: int | None, jobs: int) -> int:
    """``--fresh``: the agents on a drawn seed and fresh humans (:mod:`hri_bench.suite.fresh`)."""
    from hri_bench.suite.fresh import fresh_check

    drawn = secrets.randbelow(2**31) if seed is None else seed
    try:
        found = fresh_check(doc, drawn, jobs)
    except ConfigError as exc:
        print(f"hri-bench validate: {exc}", file=sys.stderr)
        return 1
    if found.skipped:
        print(f"{path}: FRESH CHECK INCOMPLETE: " + "; ".join(
            f"agent {a!r} cannot be re-run here ({why})" for a, why in found.skipped.items()),
              file=sys.stderr)
        return 1
    for line in found.lines:
        print(f"  {line}")
    where = f"(fresh seed {drawn}, drawn after the submission; --fresh-seed {drawn} repeats it)"
    if found.failed:
        print(f"{path}: FRESH CHECK FAILED for {', '.join(map(repr, found.failed))} {where}",
              file=sys.stderr)
        return 1
    print(f"{path}: every agent's headline on fresh humans is within its interval {where}")
    return 0


#: What ``hri-bench leaderboard`` writes into its ``--out`` (besides its lock).
LEADERBOARD_FILES = ("leaderboard.md", "profiles.png", "ranking.png", "goal_effort.png")


def _leaderboard_out(out: Path) -> str | None:
    """Why ``out`` cannot take a merged leaderboard (None when it can): it holds files
    ``hri-bench leaderboard`` did not write, or a ``leaderboard.md`` of another kind (a
    suite's).
    """
    if not out.is_dir():
        return None
    foreign = sorted(p.name for p in out.iterdir()
                     if p.name not in (*LEADERBOARD_FILES, LOCK))
    board = out / "leaderboard.md"
    if board.exists():
        try:
            with open(board, "rb") as f:
                head = f.read(len(HEADING.encode()))
        except OSError:
            head = b""
        if not board.is_file() or head != HEADING.encode():
            foreign.insert(0, "leaderboard.md (not one hri-bench leaderboard wrote)")
    if not foreign:
        return None
    shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3
                                      else "")
    return (f"{out} holds files hri-bench leaderboard did not write ({shown}); give a new or "
            "empty folder, or the one an earlier leaderboard wrote")


def leaderboard(folder: Path, out: Path | None, parser: argparse.ArgumentParser) -> int:
    """``hri-bench leaderboard DIR [--out OUT]``: 0 when every results file was merged, 1
    when some were refused (named on stderr), none was valid, or a file cannot be written;
    a DIR that is not a folder, or an OUT that holds other files, is the parser's error
    (usage, exit 2), as every other bad argument of the CLI.

    The merged leaderboard goes to ``DIR/merged`` by default, never over a suite's own
    ``leaderboard.md``; files that are not results files (a suite's ``suite.json``) are
    skipped with a note.
    """
    if not folder.is_dir():
        parser.error(f"argument dir: {folder} is not a folder")
    # it validates every file and draws the ranking: said before any file is read (a file
    # refused first would hide what is missing)
    MissingExtraError.require(["jsonschema", "matplotlib"], "hri-bench leaderboard")
    out = folder / "merged" if out is None else out
    created = not out.exists()
    lock = FolderLock(out, "leaderboard")
    try:
        check_out(out, "leaderboard")
        lock.acquire()
        why = _leaderboard_out(out)
    except ConfigError as exc:
        parser.error(f"argument --out: {exc}")
    except OSError as exc:
        lock.release()
        parser.error(f"argument --out: cannot use {out} ({exc.strerror or exc}); give a "
                     "folder you can write to")
    if why is not None:
        lock.release()
        parser.error(f"argument --out: {why}")
    files = sorted([*folder.glob("*.json"), *folder.glob("*.json.gz")])
    try:
        merged = merged_leaderboard(files, out)
    except OSError as exc:
        print(f"hri-bench leaderboard: cannot write {exc.filename or out}: "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 1
    finally:
        lock.release()
    if created and not merged.written:
        with contextlib.suppress(OSError):
            out.rmdir()  # made for nothing
    for line in merged.skipped:
        print(line)
    for line in merged.refused:
        print(line, file=sys.stderr)
    results = len(files) - len(merged.skipped)
    if not merged.written:
        print(f"hri-bench leaderboard: no valid results file in {folder}", file=sys.stderr)
        return 1
    print(f"merged {results - len(merged.refused)} of {results} results file(s): wrote "
          f"{', '.join(str(p) for p in merged.written)}")
    return 1 if merged.refused else 0


def run(args: argparse.Namespace) -> int:
    """Dispatch ``validate`` and ``leaderboard``."""
    if args.command == "validate":
        return validate(args.file, args.replay, args.replay_seed, args.fresh, args.fresh_seed,
                        args.jobs)
    return leaderboard(args.dir, args.out, args.command_parser)
