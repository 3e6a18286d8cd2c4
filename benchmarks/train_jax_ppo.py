"""Train the recurrent PPO robot in JAX against a population, draw its learning curve.

1. Train :mod:`agents.jax_ppo` (GRU actor-critic, PPO; rollouts, GAE and updates under one
   ``jit``) on :class:`hri_envs.jax.JaxRobotEnv`, in trials of the scenario's study length
   (hanger 8, wheel 20 episodes) with one human of the training population each.
2. Save ``OUT/<scenario>.npz`` (arrays + JSON config, no pickle), ``OUT/<scenario>_curve.json``
   and ``OUT/<scenario>_curve.png`` (mean episode return per update, against env steps, with a
   random valid-action policy's level for reference).
3. Rank it beside the Learner: ``hri-bench suite --agents learner,jaxppo:OUT``.

    .venv/bin/python benchmarks/train_jax_ppo.py --scenario hanger --total-steps 50000000
    .venv/bin/python benchmarks/train_jax_ppo.py --scenario wheel --total-steps 50000000

Same ``--seed``, same weights (on the same machine and JAX version).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import tyro

from agents.jax_ppo.train import TrainConfig, random_policy_return, train
from hri_envs.errors import ConfigError
from hri_envs.jax.speed import device_name


def draw_curve(curve: dict, random_level: float, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.6))
    steps = np.asarray(curve["steps"]) / 1e6
    ax.plot(steps, curve["episode_return"], label="recurrent PPO (training episodes)")
    by_ep = np.asarray(curve["return_by_episode"])
    ax.plot(steps, by_ep[:, 0], linewidth=0.8, alpha=0.7, label="its 1st episode with a human")
    ax.plot(steps, by_ep[:, -1], linewidth=0.8, alpha=0.7,
            label=f"its {by_ep.shape[1]}th episode with a human")
    ax.axhline(random_level, color="grey", linestyle="--", label="random valid actions")
    ax.set_xlabel("env steps [millions]")
    ax.set_ylabel("robot reward per episode")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(cfg: Annotated[TrainConfig, tyro.conf.arg(name="")],
         out: Path = Path("out/jaxppo")) -> None:
    """Train, save the checkpoint, write and draw the learning curve.

    Args:
        cfg: The training settings (:class:`agents.jax_ppo.train.TrainConfig`; a scripted
            population's rate ranges are ``--passive LOW HIGH`` and ``--turn-back LOW HIGH``).
        out: Folder for the checkpoint, the curve and its figure.
    """
    cfg.check()
    print(f"training on {device_name()}: {cfg.scenario}, population {cfg.population}, "
          f"{cfg.updates} updates of {cfg.steps_per_update:,} steps, trials of "
          f"{cfg.trial_length()} episodes", flush=True)
    t0 = time.perf_counter()
    path = out / f"{cfg.scenario}.npz"
    result = train(cfg, log=lambda line: print(line, flush=True), save_to=str(path))
    wall = time.perf_counter() - t0
    steps = cfg.updates * cfg.steps_per_update
    steady = steps / max(sum(result.curve["seconds"]) - result.compile_seconds, 1e-9)
    level = random_policy_return(cfg)
    doc = {"config": cfg.to_dict(), "device": device_name(), "wall_seconds": round(wall, 1),
           "compile_seconds": round(result.compile_seconds, 1), "steps": steps,
           "train_steps_per_s": round(steady), "random_policy_return": level,
           "load_average": list(os.getloadavg()),
           "curve": {k: np.round(v, 4).tolist() for k, v in result.curve.items()}}
    (out / f"{cfg.scenario}_curve.json").write_text(  # compact, 4 decimals: shipped in docs/
        json.dumps(doc, separators=(",", ":")) + "\n")
    draw_curve(result.curve, level, out / f"{cfg.scenario}_curve.png",
               f"{cfg.scenario}: recurrent PPO in JAX, population {cfg.population} "
               f"(seed {cfg.seed})")
    print(f"trained {steps:,} steps in {wall:.0f} s ({steady:,.0f} steps/s after "
          f"{result.compile_seconds:.0f} s compiling); final episode return "
          f"{result.curve['episode_return'][-1]:.3f} (random valid actions {level:.3f})")
    print(f"wrote {path}; rank it: .venv/bin/hri-bench suite --agents learner,jaxppo:"
          f"{out} --out out/suite-jaxppo")


if __name__ == "__main__":
    try:
        tyro.cli(main)
    except ConfigError as exc:  # a bad value: one line naming it, exit 2 (as hri-bench)
        print(f"train_jax_ppo.py: error: {exc}", file=sys.stderr)
        sys.exit(2)
