"""Physics backend speed: real-time factor and wall seconds per abstract step.

    .venv/bin/python benchmarks/physics_speed.py [--scenario hanger|wheel] [--async N [--seconds S]]

Targets (2-core machine): >= 20x real time on one core for the Panda + object + embodied
human (2 ms physics steps, control at 125 Hz, mink IK at 25 Hz); with ``--async N``: >= 50
abstract steps/s summed over N Panda envs in Gymnasium's AsyncVectorEnv (random valid
actions). The measuring code is hri_envs.physics.panda.speed.
"""

from __future__ import annotations

import argparse

from hri_envs.physics.panda.speed import (
    async_steps_per_second,
    physics_realtime_factor,
    seconds_per_abstract_step,
)
from hri_envs.task.scenarios import scenario_graph

TARGET = 20.0
ASYNC_TARGET = 50.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", choices=["hanger", "wheel"], default="hanger",
                        help="the scenario to time (default hanger)")
    parser.add_argument("--async", dest="num_envs", type=int, default=0, metavar="N",
                        help="measure N envs in an AsyncVectorEnv instead (one process each)")
    parser.add_argument("--seconds", type=float, default=30.0,
                        help="wall seconds of the --async measurement")
    args = parser.parse_args()
    if args.num_envs:
        res = async_steps_per_second(scenario_graph(args.scenario), args.num_envs, args.seconds)
        print(f"{args.scenario}: {res.abstract_steps / res.wall_seconds:5.1f} abstract steps/s "
              f"summed over {args.num_envs} async envs ({res.abstract_steps} steps in "
              f"{res.wall_seconds:.1f} s, {res.sim_seconds / res.abstract_steps:.2f} simulated "
              f"s each; target {ASYNC_TARGET:.0f})")
        return
    rt = physics_realtime_factor(scenario_graph(args.scenario))
    print(f"{args.scenario}: real-time factor {rt.realtime_factor:5.1f}x "
          f"({rt.sim_seconds:.1f} s simulated in {rt.wall_seconds:.2f} s; per CPU second "
          f"{rt.cpu_realtime_factor:.1f}x; target {TARGET:.0f}x)")
    ep = seconds_per_abstract_step(scenario_graph(args.scenario))
    print(f"{args.scenario}: {ep.seconds_per_step:.3f} wall s per abstract step "
          f"({ep.abstract_steps} steps, {ep.sim_seconds / ep.abstract_steps:.2f} simulated s "
          f"each, real-time factor {ep.realtime_factor:.1f}x, per CPU second "
          f"{ep.cpu_realtime_factor:.1f}x)")


if __name__ == "__main__":
    main()
