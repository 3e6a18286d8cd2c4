"""The ``hri-bench`` commands for people in the loop: ``serve``, ``dataset``, ``replay``.

::

    hri-bench serve {hanger,wheel} [--agent learner] [--episodes 8] [--data DIR] ...
    hri-bench dataset list|show|export|record|fit ...
    hri-bench replay DATASET [--participant P] [--frames DIR] [--step]

docs/people.md describes them. Bad arguments exit 2 naming the argument; a missing ``web``
extra is one line with the command that installs it (exit 1).
"""

from __future__ import annotations

import argparse
import json
import os
import stat
import sys
import textwrap
from pathlib import Path
from typing import Any

from agents.config import default_config
from hri_bench.cli.people_parser import SERVE_ARGUMENTS, add_parsers
from hri_bench.data import datasets
from hri_bench.data import fit as fitting
from hri_bench.data.datasets import create_dataset, open_dataset
from hri_bench.data.replay import replay
from hri_bench.people.recording import record_study
from hri_bench.people.serve import ServeConfig, require_web, serve
from hri_bench.run.study import StudyConfig
from hri_bench.run.studyio import StudyTerminated, stop_on_signals
from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.task.scenarios import scenario_spec

__all__ = ["COMMANDS", "add_parsers", "run"]

#: The subcommands this module adds.
COMMANDS = ("serve", "dataset", "replay")


def _fail(parser: argparse.ArgumentParser, exc: ConfigError, arguments: dict[str, str]) -> None:
    flag = arguments.get(exc.field or "")
    parser.error(f"argument {flag}: {exc}" if flag else str(exc))


def _read_text(parser: argparse.ArgumentParser, path: Path | None, flag: str) -> str | None:
    if path is None:
        return None
    try:
        # opened without blocking (a FIFO would wait for a writer), then checked to be a
        # regular file before anything is read (a device never ends)
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        parser.error(f"argument {flag}: cannot read {path} ({exc.strerror or exc})")
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            parser.error(f"argument {flag}: {path} is not a regular file; give a text file")
        with open(fd, encoding="utf-8", closefd=False) as f:
            text = f.read(100_001)
    except (OSError, UnicodeDecodeError) as exc:
        parser.error(f"argument {flag}: cannot read {path} ({exc})")
    finally:
        os.close(fd)
    if len(text) > 100_000 or not text.strip():
        parser.error(f"argument {flag}: {path} must hold a text of 1 to 100,000 characters")
    return text


def _serve(args: argparse.Namespace) -> int:
    require_web("hri-bench serve")
    parser = args.command_parser
    prefs: tuple[str, ...] = ()
    if args.preferences is not None:
        prefs = (scenario_spec(args.scenario).preferences if args.preferences == "all" else
                 tuple(p.strip() for p in args.preferences.split(",") if p.strip()))
    texts: dict[str, Any] = {}
    for name in ("instructions", "consent"):
        text = _read_text(parser, getattr(args, name), f"--{name}")
        if text is not None:
            texts[name] = text
    try:
        if args.agent is None and args.physical:
            # Here, not at the top: it imports the physics (MuJoCo, mink and, through
            # qpsolvers, JAX), which every other command would import for nothing, and
            # JAX in the process makes a study start its workers by spawn.
            from hri_bench.core.physical_robots import default_robot  # noqa: PLC0415

            agent = default_robot()
        else:
            agent = args.agent or "learner"
        config = ServeConfig(args.scenario, agent=agent, episodes=args.episodes,
                             dataset=args.dataset, data=args.data, host=args.host,
                             port=args.port, allowed_hosts=tuple(args.allow_host or ()),
                             seed=args.seed, max_steps=args.max_steps,
                             r0=args.r0, reward=args.reward, preferences=prefs,
                             show_belief=args.show_belief, max_sessions=args.max_sessions,
                             idle_timeout_s=args.idle_timeout,
                             agent_timeout_s=args.agent_timeout, physical=args.physical,
                             max_time_s=args.max_time,
                             **texts)
        if config.agent.startswith("sb3:"):
            MissingExtraError.require(["stable_baselines3", "sb3_contrib", "torch"],
                                      "an 'sb3:' agent")
        create_dataset(config.dataset_id, config.graph, synthetic=False, root=config.data,
                       physical=config.physical)
    except ConfigError as exc:
        _fail(parser, exc, SERVE_ARGUMENTS)
    try:
        serve(config)
    except ConfigError as exc:  # another server records into the dataset, say
        _fail(parser, exc, SERVE_ARGUMENTS)
    except OSError as exc:
        print(f"hri-bench serve: cannot listen on {args.host}:{args.port}: "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        pass
    return 0


def _print(doc: Any, as_json: bool, lines: list[str]) -> None:
    if as_json:
        print(json.dumps(doc, indent=1, allow_nan=True))
    else:
        print("\n".join(lines))


def _cannot_write(command: str, exc: OSError, path: Path | None = None) -> int:
    """A file that cannot be written (a full disk, a read-only folder, ...) in one line on
    stderr; exit status 1.
    """
    print(f"hri-bench {command}: cannot write {exc.filename or path or 'its output'}: "
          f"{exc.strerror or exc}", file=sys.stderr)
    return 1


def _need_folder(parser: argparse.ArgumentParser, path: Path | None, flag: str) -> None:
    """Exit 2 unless ``path`` is None, a folder, or does not exist yet."""
    if path is not None and path.exists() and not path.is_dir():
        parser.error(f"argument {flag}: {path} is a file, not a folder")


def _unfinished_note(dataset: Any, doing: str) -> list[str]:
    """A line naming the unfinished sessions ``doing`` leaves out (none: no line)."""
    left = dataset.unfinished()
    if not left:
        return []
    names = ", ".join(f"{u['participant']} ({u['status']}, {u['episodes_recorded']}/"
                      f"{u['episodes_planned']} episodes)" for u in left[:8])
    more = f" and {len(left) - 8} more" if len(left) > 8 else ""
    return [f"  {doing} leaves out {len(left)} unfinished session(s): {names}{more}"]


def _dataset(args: argparse.Namespace) -> int:
    MissingExtraError.require(["pyarrow"], f"hri-bench dataset {args.dataset_command}")
    parser = args.command_parser
    action = args.dataset_command
    try:
        if action == "list":
            found = datasets.list_datasets(args.data)
            docs = [{"dataset_id": d.dataset_id, "scenario": d.scenario,
                     "synthetic": d.synthetic, "participants": len(d.session_dirs()),
                     "episodes": len(d.episode_paths()), "path": str(d.path)} for d in found]
            _print(docs, args.json,
                   [f"{d['dataset_id']:28s} {d['scenario']:7s} "
                    f"{'synthetic' if d['synthetic'] else 'people':9s} "
                    f"{d['participants']:5d} participants {d['episodes']:6d} episodes"
                    for d in docs] or [f"no datasets in {datasets.data_root(args.data)}"])
            return 0
        if action in ("export", "fit"):
            if action == "fit" or args.format == "minari":
                _need_folder(parser, args.out, "--out")
            elif args.out is None:
                parser.error("argument --out: give the Parquet file to write")
            elif args.out.is_dir():
                parser.error(f"argument --out: {args.out} is a folder; give the Parquet file "
                             "to write")
        dataset = datasets.open_dataset(args.dataset, args.data)
        if action == "show":
            _show(dataset, args.json)
        elif action == "export":
            _export(dataset, args)
        elif action == "fit":
            return _fit(args, dataset)
    except ConfigError as exc:
        _fail(parser, exc, {"dataset": "dataset", "participant": "--participant"})
    except OSError as exc:
        if action == "show":  # it writes nothing but its output
            raise
        return _cannot_write(f"dataset {action}", exc, args.out)
    return 0


def _show(dataset: Any, as_json: bool) -> None:
    doc = dataset.summary()
    lines = [f"{doc['dataset_id']} ({doc['schema']}): {doc['scenario']}, "
             f"{'SYNTHETIC (scripted humans)' if doc['synthetic'] else 'people'}",
             f"  {doc['participants']} participants, {doc['episodes']} episodes, "
             f"{doc['steps']} steps; content {doc['content_hash']}",
             f"  path {doc['path']}; Minari id {doc['minari_id']}"]
    lines += [f"  {s['participant']} #{s['session_index']}: {s['status']}, "
              f"{s['episodes_recorded']}/{s['episodes_planned']} episodes, robot "
              f"{s['agent']}" for s in doc["sessions"]]
    if doc["unfinished"]:
        lines += [f"  {len(doc['unfinished'])} unfinished session(s) (interrupted: its "
                  "recorder stopped or killed; running: in progress, or its server killed) "
                  "are left out of the counts, the content hash, the exports and the fits"]
    _print(doc, as_json, lines)


def _export(dataset: Any, args: argparse.Namespace) -> None:
    if args.format == "parquet":
        path = datasets.export_parquet(dataset, args.out)
        print(f"wrote {path} ({dataset.content_hash()})")
    else:
        root = datasets.export_minari(dataset, args.out)
        print(f"wrote the Minari dataset {dataset.minari_id} under {root}; load it "
              f"with MINARI_DATASETS_PATH={root} and "
              f"minari.load_dataset({dataset.minari_id!r})")
    for line in _unfinished_note(dataset, "the export"):
        print(line)


def _below_uniform(name: str, score: dict[str, Any], steps: int, uniform: float,
                   scenario: str) -> list[str]:
    """Why a model scores below the uniform policy on the held-out steps, with its numbers
    (docs/people.md, "Fitted humans").
    """
    b = score["breakdown"]
    text = (f"{name} scores below uniform ({score['log_likelihood']:.4f} < {uniform:.4f}): "
            f"{b['unlikely_steps']} of the {steps} held-out steps get less than "
            f"{fitting.UNLIKELY:g} from it ({b['unlikely_waits']} of them waits; worst "
            f"{b['worst_log_likelihood']:.2f}), {b['unlikely_share']:.0%} of its total; on "
            f"the other {steps - b['unlikely_steps']} it scores "
            f"{b['others_log_likelihood']:.4f}, uniform {b['uniform_others_log_likelihood']:.4f}.")
    if name == "irl":
        tau = default_config(scenario).human_temperature
        text += (f" The irl model is the Learner's human model softmax(τ_H Q_H), τ_H = {tau:g}: "
                 "sharp, it gives waiting almost no probability where its route moves on, "
                 "and a passive human waits there (bc counts those waits). See "
                 "docs/people.md, 'Fitted humans'.")
    else:
        text += (" Too few training steps in the states the held-out participants visit? A "
                 "larger --smoothing moves it towards uniform.")
    return textwrap.wrap(text, 96, initial_indent="  ", subsequent_indent="    ")


def _fit(args: argparse.Namespace, dataset: Any) -> int:
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)  # before fitting: an OSError at once
    if dataset.physical:
        return _fit_physical(args, dataset)
    models = [fitting.fit(dataset, "bc", smoothing=args.smoothing),
              fitting.fit(dataset, "irl")]
    scores = fitting.evaluate(dataset, models)
    kind = "SYNTHETIC (scripted humans)" if dataset.synthetic else "people"
    print(f"{dataset.dataset_id} ({kind}): fitted to {len(models[0].train)} training "
          f"participants; {len(scores['held_out'])} held out ({scores['steps']} steps)")
    for line in _unfinished_note(dataset, "the fit"):
        print(line)
    if not scores["steps"]:
        print("  no held-out participant to score the models on: a quarter of the "
              "participants is held out once there are two or more")
    for name in ("uniform", "bc", "irl") if scores["steps"] else ():
        s = scores[name]
        print(f"  {name:8s} held-out log-likelihood per step {s['log_likelihood']:8.4f}, "
              f"accuracy {s['accuracy']:.3f}"
              + (" (of a uniform choice; ties are shared evenly)" if name == "uniform" else ""))
    for name in ("bc", "irl") if scores["steps"] else ():
        if scores[name]["log_likelihood"] < scores["uniform"]["log_likelihood"]:
            for line in _below_uniform(name, scores[name], scores["steps"],
                                       scores["uniform"]["log_likelihood"], dataset.scenario):
                print(line)
    if args.out is not None:
        for m in models:
            print(f"  wrote {m.save(args.out / f'{m.kind}.npz')}")
    print(f"  use as a population: --population recorded:{dataset.dataset_id} (bc) or "
          f"recorded-irl:{dataset.dataset_id} (irl)")
    return 0


def _fit_physical(args: argparse.Namespace, dataset: Any) -> int:
    """``dataset fit`` of a physical dataset (:mod:`hri_bench.people.physical_fit`)."""
    from hri_bench.people.physical_fit import fit_physical  # noqa: PLC0415

    fit = fit_physical(dataset)
    kind = "SYNTHETIC (scripted humans)" if dataset.synthetic else "people"
    s = fit.scores
    print(f"{dataset.dataset_id} ({kind}): a reference human fitted to each of "
          f"{len(fit.train)} training participants; {len(fit.held_out)} held out")
    print("  hand-target RMS error [m] (position and rotation x 0.1 m), the fitted "
          "population's nearest member vs the default human:")
    print(f"    train     {s['train']:.4f} vs {s['default_train']:.4f} "
          f"({s['steps_train']:.0f} steps)")
    print(f"    held out  {s['held_out']:.4f} vs {s['default_held_out']:.4f} "
          f"({s['steps_held_out']:.0f} steps)")
    for who, m in zip(fit.train, fit.members, strict=True):
        print(f"    {who}: speed {m.speed:.3f}, reaction {m.reaction_s:.3f} s, hesitation "
              f"{m.hesitation_s:.3f} s, preference {m.preference}")
    if args.out is not None:
        path = fit.save(args.out / f"{dataset.dataset_id}.population.json")
        print(f"  wrote {path}; name it as a physical population: fitted:{path} (the "
              "continuous v1 envs' population=; docs/people.md, 'Fitted physical humans')")
    return 0


def _record(args: argparse.Namespace) -> int:
    MissingExtraError.require(["pyarrow"], "hri-bench dataset record")
    parser = args.command_parser
    arguments = {"agents": "--agent", "runs": "--sessions", "episodes": "--episodes",
                 "preference": "--preference", "population": "--population",
                 "human_rationality": "--human-rationality", "human_passive": "--human-passive",
                 "seed": "--seed", "max_steps": "--max-steps", "dataset": "--dataset"}
    _need_folder(parser, args.data, "--data")
    try:
        cfg = StudyConfig(args.scenario, agents=(args.agent,), runs=args.sessions,
                          episodes=args.episodes, preference=args.preference,
                          population=args.population, human_rationality=args.human_rationality,
                          human_passive=args.human_passive, seed=args.seed,
                          max_steps=args.max_steps)
        with stop_on_signals():
            dataset = record_study(cfg, args.dataset, root=args.data,
                                   description="scripted humans (hri-bench dataset record)")
    except ConfigError as exc:
        _fail(parser, exc, arguments)
    except KeyboardInterrupt as exc:
        print("\nhri-bench dataset record: stopped; its sessions are marked 'interrupted' "
              "(their finished episodes are kept, and left out of fit, export and recorded "
              "populations)", file=sys.stderr)
        return 143 if isinstance(exc, StudyTerminated) else 130
    except OSError as exc:
        return _cannot_write("dataset record", exc, args.data)
    print(f"recorded {cfg.runs} synthetic sessions of {cfg.n_episodes} episodes in "
          f"{dataset.dataset_id} ({dataset.path})")
    return 0


def _wait_for_enter() -> None:
    input()


def _replay(args: argparse.Namespace) -> int:
    MissingExtraError.require(["pyarrow"], "hri-bench replay")
    parser = args.command_parser
    _need_folder(parser, args.frames, "--frames")
    try:
        dataset = open_dataset(args.dataset, args.data)
        results = replay(dataset, args.participant, write=print, frames=args.frames,
                         pause=_wait_for_enter if args.step else None)
    except ConfigError as exc:
        _fail(parser, exc, {"dataset": "dataset", "participant": "--participant"})
    except (EOFError, KeyboardInterrupt):
        return 0
    except OSError as exc:
        return _cannot_write("replay", exc, args.frames)
    differ = [r for r in results if not r.agrees]
    print(f"{len(results)} episodes replayed; " + (
        "the env gives the recorded rewards, states, actions and episode ends in every step"
        if not differ else f"{len(differ)} differ from the recording:"))
    for r in differ[:10]:
        first = r.differences[0] if r.differences else (
            f"episode end (terminated, truncated): recorded {r.terminated[0], r.truncated[0]}, "
            f"the env's {r.terminated[1], r.truncated[1]}")
        print(f"  {r.participant} episode {r.episode + 1}: {first}"
              + (f" (and {len(r.differences) - 1} more steps)" if len(r.differences) > 1
                 else ""))
    return 1 if differ else 0


def run(args: argparse.Namespace) -> int:
    """Run one of :data:`COMMANDS` (parsed by the parsers of :func:`add_parsers`)."""
    if args.command == "serve":
        return _serve(args)
    if args.command == "replay":
        return _replay(args)
    if args.dataset_command == "record":
        return _record(args)
    return _dataset(args)
