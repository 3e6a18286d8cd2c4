"""The parsers of the ``hri-bench`` commands for people in the loop (``serve``, ``dataset``,
``replay``; :func:`add_parsers`), with the argument types they check and the flag each
:class:`~hri_bench.people.serve.ServeConfig` field comes from (:data:`SERVE_ARGUMENTS`).
:mod:`hri_bench.cli.people` runs the commands.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from hri_bench.people.serve.access import check_host_name
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.scenarios import SCENARIOS

#: ServeConfig field -> the flag it comes from.
SERVE_ARGUMENTS = {"scenario": "scenario", "agent": "--agent", "episodes": "--episodes",
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
