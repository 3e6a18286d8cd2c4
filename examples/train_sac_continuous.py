"""Train stable-baselines3's SAC on the hanger's continuous env, against both references.

    nice .venv/bin/python examples/train_sac_continuous.py --steps 60000 --out out/sac_hanger

The robot learns from its wrist sensor to carry the hanger with the whole simulated human
arm (``hri_envs/HangerPandaContinuous-v0``; the human's goal is hidden). Every
``--eval-every`` steps the deterministic policy is evaluated on ``--eval-episodes`` fixed
episodes (seeds 10000, 10001, ...); the upper reference (knows the intention, follows the
human's reference) and the passive gravity-compensated floor are evaluated on the same
episodes. Writes ``OUT/learning_curve.png`` (reward per episode, and the human's effort per
episode beside it, against both references), ``OUT/summary.json`` (the curve, the final
comparison with a 95 % bootstrap CI of SAC's reward minus the passive floor's on paired
episodes, wall times) and ``OUT/sac_model.zip``.

SAC trains on the env's reward without its progress term (``reward={"progress": 0}``,
``--train-progress-weight``): the human finishes their route whatever the robot does unless
it fails (which the fault term punishes), so the undiscounted return does not reward
speed, but a discounted learner would trade the human's effort for it; every evaluation
uses the env's default reward. By default SAC starts from a policy close
to the passive floor (``--prior passive``: zero offsets, zero stiffness, little exploration
noise) and learns from there; ``--prior none`` starts from SB3's initialisation. The env is
made with a finer action scale than its default (1 cm and 0.03 rad per step at an action
of 1, ``--max-step-m``, ``--max-step-rad``): exploration then pushes the human less hard;
the passive floor does not depend on it, the upper reference follows the human as well at it.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import hri_envs  # noqa: F401
from agents.physical import PhysicalAgent
from baselines.continuous import PassiveFloor, UpperReference, run_episode

ENV_ID = "hri_envs/HangerPandaContinuous-v0"


def evaluate(env: gym.Env, agent: PhysicalAgent, seeds: list[int]) -> dict[str, list[float]]:
    """Return, effort and goal reached per episode of a robot agent."""
    out: dict[str, list[float]] = {"return": [], "effort": [], "reached": []}
    for seed in seeds:
        row = run_episode(env, agent, seed=seed)
        out["return"].append(row["return"])
        out["effort"].append(row["effort"])
        out["reached"].append(float(row["reached_intention"]))
    return out


def paired_ci(a: np.ndarray, b: np.ndarray, n: int = 10_000, seed: int = 0
              ) -> tuple[float, float, float]:
    """Mean of a - b and its 95 % percentile bootstrap CI (paired episodes)."""
    d = np.asarray(a) - np.asarray(b)
    idx = np.random.default_rng(seed).integers(len(d), size=(n, len(d)))
    means = d[idx].mean(axis=1)
    return float(d.mean()), float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def _passive_prior(model: Any) -> None:
    """Start the actor near the passive floor: its last layers' weights shrunk, the
    stiffness output's bias at -2 (tanh: -0.96, stiffness 0.02) and the log-std biases at
    -2 (exploration noise of std 0.14 before the tanh).
    """
    import torch

    with torch.no_grad():
        for layer in (model.actor.mu, model.actor.log_std):
            layer.weight.mul_(0.01)
        model.actor.mu.bias.zero_()
        model.actor.mu.bias[6] = -2.0
        model.actor.log_std.bias.fill_(-2.0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=40_000, help="training steps (25 Hz)")
    p.add_argument("--eval-every", type=int, default=5_000)
    p.add_argument("--eval-episodes", type=int, default=10)
    p.add_argument("--final-episodes", type=int, default=40)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-step-m", type=float, default=0.01,
                   help="the env's action scale: grip offset per step [m] at an action of 1")
    p.add_argument("--max-step-rad", type=float, default=0.03,
                   help="the env's action scale: rotation per step [rad] at an action of 1")
    p.add_argument("--net", default="128,128", help="hidden layers of actor and critics")
    p.add_argument("--gamma", type=float, default=0.995,
                   help="discount (close to 1: the env's return does not reward speed, and a "
                        "short horizon would make SAC push the human to finish sooner)")
    p.add_argument("--prior", choices=["passive", "none"], default="passive",
                   help="start from a policy close to the passive floor (the actor's mean "
                        "outputs zero offsets and zero stiffness, small exploration noise)")
    p.add_argument("--train-progress-weight", type=float, default=0.0,
                   help="the progress weight of the training env's reward (evaluation always "
                        "uses the env's default reward)")
    p.add_argument("--max-time-s", type=float, default=None,
                   help="episode time limit [s] (default: the env's, 30 s)")
    p.add_argument("--out", default="out/sac_hanger")
    args = p.parse_args()
    import torch
    from stable_baselines3 import SAC
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.rl import console_logger

    torch.set_num_threads(1)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kw: dict[str, float] = {"max_step_m": args.max_step_m, "max_step_rad": args.max_step_rad}
    if args.max_time_s is not None:
        kw["max_time_s"] = args.max_time_s
    # Observations and, for training only, rewards normalised (the per-step rewards are
    # small, about 0.03, and SAC's entropy bonus would drown them otherwise).
    train_reward = {"progress": args.train_progress_weight}
    train = VecNormalize(DummyVecEnv([lambda: Monitor(gym.make(ENV_ID, reward=train_reward,
                                                               **kw))]),
                         norm_obs=True, norm_reward=True, gamma=args.gamma)
    train.seed(args.seed)
    model = SAC("MlpPolicy", train, learning_starts=min(1_000, args.steps // 2),
                batch_size=256, buffer_size=200_000, learning_rate=3e-4, gamma=args.gamma,
                ent_coef="auto_0.01", seed=args.seed, verbose=0,
                policy_kwargs={"net_arch": [int(n) for n in args.net.split(",")]})
    model.set_logger(console_logger())  # no empty SB3-<time> folder in the temp dir
    if args.prior == "passive":
        _passive_prior(model)
    eval_env = gym.make(ENV_ID, **kw)
    seeds = [10_000 + i for i in range(args.eval_episodes)]

    class Sac(PhysicalAgent):
        name = "sac"

        def act(self, observation: np.ndarray) -> np.ndarray:
            action, _ = model.predict(train.normalize_obs(observation), deterministic=True)
            return np.asarray(action, dtype=np.float32)

    sac_act = Sac()

    t0 = time.perf_counter()
    refs = {"upper": evaluate(eval_env, UpperReference(), seeds),
            "passive": evaluate(eval_env, PassiveFloor(), seeds)}
    curve: list[dict[str, float]] = []
    for name, res in refs.items():
        print(f"{name} reference: return {np.mean(res['return']):.2f} effort "
              f"{np.mean(res['effort']):.0f} N s reached {np.mean(res['reached']):.2f}",
              flush=True)

    class Evaluate(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps % args.eval_every == 0:
                train.training = False
                res = evaluate(eval_env, sac_act, seeds)
                train.training = True
                curve.append({"steps": self.num_timesteps,
                              "return": float(np.mean(res["return"])),
                              "effort": float(np.mean(res["effort"])),
                              "reached": float(np.mean(res["reached"])),
                              "wall_s": time.perf_counter() - t0})
                print(f"{self.num_timesteps:6d} steps: return {curve[-1]['return']:.2f} "
                      f"effort {curve[-1]['effort']:.0f} N s reached {curve[-1]['reached']:.2f}"
                      f" ({curve[-1]['wall_s']:.0f} s)", flush=True)
            return True

    t_train = time.perf_counter()
    model.learn(total_timesteps=args.steps, callback=Evaluate())
    train_wall = time.perf_counter() - t_train
    model.save(out / "sac_model.zip")
    # The final comparison, on more (paired) episodes.
    train.training = False
    final_seeds = [20_000 + i for i in range(args.final_episodes)]
    final = {"sac": evaluate(eval_env, sac_act, final_seeds),
             "passive": evaluate(eval_env, PassiveFloor(), final_seeds),
             "upper": evaluate(eval_env, UpperReference(), final_seeds)}
    diff = paired_ci(np.array(final["sac"]["return"]), np.array(final["passive"]["return"]))
    summary = {
        "env": ENV_ID, "steps": args.steps, "seed": args.seed, "train_wall_s": train_wall,
        "total_wall_s": time.perf_counter() - t0, "load_average": os.getloadavg(),
        "curve": curve,
        "references_curve_episodes": {k: {m: float(np.mean(v)) for m, v in r.items()}
                                      for k, r in refs.items()},
        "final": {k: {m: float(np.mean(v)) for m, v in r.items()} for k, r in final.items()},
        "final_episodes": args.final_episodes,
        "sac_minus_passive_return": {"mean": diff[0], "ci95": [diff[1], diff[2]]},
        "sac_beats_passive_95": diff[1] > 0.0,
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    _plot(curve, refs, out / "learning_curve.png")
    print(f"SAC - passive return {diff[0]:.2f} [{diff[1]:.2f}, {diff[2]:.2f}] on "
          f"{args.final_episodes} paired episodes; trained {args.steps} steps in "
          f"{train_wall:.0f} s; wrote {out}/learning_curve.png and summary.json")


def _plot(curve: list[dict[str, float]], refs: dict[str, dict[str, list[float]]],
          path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hri_bench.core.plots import agent_style  # the colours of every other figure

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    steps = [c["steps"] for c in curve]
    for ax, key, label in ((axes[0], "return", "reward per episode"),
                           (axes[1], "effort", "human's effort per episode [N s]")):
        color, dashes = agent_style("sb3")  # an SB3 policy
        ax.plot(steps, [c[key] for c in curve], marker="o", ls=dashes, color=color,
                label="SAC")
        # the upper reference sees the goal, as informed does; the floor is passive
        for name, like in (("upper", "informed"), ("passive", "passive")):
            m = float(np.mean(refs[name][key]))
            color, dashes = agent_style(like)
            ax.axhline(m, color=color, ls=dashes, label=f"{name} reference")
        ax.set_xlabel("training steps (25 Hz)")
        ax.set_ylabel(label)
        ax.legend()
    fig.suptitle(ENV_ID)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
