"""``hri-bench suite --physical``: the physical suite (robots that feel the human).

Its own flags (docs/physics.md, "The physical suite"); the graph suite's parser routes here
when ``--physical`` is given (:func:`wants_physical`).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from hri_bench.cli.args import as_flags, bounded, resume_hint, split_imports, whole
from hri_envs.errors import ActionError, ConfigError, MissingExtraError

__all__ = ["build_physical_parser", "main", "wants_physical"]


#: run_physical_suite's parameters as this command's flags (in its error messages).
_FLAGS = {"resume": "--resume", "overwrite": "--overwrite", "runs_scale": "--runs-scale",
          "agents": "--agents", "tracks": "--tracks", "jobs": "--jobs"}


def wants_physical(argv: Sequence[str]) -> bool:
    """Whether the command line asks for the physical suite (``suite ... --physical``)."""
    words = split_imports(argv)[1]
    return bool(words) and words[0] == "suite" and "--physical" in words[1:]


def build_physical_parser() -> argparse.ArgumentParser:
    """The parser of ``hri-bench suite --physical`` (its flags, apart from the graph suite's)."""
    from hri_bench.suite.physical_tracks import (  # noqa: PLC0415
        DEFAULT_AGENTS,
        PHYSICAL_LATEST,
        PHYSICAL_VERSIONS,
        TRACKS_P1,
    )

    p = argparse.ArgumentParser(
        prog="hri-bench suite --physical",
        description="Run the physical suite: robots that feel the human, ranked on the "
                    "held-out physical humans of the test split on the continuous envs' v1 "
                    "(*PandaContinuous-v1); write results.json, leaderboard.md and figures.")
    p.add_argument("--physical", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--out", required=True, type=Path,
                   help="output directory (new or empty, unless --resume or --overwrite)")
    p.add_argument("--suite-version", choices=PHYSICAL_VERSIONS, default=PHYSICAL_LATEST,
                   help=f"the physical track set (default {PHYSICAL_LATEST})")
    p.add_argument("--agents", default=None,
                   help="robots to rank, comma-separated (default: "
                        f"{','.join(DEFAULT_AGENTS)}; the upper reference and the passive "
                        "floor are always run)")
    p.add_argument("--tracks", default=None,
                   help=f"comma-separated tracks (default all: {', '.join(TRACKS_P1)})")
    p.add_argument("--jobs", type=bounded(int, "a whole number >= 1", lambda v: v >= 1),
                   default=1, help="worker processes (default 1)")
    p.add_argument("--runs-scale", type=bounded(float, "a number in (0, 10]",
                                                lambda v: math.isfinite(v) and 0 < v <= 10),
                   default=1.0, help="multiply every track's runs (default 1)")
    p.add_argument("--seed", type=whole, default=0, help="base seed, >= 0 (default 0)")
    p.add_argument("--resume", action="store_true",
                   help="continue the suite interrupted in --out (same settings)")
    p.add_argument("--overwrite", action="store_true",
                   help="start afresh in a non-empty --out")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return p


def main(argv: Sequence[str]) -> int:
    """Run ``hri-bench suite --physical ...`` (``argv`` without the program name)."""
    args = build_physical_parser().parse_args(split_imports(argv)[1][1:])
    from hri_bench.run.isolation import AgentProcessError  # noqa: PLC0415
    from hri_bench.suite.physical_running import run_physical_suite  # noqa: PLC0415

    agents = None if args.agents is None else [a.strip() for a in args.agents.split(",")
                                               if a.strip()]
    # before any simulation: the figures need matplotlib, the bar tqdm (the bench extra)
    MissingExtraError.require(["matplotlib", *([] if args.no_progress else ["tqdm"])],
                              "the physical suite's figures and progress bar")
    t0 = time.perf_counter()
    bar = None
    if not args.no_progress:
        from tqdm.auto import tqdm  # noqa: PLC0415  (the bench extra)

        bar = tqdm(unit="unit", desc="physical suite")

    def progress(done: int, total: int) -> None:
        if bar is not None:
            bar.total, bar.n = total, done
            bar.refresh()

    try:
        doc = run_physical_suite(args.out, version=args.suite_version, agents=agents,
                                 seeds=(args.seed,), runs_scale=args.runs_scale,
                                 jobs=args.jobs, tracks=args.tracks, resume=args.resume,
                                 overwrite=args.overwrite, progress=progress)
    except ConfigError as exc:
        print(f"hri-bench suite --physical: {as_flags(str(exc), _FLAGS)}", file=sys.stderr)
        return 2
    except (AgentProcessError, ActionError) as exc:  # a robot of one's own failed
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"hri-bench suite --physical: a robot failed: {first}\nThe finished units are "
              f"kept in {args.out}; fix the robot, then continue with:\n  "
              f"{resume_hint(argv)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"\nstopped; the finished units are kept in {args.out}. Resume with:\n  "
              f"{resume_hint(argv)}", file=sys.stderr)
        return 130
    finally:
        if bar is not None:
            bar.close()
    from hri_bench.suite.physical_board import headline_table  # noqa: PLC0415

    print(headline_table(doc))
    print(f"physical suite v{doc['suite_version']}: {len(doc['tracks'])} tracks in "
          f"{time.perf_counter() - t0:.1f} s (--jobs {args.jobs}); wrote "
          f"{args.out / 'results.json'}, {args.out / 'leaderboard.md'}, "
          f"{args.out / 'ranking.png'} and {args.out / 'goal_effort.png'}")
    return 0
