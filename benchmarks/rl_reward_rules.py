"""Does standard RL exploit the free grasp/let-go rule? MaskablePPO under both reward rules.

Under the paper's reward (``reward="paper"``) grasping and letting go are never counteracted
and cost nothing, so a robot can replace a wait (r0) by a pointless toggle (docs/task-model.md,
"Reward"). This trains sb3-contrib's MaskablePPO on the same track under ``"paper"`` and under
``"no-free-toggle"`` and evaluates each policy under both rules, counting the robot's unneeded
toggles (``hri_envs.task.episode.unneeded_toggle``)::

    .venv/bin/python benchmarks/rl_reward_rules.py --timesteps 60000 --episodes 200

Needs the ``rl`` extra. Prints one JSON line at the end.
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np

import hri_envs  # noqa: F401  (registers the ids)
from agents.rl import train_maskable_ppo
from hri_envs.task.episode import unneeded_toggle

RULES = ("paper", "no-free-toggle")


def evaluate(model, env_id: str, rule: str, episodes: int, seed: int, **kwargs) -> dict:
    """Mean episode reward under ``rule`` and the robot's unneeded toggles per episode."""
    env = gym.make(env_id, reward=rule, **kwargs)
    base = env.unwrapped
    graph = base.graph
    total, toggles = 0.0, 0
    for e in range(episodes):
        obs, _ = env.reset(seed=seed + e)
        done = False
        while not done:
            action, _ = model.predict(obs, action_masks=base.action_masks(), deterministic=True)
            ep = base._episode
            toggles += int(unneeded_toggle(graph, ep.state, int(action), ep.start, ep.lifted))
            obs, r, term, trunc, _ = env.step(int(action))
            total += float(r)
            done = term or trunc
    env.close()
    return {"reward": total / episodes, "unneeded_toggles": toggles / episodes}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="hri_envs/Wheel-v0",
                        help="the Gymnasium id to train on (default hri_envs/Wheel-v0)")
    parser.add_argument("--preference", default="straight",
                        help="the scripted human's preference (default straight)")
    parser.add_argument("--human-passive", type=float, default=0.2,
                        help="probability that the human waits in a step (default 0.2)")
    parser.add_argument("--timesteps", type=int, default=60_000,
                        help="MaskablePPO's training steps per reward rule (default 60000)")
    parser.add_argument("--episodes", type=int, default=200,
                        help="evaluation episodes per policy and rule (default 200)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the training and of the evaluation episodes (default 0)")
    args = parser.parse_args()
    kwargs = {"preference": args.preference, "human_passive": args.human_passive}
    out: dict = {"env": args.env, **kwargs, "timesteps": args.timesteps}
    for trained in RULES:
        t0 = time.perf_counter()
        model = train_maskable_ppo(args.env, args.timesteps, n_envs=16, seed=args.seed,
                                   reward=trained, **kwargs)
        out[f"trained_{trained}"] = {
            f"eval_{rule}": evaluate(model, args.env, rule, args.episodes, 10_000, **kwargs)
            for rule in RULES}
        out[f"trained_{trained}"]["train_s"] = round(time.perf_counter() - t0, 1)
        print(trained, json.dumps(out[f"trained_{trained}"]))
    print(json.dumps(out))


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    main()
