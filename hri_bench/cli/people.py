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
import math
import os
import stat
import sys
import textwrap
from pathlib import Path
from typing import Any

from agents.config import default_config
from hri_bench.data import datasets
from hri_bench.data import fit as fitting
from hri_bench.data.datasets import create_dataset, open_dataset
from hri_bench.data.replay import replay
from hri_bench.people.recording import record_study
from hri_bench.people.serve import ServeConfig, require_web, serve
from hri_bench.people.serve.access import check_host_name
from hri_bench.run.study import StudyConfig
from hri_bench.run.studyio import StudyTerminated, stop_on_signals
from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.scenarios import SCENARIOS, scenario_spec

__all__ = ["COMMANDS", "add_parsers", "run"]

#: The subcommands this module adds.
COMMANDS = ("serve", "dataset", "replay")

#: ServeConfig field -> the flag it comes from.
_SERVE_ARGUMENTS = {"scenario": "scenario", "agent": "--agent", "episodes": "--episodes",
                    "physical": "--physical", "max_time_s": "--max-time",
                    "dataset": "--dataset", "data": "--data", "host": "--host",
                    "allowed_hosts": "--allow-host",
                    "port": "--port", "seed": "--seed", "max_steps": "--max-steps",
                    "r0": "--r0", "reward": "--reward", "preferences": "--preferences",
                    "instructions": "--instructions", "consent": "--consent",
                    "max_sessions": "--max-sessions", "idle_timeout_s": "--idle-timeout",
                    "agent_timeout_s": "--agent-timeout"}


def _whole(low: int, high: int | None = None) -> Any:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < low or (high is not None and value > high):
            bound = f">= {low}" if high is None else f"in [{low}, {high}]"
            raise argparse.ArgumentTypeError(f"expected a whole number {bound}, got {text!r}")
        return value

    return parse


def _real(ok: Any, allowed: str) -> Any:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and ok(value)):
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}")
        return value

    return parse


def _host_name(text: str) -> str:
    try:
        return check_host_name(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


#: The help of every ``--data`` flag.
_DATA_HELP = "the datasets' root folder (default: $HRI_BENCH_DATASETS, else ~/.hri-bench/datasets)"


def add_parsers(sub: Any) -> None:
    """Add ``serve``, ``dataset`` and ``replay`` to the ``hri-bench`` subparsers."""
    _serve_parser(sub)
    _dataset_parsers(sub)
    _replay_parser(sub)


def _serve_parser(sub: Any) -> None:
    """``serve``: the web page, the robot, the design and the limits of the server."""
    serve = sub.add_parser("serve", help="play the human in a browser; sessions are recorded",
                           description="Serve a web page where a person plays the human "
                           "against a robot agent that learns across the session's episodes; "
                           "every session is recorded as a dataset (docs/people.md).")
    serve.add_argument("scenario", choices=SCENARIOS, nargs="?", default="hanger")
    serve.add_argument("--agent", default=None,
                       help="the robot: an agent name as for 'study --agents' (default "
                            "learner; sb3:PATH, module:Class; not oracle, informed, blind, "
                            "qmdp); with --physical a physical robot (default: the best "
                            "shipped one)")
    serve.add_argument("--max-time", type=_real(lambda v: 1 <= v <= 3600,
                                                "seconds in [1, 3600]"), default=None,
                       help="with --physical: the time limit per episode (default: the "
                            "env's, 30 s hanger, 45 s wheel)")
    serve.add_argument("--physical", action="store_true",
                       help="the continuous physical task: the participant leads the "
                            "simulated arm's hand with the mouse, a finger or the keys "
                            "(docs/people.md, 'Leading the arm')")
    serve.add_argument("--episodes", type=_whole(1, 1000), default=8,
                       help="episodes per session (default 8)")
    serve.add_argument("--dataset", default=None,
                       help="dataset id to record in (default <scenario>-people-v0)")
    serve.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    serve.add_argument("--host", default="127.0.0.1",
                       help="address to bind (default 127.0.0.1: this machine only)")
    serve.add_argument("--port", type=_whole(0, 65535), default=8000,
                       help="TCP port (default 8000; 0: any free port)")
    serve.add_argument("--allow-host", action="append", type=_host_name, default=None,
                       metavar="NAME[:PORT]",
                       help="a name the server answers to besides the address it listens "
                            "on, e.g. this machine's name or a TLS proxy's (repeatable; "
                            "requests naming another host are refused, against DNS "
                            "rebinding)")
    serve.add_argument("--seed", type=_whole(0), default=0, help="base seed (default 0)")
    serve.add_argument("--max-steps", type=_whole(1, 10_000), default=60,
                       help="step limit per episode (default 60)")
    serve.add_argument("--r0", type=_real(lambda v: -1 < v < 0, "a number in (-1, 0)"),
                       default=None, help="the robot's waiting reward (default: the scenario's)")
    serve.add_argument("--reward", choices=tuple(REWARD_RULES), default="paper",
                       help="reward rule: " + ", ".join(REWARD_RULES) + " (default paper)")
    serve.add_argument("--preferences", default=None,
                       help="preferences participants are asked to follow, counterbalanced "
                            "(comma-separated, or 'all'; default: none asked for)")
    serve.add_argument("--instructions", type=Path, default=None,
                       help="a text file of instructions ({object}, {supports} filled in)")
    serve.add_argument("--consent", type=Path, default=None,
                       help="a text file shown for consent before a session starts ({object}, "
                            "{supports} filled in)")
    serve.add_argument("--show-belief", action="store_true",
                       help="show the robot's belief about the goal while playing")
    serve.add_argument("--max-sessions", type=_whole(1, 1000), default=50,
                       help="sessions at once (default 50)")
    serve.add_argument("--idle-timeout", type=_real(lambda v: 1 <= v <= 604800,
                                                    "seconds in [1, 604800]"),
                       default=1800.0, help="close a session idle this long (default 1800 s; "
                                            "one nobody has played after 30 s without its page)")
    serve.add_argument("--agent-timeout", type=_real(lambda v: 0.1 <= v <= 86400,
                                                     "seconds in [0.1, 86400]"),
                       default=60.0, help="end a session whose robot takes longer than this "
                                          "for one call (making it, a step, its learning "
                                          "after an episode; default 60 s, and never "
                                          "longer than --idle-timeout)")
    serve.set_defaults(command_parser=serve)


def _dataset_parsers(sub: Any) -> None:
    """``dataset list|show|export|record|fit``."""
    ds = sub.add_parser("dataset", help="list, show, export, record or fit recorded datasets",
                        description="Recorded sessions (docs/people.md, 'Datasets').")
    ds_sub = ds.add_subparsers(dest="dataset_command", required=True, metavar="ACTION")
    listing = ds_sub.add_parser("list", help="the datasets under the root")
    listing.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    listing.add_argument("--json", action="store_true", help="one JSON document")
    show = ds_sub.add_parser("show", help="a dataset's metadata, counts, hash and sessions")
    show.add_argument("dataset", help="dataset id (or a dataset folder)")
    show.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    show.add_argument("--json", action="store_true", help="one JSON document")
    export = ds_sub.add_parser("export", help="write the steps as one Parquet file, or the "
                               "robot's view as a Minari dataset")
    export.add_argument("dataset", help="dataset id (or a dataset folder)")
    export.add_argument("--format", choices=("parquet", "minari"), default="parquet")
    export.add_argument("--out", type=Path, default=None,
                        help="the Parquet file, or the Minari root folder (default: "
                             "<dataset>/minari for minari; required for parquet)")
    export.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    record = ds_sub.add_parser("record", help="record scripted humans' sessions (synthetic)")
    record.add_argument("scenario", choices=SCENARIOS)
    record.add_argument("--dataset", required=True, help="dataset id (synthetic data only)")
    record.add_argument("--agent", default="learner", help="the robot (default learner)")
    record.add_argument("--sessions", type=_whole(1, 10_000), default=10,
                        help="sessions (one scripted participant each; default 10)")
    record.add_argument("--episodes", type=_whole(1, 1000), default=None,
                        help="episodes per session (default: the scenario's)")
    record.add_argument("--preference", default=None, help="the scripted humans' preference "
                        "(or 'all')")
    record.add_argument("--population", default=None, help="draw each session's human from "
                        "a population")
    record.add_argument("--human-rationality", type=_real(lambda v: v > 0, "a number > 0"),
                        default=math.inf, metavar="BETA", help="Boltzmann humans (default inf)")
    record.add_argument("--human-passive", type=_real(lambda v: 0 <= v <= 1, "a probability"),
                        default=0.0, help="probability of waiting in a step")
    record.add_argument("--seed", type=_whole(0), default=0, help="base seed (default 0)")
    record.add_argument("--max-steps", type=_whole(1, 10_000), default=100,
                        help="step limit per episode (default 100)")
    record.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    fit = ds_sub.add_parser("fit", help="fit human models to the training participants and "
                            "score them on the held-out ones")
    fit.add_argument("dataset", help="dataset id (or a dataset folder)")
    fit.add_argument("--smoothing", type=_real(lambda v: v > 0, "a number > 0"), default=1.0,
                     help="behaviour cloning's smoothing α (default 1)")
    fit.add_argument("--out", type=Path, default=None,
                     help="a folder for the models (bc.npz, irl.npz; a physical dataset's: "
                          "<dataset>.population.json)")
    fit.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    for p in (listing, show, export, record, fit):
        p.set_defaults(command_parser=p)


def _replay_parser(sub: Any) -> None:
    """``replay``: a recorded session, step by step."""
    rep = sub.add_parser("replay", help="re-play a recorded session step by step",
                         description="Re-play recorded sessions in the env: a log line per "
                                     "step and, with --frames, the pictures.")
    rep.add_argument("dataset", help="dataset id (or a dataset folder)")
    rep.add_argument("--participant", action="append", default=None,
                     help="whose session (repeatable; default: all)")
    rep.add_argument("--frames", type=Path, default=None, help="write each step's picture here")
    rep.add_argument("--step", action="store_true", help="wait for Enter after each step")
    rep.add_argument("--data", type=Path, default=None, help=_DATA_HELP)
    rep.set_defaults(command_parser=rep)


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
        create_dataset(config.dataset_id, config.scenario, synthetic=False, root=config.data,
                       physical=config.physical)
    except ConfigError as exc:
        _fail(parser, exc, _SERVE_ARGUMENTS)
    try:
        serve(config)
    except ConfigError as exc:  # another server records into the dataset, say
        _fail(parser, exc, _SERVE_ARGUMENTS)
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
