"""Speed of the continuous envs on the C backend (one core) and on MuJoCo Warp (N worlds).

The C backend's real-time factor, and world-steps per second of N worlds on MuJoCo Warp
beside it:

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/continuous_speed.py --scenario hanger
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/continuous_speed.py --backend both \\
        --worlds 1,64,1024

``--backend mujoco`` (the default) runs the env with the upper reference (whole episodes,
seeds 0, 1, ...) for ``--seconds`` of wall time (after one untimed reset and step, which
load the compiled control periods, or compile them on a cold cache: the time is printed)
and reports simulated seconds per wall second and per CPU second of the process (one
thread: what one core gives when other jobs share the machine), beside raw ``mj_step`` of
the same compiled scene, two ways:

* *raw, the env's states* (what the ratio env / raw is taken against): the physics state at
  the start of every tenth env step is kept (``mj_getState``, the full integration state
  with the controls and applied forces), and each is stepped 20 times (one env step's
  physics, 40 ms) with its controls held, one after the other; only ``mj_step`` is timed.
  This is the physics the env itself runs: the same contacts (hand on the handle, object
  on its supports), the same solver work. The env and this raw stepping take turns of
  0.25 s of wall time each, so both meet the same load of the machine;
* *raw, one state run on* (the earlier figure, kept for comparison), after the turns: from
  the state at the 60th env step (both partners holding the object) the scene runs on with
  the controls held for ``min(--seconds, 10)`` s. Left alone, the handle slips out of the
  still hand after about 40 simulated seconds and the object swings free without contacts
  for the rest of the run, so this figure times mostly a cheaper scene than the env's
  (hanger about 16 µs per physics step against 24 µs for the env's own states).

The ratio env / raw is printed per CPU second and by the wall clock; ``--runs N`` measures
N times in the process and prints its range.

``--backend mjwarp`` steps N worlds of the same scene together on MuJoCo Warp
(:class:`~hri_envs.physics.carry.warp.worlds.WarpCarryWorlds`, Warp's default device or
``--device``) for each N of ``--worlds``: every world a copy of one reset (start B, the
human's goal A; a reset costs a C IK solve per world, which is not timed), the upper
reference acting in every world, ``--steps`` env steps of 40 ms timed after one untimed
step. A *world-step* is one 2 ms physics step of one world; the real-time factor is the
simulated seconds of all worlds per wall second. ``--backend both`` measures the C backend
first in the same run (its world-steps/s: the env's physics steps per wall second).

Wall-clock figures depend on the machine's load (``os.getloadavg()`` is printed).
"""

from __future__ import annotations

import argparse
import os
import time
from types import SimpleNamespace

import numpy as np

import hri_envs  # noqa: F401
from baselines.continuous import follow_action
from hri_bench.report.continuous_speed import c_speed
from hri_envs.task.scenarios import scenario_graph


def warp_speed(scenario: str, n_worlds: int, steps: int,
               device: str | None) -> dict[str, float | str]:
    """N worlds on MuJoCo Warp with the upper reference in each (see the module)."""
    from hri_envs.physics.carry.warp.sim import WarpCarrySim
    from hri_envs.physics.carry.warp.worlds import WarpCarryWorlds

    t0 = time.perf_counter()
    worlds = WarpCarryWorlds(scenario_graph(scenario), n_worlds, device=device)
    worlds.reset_world(0, 1, 0, np.random.default_rng(0))
    if n_worlds > 1:
        worlds.copy_world(0, np.arange(1, n_worlds))
    views = [SimpleNamespace(sim=WarpCarrySim(worlds, i)) for i in range(n_worlds)]
    rows, active = np.arange(n_worlds), np.ones(n_worlds, dtype=bool)

    scale = SimpleNamespace(max_step_m=worlds.max_step_m, max_step_rad=worlds.max_step_rad)

    def one_step() -> None:
        actions = np.stack([follow_action(scale, v.sim.grip_pose(),  # type: ignore[arg-type]
                                          v.sim.human_grip_reference()) for v in views])
        worlds.step(worlds.commands(rows, actions), active)

    one_step()  # the first run on a machine compiles Warp's kernels here
    setup = time.perf_counter() - t0
    t1 = time.perf_counter()
    for _ in range(steps):
        one_step()
    wall = time.perf_counter() - t1
    world_steps = n_worlds * steps * round(worlds.dt_step / worlds.dt)
    return {"worlds": n_worlds, "device": worlds.device, "setup_s": setup, "wall": wall,
            "world_steps_per_s": world_steps / wall, "rtf": world_steps * worlds.dt / wall}


def _print_c(scenario: str, drive: str, c: dict[str, float]) -> None:
    print(f"{scenario} ({drive}), C backend: env {c['steps']} steps in "
          f"{c['wall']:.1f} s = {c['world_steps_per_s']:.0f} world-steps/s, "
          f"{c['env_rtf']:.1f}x real time by the wall clock, {c['env_rtf_cpu']:.1f}x per "
          f"CPU second of the process (nv {c['nv']}, nu {c['nu']}; the untimed first "
          f"reset and step before, which load or compile the kernels: {c['first_s']:.1f} s)")
    print(f"  raw mj_step, the env's states ({c['replay_states']} states x 20 steps): "
          f"{c['replay_steps_per_s']:.0f} steps/s, {c['replay_rtf']:.1f}x real time by "
          f"the wall clock, {c['replay_rtf_cpu']:.1f}x per CPU second; env / raw "
          f"{c['env_rtf_cpu'] / c['replay_rtf_cpu']:.2f} per CPU second, "
          f"{c['env_rtf'] / c['replay_rtf']:.2f} by the wall clock")
    print(f"  raw mj_step, one state run on (the earlier figure): "
          f"{c['raw_steps_per_s']:.0f} steps/s, {c['raw_rtf']:.1f}x real time by the wall "
          f"clock, {c['raw_rtf_cpu']:.1f}x per CPU second; env / raw "
          f"{c['env_rtf_cpu'] / c['raw_rtf_cpu']:.2f} per CPU second; "
          f"load average {os.getloadavg()}", flush=True)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenario", default="hanger", help="hanger (default) or wheel")
    p.add_argument("--drive", default="torque",
                   help="the human arm's drive: torque (default) or muscle (C backend only)")
    p.add_argument("--seconds", type=float, default=20.0,
                   help="wall seconds of the C backend's measurement (default 20)")
    p.add_argument("--backend", default="mujoco", choices=("mujoco", "mjwarp", "both"),
                   help="mujoco: the C backend (default); mjwarp: N worlds on MuJoCo Warp; "
                        "both: the C backend, then MuJoCo Warp, in one run")
    p.add_argument("--worlds", default="1,64,1024",
                   help="numbers of worlds on MuJoCo Warp, comma-separated (default 1,64,1024)")
    p.add_argument("--steps", type=int, default=10,
                   help="timed env steps (40 ms) per number of worlds on MuJoCo Warp "
                        "(default 10)")
    p.add_argument("--device", default=None,
                   help="Warp's device, e.g. cpu or cuda:0 (default: Warp's default, a GPU "
                        "where there is one)")
    p.add_argument("--runs", type=int, default=1,
                   help="C backend: measure this many times in the process (default 1); "
                        "the range of env / raw is printed")
    args = p.parse_args()
    print(f"load average before: {os.getloadavg()}")
    if args.backend in ("mujoco", "both"):
        ratios: list[tuple[float, float]] = []
        for _ in range(args.runs):
            c = c_speed(args.scenario, args.drive, args.seconds)
            ratios.append((c["env_rtf_cpu"] / c["replay_rtf_cpu"], c["env_rtf"] / c["replay_rtf"]))
            _print_c(args.scenario, args.drive, c)
        if args.runs > 1:
            cpu, wall = zip(*ratios, strict=True)
            print(f"{args.scenario} ({args.drive}), env / raw over {args.runs} runs: "
                  f"{min(cpu):.2f}-{max(cpu):.2f} per CPU second, {min(wall):.2f}-{max(wall):.2f} "
                  f"by the wall clock", flush=True)
    if args.backend in ("mjwarp", "both"):
        for n in (int(x) for x in args.worlds.split(",")):
            w = warp_speed(args.scenario, n, args.steps, args.device)
            print(f"{args.scenario} (torque), MuJoCo Warp on {w['device']}, {n} worlds: "
                  f"{w['world_steps_per_s']:.0f} world-steps/s, real-time factor "
                  f"{w['rtf']:.2f} (all worlds; {args.steps} steps in {w['wall']:.1f} s, set-up "
                  f"{w['setup_s']:.1f} s); load average {os.getloadavg()}", flush=True)


if __name__ == "__main__":
    main()
