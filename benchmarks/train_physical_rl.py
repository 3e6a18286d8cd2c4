"""Train the learned physical robot (``rl``): a residual policy over the variable admittance.

    .venv/bin/python benchmarks/train_physical_rl.py --scenario hanger --steps 200000 \
        --n-envs 2 --seed 0 --out out/physical-rl/hanger

trains :class:`~baselines.physical.residual.ResidualAdmittance`'s MLP with PPO
(stable-baselines3) on ``--n-envs`` processes (``SubprocVecEnv``) of the scenario's v1
continuous env (``*PandaContinuous-v1``) with ``population="train"`` (a human of the train
split drawn at every reset), wrapped in :class:`~baselines.physical.residual.ResidualEnv`
(the variable admittance runs inside; the policy's action is the residual) and
``VecNormalize`` (observations and rewards). The policy's last layer starts at zero: the
untrained policy is the variable admittance.

Every ``--eval-every`` steps (and at the start and the end) the current policy is exported
to numpy and run as the shipped robot would be, deterministically, on ``--eval-episodes``
episodes of the *validation* split (seeds 0, 1, ...: the same humans every time). The
checkpoint with the best mean validation return is the one written. Output, in ``--out``:

* ``rl-<scenario>.npz``: the best checkpoint (the arrays of :mod:`baselines.physical.
  residual`; no pickle). Copy it to ``baselines/physical/data/`` to ship it;
* ``curve-<scenario>.csv``: per evaluation, the steps, wall time, validation goal rate,
  mean return and effort (with min and max), the training episodes' mean return;
* ``curve-<scenario>.png``: the validation return and effort against steps, the variable
  admittance's (step 0) as a dashed line.

Wall time depends on the machine's load (``uptime`` is printed at the start and the end).
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.physical import run_physical_episode
from baselines.physical.residual import (
    ResidualAdmittance,
    ResidualEnv,
    ResidualPolicy,
    save_policy,
)
from baselines.physical.runs import make_env
from hri_envs.task.scenarios import scenario_spec

CURVE_FIELDS = ("steps", "wall_s", "goal_rate", "return", "return_min", "return_max",
                "effort", "effort_min", "effort_max", "train_return")


def _env_fn(scenario: str, scale: float, population: str) -> Any:
    def make() -> ResidualEnv:
        return ResidualEnv(make_env(scenario_spec(scenario), population=population), scenario,
                           scale)
    return make


def export(model: Any, vecnorm: Any, scale: float, scenario: str) -> ResidualPolicy:
    """The PPO model's deterministic actor and ``vecnorm``'s statistics as a numpy policy."""
    import torch

    layers = [m for m in model.policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    layers.append(model.policy.action_net)
    weights = [m.weight.detach().cpu().numpy().astype(np.float64) for m in layers]
    biases = [m.bias.detach().cpu().numpy().astype(np.float64) for m in layers]
    rms = vecnorm.obs_rms
    return ResidualPolicy(weights, biases, rms.mean.copy(), rms.var.copy(),
                          clip_obs=vecnorm.clip_obs, epsilon=vecnorm.epsilon, scale=scale,
                          scenario=scenario)


def evaluate(policy: ResidualPolicy, env: Any, scenario: str, episodes: int
             ) -> dict[str, float]:
    """The policy as the shipped robot, on ``episodes`` seeded validation episodes."""
    agent = ResidualAdmittance(scenario, policy)
    returns, efforts, placed = [], [], 0
    for seed in range(episodes):
        ep = run_physical_episode(env, agent, seed=seed)
        returns.append(ep.reward)
        efforts.append(float(ep.outcome.metrics["effort"]))
        placed += bool(ep.outcome.metrics.get("reached_intention"))
    return {"goal_rate": placed / episodes, "return": float(np.mean(returns)),
            "return_min": float(np.min(returns)), "return_max": float(np.max(returns)),
            "effort": float(np.mean(efforts)), "effort_min": float(np.min(efforts)),
            "effort_max": float(np.max(efforts))}


def plot(rows: list[dict[str, Any]], path: Path, scenario: str) -> None:
    """The validation return and effort against steps (step 0 dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r["steps"] for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    for ax, key, label in ((axes[0], "return", "mean return"),
                           (axes[1], "effort", "mean effort [N s]")):
        ax.plot(steps, [r[key] for r in rows], "o-")
        ax.fill_between(steps, [r[f"{key}_min"] for r in rows],
                        [r[f"{key}_max"] for r in rows], alpha=0.2)
        ax.axhline(rows[0][key], ls="--", c="grey", label="variable admittance (step 0)")
        ax.set_xlabel("training env steps")
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"rl on {scenario}: validation humans, deterministic (band: min-max)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "?"


def main() -> None:
    """Train, evaluate on validation periodically, write the best checkpoint and the curve."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenario", choices=["hanger", "wheel"], required=True,
                   help="the scenario to train on")
    p.add_argument("--steps", type=int, default=200_000, help="training env steps")
    p.add_argument("--n-envs", type=int, default=2, help="env processes (default 2)")
    p.add_argument("--seed", type=int, default=0, help="the random seed (default 0)")
    p.add_argument("--out", default=None, help="output folder (default out/physical-rl/<s>)")
    p.add_argument("--scale", type=float, default=0.3, help="the residual's scale")
    p.add_argument("--eval-every", type=int, default=20_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=12,
                   help="validation episodes per evaluation")
    p.add_argument("--n-steps", type=int, default=512, help="PPO rollout steps per env")
    p.add_argument("--lr", type=float, default=3e-4, help="PPO learning rate")
    p.add_argument("--max-wall-s", type=float, default=None,
                   help="stop training after this wall time [s] (then a last evaluation)")
    p.add_argument("--log-std", type=float, default=-1.5,
                   help="initial log standard deviation of the residual's noise")
    args = p.parse_args()

    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import SubprocVecEnv, VecMonitor, VecNormalize
    from tqdm import tqdm

    from agents.rl import console_logger

    torch.set_num_threads(1)
    out = Path(args.out or f"out/physical-rl/{args.scenario}")
    out.mkdir(parents=True, exist_ok=True)
    print(f"start: {_uptime()}", flush=True)
    fns = [_env_fn(args.scenario, args.scale, "train") for _ in range(args.n_envs)]
    venv = VecNormalize(VecMonitor(SubprocVecEnv(fns)), norm_obs=True, norm_reward=True,
                        clip_obs=10.0, gamma=0.99)
    venv.seed(args.seed)
    model = PPO("MlpPolicy", venv, n_steps=args.n_steps, batch_size=256, n_epochs=5,
                learning_rate=args.lr, gamma=0.99, gae_lambda=0.95, clip_range=0.2,
                seed=args.seed, device="cpu", verbose=0,
                policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]},
                               "activation_fn": torch.nn.Tanh,
                               "log_std_init": args.log_std})
    model.set_logger(console_logger())  # no empty SB3-<time> folder in the temp dir
    for param in model.policy.action_net.parameters():  # untrained: variable admittance
        torch.nn.init.zeros_(param)
    eval_env = make_env(scenario_spec(args.scenario), population="validation")
    rows: list[dict[str, Any]] = []
    best: dict[str, Any] = {}
    t0 = time.perf_counter()
    npz = out / f"rl-{args.scenario}.npz"

    def checkpoint(steps: int) -> None:
        policy = export(model, venv, args.scale, args.scenario)
        row: dict[str, Any] = {"steps": steps, **evaluate(policy, eval_env, args.scenario,
                                          args.eval_episodes)}
        buf = list(model.ep_info_buffer or [])
        row["train_return"] = float(np.mean([e["r"] for e in buf])) if buf else None
        row["wall_s"] = time.perf_counter() - t0
        rows.append(row)
        if not best or row["return"] > best["return"]:
            best.update(row)
            save_policy(policy, npz)
        tqdm.write(f"{steps:>8d} steps: validation goal {row['goal_rate']:.2f} return "
                   f"{row['return']:.3f} effort {row['effort']:.1f} N s (best at "
                   f"{best['steps']}), train return {row['train_return']}, "
                   f"{row['wall_s']:.0f} s")
        with (out / f"curve-{args.scenario}.csv").open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=CURVE_FIELDS)
            writer.writeheader()
            writer.writerows(rows)
        plot(rows, out / f"curve-{args.scenario}.png", args.scenario)

    class Progress(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.bar = tqdm(total=args.steps, unit="step", smoothing=0.1)
            self.next_eval = args.eval_every

        def _on_step(self) -> bool:
            self.bar.update(self.training_env.num_envs)
            return args.max_wall_s is None or time.perf_counter() - t0 < args.max_wall_s

        def _on_rollout_end(self) -> None:
            if self.num_timesteps >= self.next_eval:
                self.next_eval += args.eval_every
                checkpoint(self.num_timesteps)

    checkpoint(0)
    progress = Progress()
    model.learn(total_timesteps=args.steps, callback=progress)
    progress.bar.close()
    if model.num_timesteps - rows[-1]["steps"] >= args.n_steps * args.n_envs:
        checkpoint(model.num_timesteps)
    venv.close()
    eval_env.close()
    print(f"best validation return {best['return']:.3f} at {best['steps']} steps (step 0: "
          f"{rows[0]['return']:.3f}); wrote {npz}, {out}/curve-{args.scenario}.csv/.png; "
          f"{time.perf_counter() - t0:.0f} s; end: {_uptime()}", flush=True)


if __name__ == "__main__":
    main()
