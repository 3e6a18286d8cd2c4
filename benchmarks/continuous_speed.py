"""Real-time factor of the continuous envs on one core, beside raw ``mj_step`` of the scene.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/continuous_speed.py --scenario hanger

runs the env with the upper reference (whole episodes, seeds 0, 1, ...) for ``--seconds``
of wall time and reports simulated seconds per wall second; then steps the same compiled
scene with ``mujoco.mj_step`` alone (from a state mid-episode, both partners holding the
object, the controls held) for as long. Timings depend on the machine's load: say what
else ran (``uptime``'s load averages are printed).
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
    p.add_argument("--scenario", default="hanger")
    p.add_argument("--drive", default="torque")
    p.add_argument("--seconds", type=float, default=20.0)
    args = p.parse_args()
    env = gym.make(str(scenario_spec(args.scenario).continuous_id), drive=args.drive)
    base = env.unwrapped
    policy = UpperReference()
    with threadpool_limits(1):
        steps, seed = 0, 0
        t0 = time.perf_counter()
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
        wall = time.perf_counter() - t0
        env_rtf = steps * base.sim.dt_step / wall
        model = base.sim.model
        data = snapshot if snapshot is not None else base.sim.data
        n, t1 = 0, time.perf_counter()
        while time.perf_counter() - t1 < min(args.seconds, 10.0):
            mujoco.mj_step(model, data, nstep=100)
            n += 100
        raw_wall = time.perf_counter() - t1
        raw_rtf = n * model.opt.timestep / raw_wall
    print(f"{args.scenario} ({args.drive}): env {steps} steps in {wall:.1f} s = "
          f"{steps / wall:.0f} steps/s, {env_rtf:.1f}x real time; raw mj_step "
          f"{n / raw_wall:.0f} steps/s, {raw_rtf:.1f}x real time (nv {model.nv}, "
          f"nu {model.nu}); load average {os.getloadavg()}")
    env.close()


if __name__ == "__main__":
    main()
