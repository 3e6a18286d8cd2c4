"""``hri-bench validate``, ``hri-bench leaderboard`` and the suite's ``--config`` and
``--seeds`` (docs/results.md).

Kept apart from :mod:`hri_bench.cli.commands`, which calls :func:`add_parsers`,
:func:`add_suite_flags`, :func:`suite_plan` and :func:`run_suites`.
"""

from __future__ import annotations

import argparse
import json
import secrets
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hri_bench.core.atomic import atomic_writer
from hri_bench.run.agents import PLANNING_REFERENCES, validate_agent_name
from hri_bench.run.provenance import code_changes
from hri_bench.suite import audit, submission
from hri_bench.suite.merged import merged_leaderboard
from hri_bench.suite.tracks import SUITE_VERSIONS, TRACKS_BY_VERSION
from hri_envs.errors import ConfigError

__all__ = ["add_parsers", "add_suite_flags", "leaderboard", "run", "run_suites", "suite_plan",
           "warn_code_changes",
           "validate"]

#: The suite flags ``--config`` may be combined with (they change no number).
EXECUTION_FLAGS = ("out", "jobs", "executor", "no_progress")


def add_parsers(sub: Any) -> None:
    """The ``validate`` and ``leaderboard`` subcommands."""
    val = sub.add_parser("validate", help="check a results file against the schema and the "
                         "suite, recomputing every statistic",
                         description="Check a results file (results.json of hri-bench suite) "
                         "against the results schema and the installed suite's version and "
                         "hashes, and recompute every statistic from its per-run data. Exit "
                         "0 when valid, 1 with one line per problem otherwise.")
    val.add_argument("file", type=Path, help="results.json (or .json.gz)")
    val.add_argument("--replay", type=_whole, default=0, metavar="K",
                     help="also re-simulate K randomly chosen runs of every agent whose code "
                          "is installed here (built-in agents of this hri-envs version, "
                          "module:Class with the recorded source hash) and require the "
                          "recorded values exactly (default 0: no replay)")
    val.add_argument("--replay-seed", type=_whole, default=None, metavar="S",
                     help="seed of the runs --replay picks (default: a fresh one, printed)")
    val.set_defaults(command_parser=val)
    lb = sub.add_parser("leaderboard", help="merge validated results files into a leaderboard",
                        description="Validate every results file in DIR (*.json, *.json.gz), "
                        "merge the valid ones and write leaderboard.md and profiles.png.")
    lb.add_argument("dir", type=Path, help="folder of results files")
    lb.add_argument("--out", type=Path, default=None, help="output folder (default: DIR)")
    lb.set_defaults(command_parser=lb)


def _whole(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}")
    return value


def add_suite_flags(suite: argparse.ArgumentParser) -> None:
    """The suite's ``--config`` (replay) and ``--seeds`` flags."""
    suite.add_argument("--config", type=Path, default=None, metavar="FILE",
                       help="replay the suite a suite.json or results.json describes (only "
                            "--out, --jobs, --executor, --no-progress may be given with it)")
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
                    "runs_scale": doc["runs_scale"], "seeds": list(doc["seeds"]),
                    "identities": doc["agents"], "version": version}
        else:
            version = doc["suite_version"]
            known = TRACKS_BY_VERSION.get(version, {})
            identities = doc.get("provenance", {}).get("agents")
            beside = path.with_name("results.json")
            if identities is None and beside.is_file():  # v1's suite.json has none
                identities = submission.load(beside).get("agents")
            plan = {"agents": list(doc["agents"]),
                    "tracks": [t for t in doc["tracks"] if t in known],
                    "populations": [tr["settings"]["population"]
                                    for t, tr in doc["tracks"].items() if t not in known],
                    "runs_scale": doc["runs_scale"],
                    "seeds": list(doc["seeds"] if "seeds" in doc else [doc["seed"]]),
                    "identities": identities or {}, "version": version}
    except (KeyError, TypeError, AttributeError, ConfigError) as exc:
        parser.error(f"argument --config: {path}: not a suite.json or results.json (missing "
                     f"{exc})")
    if plan["version"] not in SUITE_VERSIONS:
        parser.error(f"argument --config: {path}: suite version {plan['version']!r} is not "
                     f"one of {', '.join(SUITE_VERSIONS)}")
    return plan


def suite_plan(args: argparse.Namespace, parser: argparse.ArgumentParser) -> list[int]:
    """Apply ``--config`` (replay: the file's agents, tracks, scale and seeds; warn on stderr
    when an agent's code differs from the recorded one) and ``--seeds``; the seeds to run.
    """
    if args.config is None:
        return _seeds(args.seeds, parser) if args.seeds is not None else [args.seed]
    given = [f"--{k.replace('_', '-')}" for k, v in vars(args).items()
             if k not in (*EXECUTION_FLAGS, "config", "command", "command_parser")
             and v != parser.get_default(k)]
    if given:
        parser.error(f"argument --config: it replays the recorded suite; drop {', '.join(given)}")
    plan = _read_config(args.config, parser)
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


def run_suites(args: argparse.Namespace, seeds: list[int], run_one: Callable[..., Any]
               ) -> list[dict[str, Any]]:
    """Run the suite once per seed; with several, each in ``out/seed-S``, then the combined
    ``results.json``, ``leaderboard.md`` and ``profiles.png`` in ``out``.
    """
    if len(seeds) == 1:
        return [run_one(args.out, seed=seeds[0])]
    docs = [run_one(args.out / f"seed-{s}", seed=s) for s in seeds]
    parts = [args.out / f"seed-{s}" / "results.json" for s in seeds]
    if all(p.is_file() for p in parts):
        results = submission.combine([submission.load(p) for p in parts])
        submission.write_results(args.out, results)
        with atomic_writer(args.out / "leaderboard.md") as f:
            f.write(f"# hri-envs benchmark suite v{results['suite']['version']}, seeds "
                    f"{', '.join(map(str, seeds))}\n\nPer seed: `seed-S/leaderboard.md`.\n\n"
                    + submission.lead_section(results) + "\n"
                    + submission.task_section(results) + "\n")
        with atomic_writer(args.out / "suite.json") as f:
            f.write(json.dumps({"suite_version": docs[0]["suite_version"], "seeds": seeds,
                                "runs_scale": docs[0]["runs_scale"],
                                "agents": docs[0]["agents"],
                                "tracks": {n: {"settings": t["settings"]}
                                           for n, t in docs[0]["tracks"].items()},
                                "provenance": docs[0].get("provenance", {})}, indent=1)
                    + "\n")
    return docs


def warn_code_changes(recorded: Any, agents: Any) -> None:
    """Warn on stderr for each agent of a study's ``--config`` (a summary.json) whose code
    differs from the identity ``recorded`` (the file's ``agent_configs``, as the caller read
    it; anything but an object: nothing recorded).
    """
    for line in code_changes(recorded if isinstance(recorded, dict) else {}, agents):
        print(f"hri-bench study: warning: {line}", file=sys.stderr)


def validate(path: Path, replay: int = 0, replay_seed: int | None = None) -> int:
    """``hri-bench validate FILE [--replay K]``: 0 when valid (and every replayed run
    identical); 1 with one line per problem.
    """
    try:
        doc = submission.load(path)
        problems = submission.validate(doc)
    except ConfigError as exc:
        print(f"hri-bench validate: {exc}", file=sys.stderr)
        return 1
    if problems:
        print(f"{path}: INVALID ({len(problems)} problem(s)):", file=sys.stderr)
        for line in problems:
            print(f"  {line}", file=sys.stderr)
        return 1
    print(f"{path}: valid (schema, suite version and hashes, every statistic recomputed)")
    if replay:
        seed = secrets.randbelow(2**31) if replay_seed is None else replay_seed
        checked, bad, skipped = audit.replay(doc, replay, seed, progress=sys.stderr.isatty())
        for agent, why in skipped.items():
            print(f"  not replayed: agent {agent!r}: {why}")
        if bad:
            print(f"{path}: REPLAY FAILED ({len(bad)} of {len(checked)} run(s) differ; "
                  f"--replay-seed {seed}):", file=sys.stderr)
            for line in bad:
                print(f"  {line}", file=sys.stderr)
            return 1
        print(f"{path}: {len(checked)} replayed run(s) identical (--replay {replay} "
              f"--replay-seed {seed})")
    return 0


def leaderboard(folder: Path, out: Path | None, parser: argparse.ArgumentParser) -> int:
    """``hri-bench leaderboard DIR``: 0 when every file was merged, 1 when some were
    refused (named on stderr) or none was valid; a DIR that is not a folder is the
    parser's error (usage, exit 2), as every other bad argument of the CLI.
    """
    if not folder.is_dir():
        parser.error(f"argument dir: {folder} is not a folder")
    files = sorted([*folder.glob("*.json"), *folder.glob("*.json.gz")])
    written, refused = merged_leaderboard(files, out or folder)
    for line in refused:
        print(line, file=sys.stderr)
    if not written:
        print(f"hri-bench leaderboard: no valid results file in {folder}", file=sys.stderr)
        return 1
    print(f"merged {len(files) - len(refused)} of {len(files)} file(s): wrote "
          f"{', '.join(str(p) for p in written)}")
    return 1 if refused else 0


def run(args: argparse.Namespace) -> int:
    """Dispatch ``validate`` and ``leaderboard``."""
    if args.command == "validate":
        return validate(args.file, args.replay, args.replay_seed)
    return leaderboard(args.dir, args.out, args.command_parser)
