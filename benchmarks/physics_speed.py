"""Physics backend speed: real-time factor and wall seconds per abstract step.

    python benchmarks/physics_speed.py [--scenario hanger|wheel]

Target (2-core machine): >= 10x real time for the Panda + object + impedance controller at
a 2 ms physics step with mink IK at 50 Hz. The measuring code is hri_envs.physics.speed.
"""

from __future__ import annotations

import argparse

from hri_envs.physics.speed import physics_realtime_factor, seconds_per_abstract_step

TARGET = 10.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", choices=["hanger", "wheel"], default="hanger")
    args = parser.parse_args()
    rt = physics_realtime_factor(args.scenario)
    print(f"{args.scenario}: real-time factor {rt.realtime_factor:5.1f}x "
          f"({rt.sim_seconds:.1f} s simulated in {rt.wall_seconds:.2f} s; target {TARGET:.0f}x)")
    ep = seconds_per_abstract_step(args.scenario)
    print(f"{args.scenario}: {ep.seconds_per_step:.3f} wall s per abstract step "
          f"({ep.abstract_steps} steps, {ep.sim_seconds / ep.abstract_steps:.2f} simulated s "
          f"each, real-time factor {ep.realtime_factor:.1f}x)")


if __name__ == "__main__":
    main()
