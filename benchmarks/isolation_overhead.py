"""What running agents of one's own in a process of their own costs: a suite with
``module:Class`` agents, isolated (the default) and in the benchmark's process
(``HRI_BENCH_IN_PROCESS_AGENTS=1``), alternately.

    .venv/bin/python benchmarks/isolation_overhead.py [--runs-scale 0.25] [--repeats 2]
        [--jobs 2] [--agents baselines.countqmdp:CountQMDP,examples.custom_learner:GoalMemory]

Each run is a whole ``hri-bench suite`` process (start-up, every track, every file written);
it prints each wall time, the ratio of the medians (goal: at most 1.25) and the load average.
The two runs of a pair write byte-identical ``results.json`` (the host changes what an agent
sees, not what it does), which the script checks.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _suite(out: Path, args: argparse.Namespace, in_process: bool) -> float:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("HRI_BENCH_IN_PROCESS_AGENTS", None)
    if in_process:
        env["HRI_BENCH_IN_PROCESS_AGENTS"] = "1"
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "hri_bench.cli", "suite", "--out", str(out),
                    "--runs-scale", str(args.runs_scale), "--jobs", str(args.jobs),
                    "--agents", args.agents, "--no-progress"], env=env, check=True,
                   stdout=subprocess.DEVNULL, cwd=ROOT)
    return time.perf_counter() - t0


def main() -> None:
    """Time the suite both ways and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs-scale", type=float, default=0.25,
                        help="the suite's --runs-scale (default 0.25)")
    parser.add_argument("--repeats", type=int, default=2,
                        help="pairs of runs, isolated then in-process (default 2)")
    parser.add_argument("--jobs", type=int, default=2, help="the suite's --jobs (default 2)")
    parser.add_argument("--agents", default="baselines.countqmdp:CountQMDP,"
                                            "examples.custom_learner:GoalMemory",
                        help="the agents of one's own (module:Class, comma-separated)")
    args = parser.parse_args()
    times: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeats):
            for in_process in (False, True):
                out = Path(tmp) / f"{i}-{in_process}"
                times[in_process].append(_suite(out, args, in_process))
                print(f"{'in-process' if in_process else 'isolated  '} run {i + 1}: "
                      f"{times[in_process][-1]:.1f} s (load {os.getloadavg()[0]:.1f})",
                      flush=True)
            same = ((Path(tmp) / f"{i}-False" / "results.json").read_bytes()
                    == (Path(tmp) / f"{i}-True" / "results.json").read_bytes())
            print(f"  results.json identical: {same}", flush=True)
    iso, here = statistics.median(times[False]), statistics.median(times[True])
    print(f"isolated {iso:.1f} s, in-process {here:.1f} s (medians of {args.repeats}): "
          f"ratio {iso / here:.3f} (goal <= 1.25); agents {args.agents}, runs scale "
          f"{args.runs_scale}, --jobs {args.jobs}, {os.cpu_count()} cpus")


if __name__ == "__main__":
    main()
