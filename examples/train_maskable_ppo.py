"""Train MaskablePPO (or a masked DQN) against a scripted human, then benchmark it.

1. Train sb3-contrib's MaskablePPO on ``hri_envs/Hanger-v0`` (or ``Wheel-v0``), masks from
   the env's ``action_masks()``, on the numpy-batched vector env (``--vec vector``) or on
   SB3's ``DummyVecEnv`` / ``SubprocVecEnv``. ``--algo dqn`` trains ``agents.rl.MaskedDQN``.
2. Save the model as a ``.zip`` (SB3's format).
3. Compare it with the paper's Learner and the Oracle on the same seeds, exactly what
   ``hri-bench study hanger --agents learner,sb3:PATH,oracle`` does.

    python examples/train_maskable_ppo.py                     # ~20 s
    python examples/train_maskable_ppo.py --timesteps 60000 --n-envs 16
    python examples/train_maskable_ppo.py --algo dqn --timesteps 5000
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import tyro
from stable_baselines3.common.base_class import BaseAlgorithm

from agents.rl import RandomMasked, train_dqn, train_maskable_ppo
from agents.sb3 import SB3BatchAgent
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import StudyConfig, graph_for, run_study
from hri_envs.humans.scripted import preference_human


@dataclass
class Config:
    scenario: Literal["hanger", "wheel"] = "hanger"
    """the task"""
    algo: Literal["ppo", "dqn"] = "ppo"
    """ppo (MaskablePPO) or dqn (MaskedDQN)"""
    timesteps: int = 30_000
    """environment steps to train for"""
    n_envs: int = 8
    """environments stepped together"""
    vec: Literal["vector", "dummy", "subproc"] = "vector"
    """vector (the numpy-batched env), dummy or subproc (SB3's vector envs)"""
    preference: str = ""
    """the scripted human's preference (empty: the scenario's default)"""
    seed: int = 0
    """seed of training and evaluation"""
    runs: int = 20
    """benchmark runs per agent"""
    episodes: int = 8
    """benchmark episodes per run"""
    out: str = "out/train_maskable_ppo"
    """where the model and the benchmark results go"""


def parse(argv: list[str] | None = None) -> Config:
    """The configuration from the command line (the fields' docstrings are its ``--help``)."""
    return tyro.cli(Config, args=argv, description=__doc__.splitlines()[0])


def main(argv: list[str] | None = None) -> dict[str, float]:
    cfg = parse(argv)
    env_id = {"hanger": "hri_envs/Hanger-v0", "wheel": "hri_envs/Wheel-v0"}[cfg.scenario]
    preference = cfg.preference or None

    # 1. Train.
    t0 = time.perf_counter()
    model: BaseAlgorithm
    if cfg.algo == "ppo":
        model = train_maskable_ppo(env_id, cfg.timesteps, n_envs=cfg.n_envs, vec=cfg.vec,
                                   seed=cfg.seed, preference=preference)
    elif cfg.algo == "dqn":
        model = train_dqn(env_id, cfg.timesteps, n_envs=1, vec=cfg.vec, seed=cfg.seed,
                          preference=preference)
    else:
        raise SystemExit(f"--algo must be ppo or dqn, got {cfg.algo!r}")
    seconds = time.perf_counter() - t0
    print(f"trained {type(model).__name__} for {model.num_timesteps} steps on {cfg.vec} x "
          f"{cfg.n_envs if cfg.algo == 'ppo' else 1} in {seconds:.1f} s "
          f"({model.num_timesteps / seconds:,.0f} steps/s)")

    # 2. Save (SB3's .zip).
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{cfg.algo}_{cfg.scenario}.zip"
    model.save(path)

    # The frozen policy against a random valid-action policy, same episodes.
    graph = graph_for(cfg.scenario)
    human = preference_human(graph, preference)
    runs = np.arange(cfg.runs)
    schedule = make_schedule(graph, "random", runs, cfg.episodes, cfg.seed, human)
    r0 = StudyConfig(cfg.scenario).waiting_reward
    rewards = {}
    for name, agent in (("trained", SB3BatchAgent(model, cfg.runs, graph=graph)),
                        ("random", RandomMasked(cfg.runs, seed=cfg.seed))):
        m = simulate(graph, agent, human, schedule, runs=runs, seed=cfg.seed, r0=r0)
        rewards[name] = float(m.reward.mean())
    print(f"mean reward per episode: trained {rewards['trained']:.2f}, "
          f"random valid actions {rewards['random']:.2f}")

    # 3. The benchmark, as `hri-bench study ... --agents learner,sb3:PATH,oracle`.
    sb3_name = f"sb3:{path}"
    study = run_study(StudyConfig(cfg.scenario, agents=("learner", sb3_name, "oracle"),
                                  runs=cfg.runs, episodes=cfg.episodes, seed=cfg.seed,
                                  preference=preference))
    for name, metrics in study.metrics.items():
        r = metrics["reward"].mean(0)
        print(f"  {name:28s} episode 1 {r[0]:6.2f}   episode {cfg.episodes} {r[-1]:6.2f}")
        rewards[name] = float(r.mean())
    print(f"model saved to {path}; the same from the shell:\n  hri-bench study {cfg.scenario} "
          f"--agents learner,{sb3_name},oracle --runs {cfg.runs} --episodes {cfg.episodes} "
          f"--out {out / 'study'}")
    return rewards


if __name__ == "__main__":
    main()
