"""Real-time factor of the continuous envs on one core, beside raw ``mj_step`` of the scene.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/continuous_speed.py --scenario hanger

runs the env with the upper reference (whole episodes, seeds 0, 1, ...) for ``--seconds``
of wall time and reports simulated seconds per wall second and per CPU second of the
process (one thread: what one core gives when other jobs share the machine); then steps
the same compiled scene with ``mujoco.mj_step`` alone (from a state mid-episode, both
partners holding the object, the controls held) for as long. Wall-clock figures depend on
the machine's load (``uptime``'s load averages are printed).
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import mujoco
from threadpoolctl import threadpool_limits

import hri_envs  # noqa: F401
from baselines.continuous import UpperReference
from hri_envs.task.scenarios import scenario_spec


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenario", default="hanger", help="hanger (default) or wheel")
    p.add_argument("--drive", default="torque",
                   help="the human arm's drive: torque (default) or muscle")
    p.add_argument("--seconds", type=float, default=20.0,
                   help="simulated seconds per measurement (default 20)")
    args = p.parse_args()
    env = gym.make(str(scenario_spec(args.scenario).continuous_id), drive=args.drive)
    base = env.unwrapped
    policy = UpperReference()
    with threadpool_limits(1):
        steps, seed = 0, 0
        t0, c0 = time.perf_counter(), time.process_time()
        snapshot = None
        while time.perf_counter() - t0 < args.seconds:
            obs, _ = env.reset(seed=seed)
            seed += 1
            while True:
                obs, _, term, trunc, _ = env.step(policy.act(obs, base))
                steps += 1
                if steps == 60 and snapshot is None:
                    snapshot = mujoco.MjData(base.sim.model)
                    mujoco.mj_copyData(snapshot, base.sim.model, base.sim.data)
                if term or trunc:
                    break
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        env_rtf = steps * base.sim.dt_step / wall
        env_rtf_cpu = steps * base.sim.dt_step / cpu
        model = base.sim.model
        data = snapshot if snapshot is not None else base.sim.data
        n, t1, c1 = 0, time.perf_counter(), time.process_time()
        while time.perf_counter() - t1 < min(args.seconds, 10.0):
            mujoco.mj_step(model, data, nstep=100)
            n += 100
        raw_wall, raw_cpu = time.perf_counter() - t1, time.process_time() - c1
        raw_rtf = n * model.opt.timestep / raw_wall
        raw_rtf_cpu = n * model.opt.timestep / raw_cpu
    print(f"{args.scenario} ({args.drive}): env {steps} steps in {wall:.1f} s = "
          f"{steps / wall:.0f} steps/s, {env_rtf:.1f}x real time by the wall clock, "
          f"{env_rtf_cpu:.1f}x per CPU second of the process; raw mj_step "
          f"{n / raw_wall:.0f} steps/s, {raw_rtf:.1f}x real time by the wall clock, "
          f"{raw_rtf_cpu:.1f}x per CPU second (nv {model.nv}, nu {model.nu}); load average "
          f"{os.getloadavg()}")
    env.close()


if __name__ == "__main__":
    main()
