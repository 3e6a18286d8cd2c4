"""``hri-bench study``: the study's configuration from the command line (or a ``--config``
file), the checks before it runs, running it in its folder and reporting the result.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from agents.config import default_config
from hri_bench.cli import results as cli_results
from hri_bench.cli.args import as_flags, cannot_write, config_error, resume_hint
from hri_bench.cli.parser import LEARNER_FLAGS, STUDY_ARGUMENTS
from hri_bench.run.agents import SB3_PREFIX, jaxppo_path
from hri_bench.run.humans import population_changes
from hri_bench.run.regret import REFERENCES
from hri_bench.run.study import EXECUTION_FIELDS, StudyConfig, UnitLostError
from hri_bench.run.studyio import UNITS, StudyDir, StudyTerminated, run_in, stop_on_signals
from hri_bench.suite.submission import read_json
from hri_envs.envs.backends import check_backend
from hri_envs.errors import ConfigError, LearnerStateError, MissingExtraError
from hri_envs.imports import imported_modules


def _learner_changes(args: argparse.Namespace, parser: argparse.ArgumentParser
                     ) -> dict[str, Any]:
    """The ``--learner-*`` flags given, checked against the scenario's LearnerConfig."""
    learner: dict[str, Any] = {f: getattr(args, f"learner_{f}") for f in LEARNER_FLAGS
                               if getattr(args, f"learner_{f}") is not None}
    if args.learner_no_passive_prior:
        learner["passive_prior"] = False
    try:
        default_config(args.scenario, **learner)
    except ConfigError as exc:
        flags = {f: flag for f, (flag, _, _) in LEARNER_FLAGS.items()}
        config_error(parser, exc, {**flags, "passive_prior": "--learner-no-passive-prior"})
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
    given = [flag for field, flag in STUDY_ARGUMENTS.items()
             if field not in EXECUTION_FIELDS and field != "scenario"
             and getattr(args, field) != parser.get_default(field)]
    given += [flag for field, (flag, _, _) in LEARNER_FLAGS.items()
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


def require_for_study(cfg: Any, *, progress: bool) -> None:
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
                    SB3BatchAgent(name[len(SB3_PREFIX):], 1, graph=cfg.graph)
                except ConfigError as exc:
                    raise ConfigError(f"agent {name!r}: {exc}", field="agents") from None
    if any(jaxppo_path(a) is not None for a in cfg.agents):
        MissingExtraError.require(["jax", "optax"], "a 'jaxppo' agent")
        from agents.jax_ppo.agent import load_checked  # jax: the jax extra, only for jaxppo

        for name in cfg.agents:  # a checkpoint that cannot be loaded is bad input: exit 2
            path = jaxppo_path(name)
            if path is not None:
                try:
                    load_checked(path, cfg.graph)
                except (ConfigError, LearnerStateError) as exc:
                    raise ConfigError(f"agent {name!r}: {exc}", field="agents") from None


def study(args: argparse.Namespace, parser: argparse.ArgumentParser,
          argv: Sequence[str]) -> int:
    """``hri-bench study``: check, run (or resume) and report the study; the exit status."""
    executor = args.executor or ("process" if args.jobs > 1 else "serial")
    arguments = {**STUDY_ARGUMENTS, "out": "--out", "resume": "--resume"}
    try:
        cfg = _study_config(args, parser, executor)
        require_for_study(cfg, progress=not args.no_progress)
    except ConfigError as exc:
        config_error(parser, exc, arguments)
    try:
        # From the lock on: the folder's checks remove a killed study's leftovers.
        with stop_on_signals():
            try:
                folder = StudyDir(args.out, cfg, resume=args.resume, overwrite=args.overwrite)
            except ConfigError as exc:
                config_error(parser, exc, arguments)
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
        print(f"hri-bench: study stopped: {as_flags(str(exc), STUDY_ARGUMENTS)}; {kept} "
              f"finished unit(s) kept in "
              f"{Path(args.out) / UNITS}; continue with: {resume_hint(argv)}",
              file=sys.stderr)
        return 1
    except OSError as exc:
        return cannot_write(exc, args.out, argv)
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
