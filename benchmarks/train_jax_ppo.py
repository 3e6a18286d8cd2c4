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
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np
import tyro

from agents.jax_ppo.train import TrainConfig, make_env, train
from hri_envs.jax.env import uniform
from hri_envs.jax.speed import device_name


@dataclass
class Config:
    scenario: Literal["hanger", "wheel"] = "hanger"
    """the task"""
    population: str = "train"
    """the training population: the frozen train split (default), or a scripted population
    (the evaluation splits and the held-out population are refused)"""
    passive_max: float | None = None
    """a scripted population only: each human's passive rate drawn in [0, passive_max]"""
    turn_back_max: float | None = None
    """a scripted population only: each human's turning-back rate drawn in
    [0, turn_back_max]"""
    total_steps: int = 20_000_000
    """env steps to train for"""
    num_envs: int = 1024
    """envs stepped together"""
    rollout: int = 32
    """steps per env between updates"""
    hidden: int = 32
    """GRU width"""
    lr: float = 2e-3
    """Adam's learning rate (annealed to 0)"""
    seed: int = 0
    """every draw derives from it"""
    out: Path = Path("out/jaxppo")
    """folder for the checkpoint, the curve and its figure"""


def random_policy_return(cfg: TrainConfig, steps: int = 400, n: int = 2048) -> float:
    """Mean episode return of a uniform random valid-action robot in the training env."""
    env = make_env(cfg)
    params = env.default_params

    @jax.jit
    def run(key: jax.Array) -> jax.Array:
        obs, state = env.reset_batch(key, n, params)

        def body(carry: tuple, t: jax.Array) -> tuple:
            obs, state, ret, total, count = carry
            seed = jax.random.bits(jax.random.fold_in(key, 2 * t), (2,), jnp.uint32)
            u = uniform(seed, jnp.arange(n, dtype=jnp.uint32), 0)
            mask = obs["action_mask"].astype(jnp.float32)
            cum = jnp.cumsum(mask / mask.sum(-1, keepdims=True), -1)
            action = jnp.minimum(jnp.sum(u[:, None] >= cum, -1), mask.shape[-1] - 1)
            obs, state, r, done, _ = env.step_batch(jax.random.fold_in(key, 2 * t + 1), state,
                                                    action, params)
            ret = ret + r
            total, count = total + jnp.sum(ret * done), count + jnp.sum(done)
            return (obs, state, ret * ~done, total, count), None

        zero = jnp.zeros(())
        (_, _, _, total, count), _ = jax.lax.scan(body, (obs, state, jnp.zeros(n), zero, zero),
                                                  jnp.arange(steps))
        return total / count

    return float(run(jax.random.key(cfg.seed + 1)))


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


def _rounded(x: object, digits: int = 4) -> object:
    """``x`` with every float rounded to ``digits`` decimals (the curve JSON is shipped)."""
    if isinstance(x, float):
        return round(x, digits)
    if isinstance(x, dict):
        return {k: _rounded(v, digits) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_rounded(v, digits) for v in x]
    return x


def main(args: Config) -> None:
    cfg = TrainConfig(scenario=args.scenario, population=args.population,
                      passive=None if args.passive_max is None else (0.0, args.passive_max),
                      turn_back=None if args.turn_back_max is None else (
                          0.0, args.turn_back_max),
                      total_steps=args.total_steps, num_envs=args.num_envs,
                      rollout=args.rollout, hidden=args.hidden, lr=args.lr, seed=args.seed)
    print(f"training on {device_name()}: {cfg.scenario}, population {cfg.population}, "
          f"{cfg.updates} updates of {cfg.steps_per_update:,} steps, trials of "
          f"{cfg.trial_length()} episodes", flush=True)
    t0 = time.perf_counter()
    path = args.out / f"{args.scenario}.npz"
    result = train(cfg, log=lambda line: print(line, flush=True), save_to=str(path))
    wall = time.perf_counter() - t0
    steps = cfg.updates * cfg.steps_per_update
    steady = steps / max(sum(result.curve["seconds"]) - result.compile_seconds, 1e-9)
    level = random_policy_return(cfg)
    doc = {"config": cfg.to_dict(), "device": device_name(), "wall_seconds": round(wall, 1),
           "compile_seconds": round(result.compile_seconds, 1), "steps": steps,
           "train_steps_per_s": round(steady), "random_policy_return": level,
           "load_average": list(__import__("os").getloadavg()), "curve": _rounded(result.curve)}
    (args.out / f"{args.scenario}_curve.json").write_text(  # compact: it is shipped in docs/
        json.dumps(doc, separators=(",", ":")) + "\n")
    draw_curve(result.curve, level, args.out / f"{args.scenario}_curve.png",
               f"{args.scenario}: recurrent PPO in JAX, population {cfg.population} "
               f"(seed {cfg.seed})")
    print(f"trained {steps:,} steps in {wall:.0f} s ({steady:,.0f} steps/s after "
          f"{result.compile_seconds:.0f} s compiling); final episode return "
          f"{result.curve['episode_return'][-1]:.3f} (random valid actions {level:.3f})")
    print(f"wrote {path}; rank it: .venv/bin/hri-bench suite --agents learner,jaxppo:"
          f"{args.out} --out out/suite-jaxppo")


if __name__ == "__main__":
    main(tyro.cli(Config))
