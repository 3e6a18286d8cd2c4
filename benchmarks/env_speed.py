"""Environment throughput: PettingZoo joint steps/s and vector-env steps/s.

    .venv/bin/python benchmarks/env_speed.py [--num-envs 1024] [--cpu-time] [--repeats 3]

Targets (an idle 2-core machine): parallel env >= 300,000 joint steps/s, vector env with 1024
envs >= 20,000,000 env steps/s. The measuring code lives in hri_envs.envs.speed (also used by
``hri-bench speed``). ``--cpu-time`` times with the measuring thread's CPU time instead of
wall time: on a machine loaded by other jobs it stays close to the idle figure (give it more
``--repeats``; the fastest counts).
"""

from __future__ import annotations

import argparse
import time

from hri_envs.envs.speed import parallel_env_steps_per_s, vector_env_steps_per_s

PARALLEL_TARGET = 300_000
VECTOR_TARGET = 20_000_000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=1024,
                        help="envs of the vector env (default 1024)")
    parser.add_argument("--scenario", choices=["hanger", "wheel", "both"], default="both",
                        help="the scenario to time (default both)")
    parser.add_argument("--cpu-time", action="store_true",
                        help="time with the thread's CPU time (for a loaded machine)")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats; the best counts")
    args = parser.parse_args()
    clock = time.thread_time if args.cpu_time else time.perf_counter
    scenarios = ["hanger", "wheel"] if args.scenario == "both" else [args.scenario]
    for scenario in scenarios:
        par = parallel_env_steps_per_s(scenario, repeats=args.repeats, clock=clock)
        vec = vector_env_steps_per_s(args.num_envs, scenario, repeats=args.repeats, clock=clock)
        print(f"{scenario:6s} parallel env: {par.steps_per_s:12,.0f} joint steps/s "
              f"(target {PARALLEL_TARGET:,})")
        print(f"{scenario:6s} vector env ({args.num_envs} envs): {vec.steps_per_s:12,.0f} "
              f"env steps/s (target {VECTOR_TARGET:,})")


if __name__ == "__main__":
    main()
