"""Ray RLlib: train the robot with PPO next to a fixed scripted human, in the PettingZoo env.

The two-agent ``hri_envs.hanger_v0.parallel_env(observation_format="flat")`` goes through
RLlib's own ``ParallelPettingZooEnv`` wrapper, with no wrapper of ours: in the "flat" format
every agent observes one float vector (one-hot state, start support, last human action and
intention, an "intention absent" flag, then the action mask; docs/environments.md), which
RLlib's default MLP reads as it is. Agent ids map one-to-one to RLlib modules:

- ``"human"``: :class:`ScriptedHumanModule`, a fixed (not trained) RLModule that plays the
  scripted human's preferred action for the intention in its observation;
- ``"robot"``: RLlib's default PPO module, trained. It never sees the intention (its slot
  is zero, the "absent" flag set); actions that are invalid in the state abort the step with
  reward -1, which PPO learns to avoid.

Runs on a local Ray (``ray.init(num_cpus=...)``) with sampling in the driver process, so
it fits a laptop: ``python examples/rllib_multiagent.py`` takes about 20 s;
``--iterations 12 --batch-size 1000`` (about 45 s) takes the robot's mean return from
about -30 (random actions, many of them invalid) to about -4.

Needs Ray RLlib: ``pip install -e '.[ray]' -c constraints.txt`` (the extra lists RLlib's
requirements itself, since ``ray[rllib]`` pins an older Gymnasium; see docs/rl.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import tyro

from hri_envs import hanger_v0, wheel_v0
from hri_envs.envs.formats import ClassicLayout
from hri_envs.humans.scripted import preference_human


@dataclass
class Config:
    scenario: Literal["hanger", "wheel"] = "hanger"
    """the task"""
    iterations: int = 3
    """PPO training iterations"""
    batch_size: int = 300
    """environment steps per training iteration"""
    minibatch_size: int = 100
    """SGD minibatch size"""
    epochs: int = 4
    """SGD epochs per iteration"""
    lr: float = 1e-3
    """Adam learning rate"""
    num_cpus: int = 2
    """CPUs for the local Ray instance"""
    seed: int = 0
    """seed of the algorithm and its environments"""


def make_env(env_config: dict[str, Any]) -> Any:
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    module = hanger_v0 if env_config.get("scenario", "hanger") == "hanger" else wheel_v0
    return ParallelPettingZooEnv(module.parallel_env(observation_format="flat"))


def scripted_human_module() -> Any:
    """The RLModule class of the scripted human (defined lazily: it needs Ray)."""
    from ray.rllib.core.columns import Columns
    from ray.rllib.core.rl_module.rl_module import RLModule

    class ScriptedHumanModule(RLModule):
        """Plays the scripted human's preferred action; nothing to train."""

        def setup(self) -> None:
            config = self.model_config if isinstance(self.model_config, dict) else {}
            scenario = config.get("scenario", "hanger")
            graph = make_env({"scenario": scenario}).par_env.unwrapped.graph
            self.human = preference_human(graph)
            self.layout = ClassicLayout(graph.n_states, graph.n_intentions, graph.n_actions)

        def _forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
            rows = [self.layout.decode(o) for o in np.asarray(batch[Columns.OBS])]
            state, start, goal = (np.array([r[k] for r in rows], dtype=np.int64)
                                  for k in ("state", "start", "intention"))
            return {Columns.ACTIONS: self.human.preferred_action(state, start, goal)}

        def _forward_exploration(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
            return self._forward_inference(batch, **kwargs)

        def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
            raise NotImplementedError("the scripted human is fixed; keep it out of "
                                      "policies_to_train")

    return ScriptedHumanModule


def build(cfg: Config) -> Any:
    """The PPO algorithm: robot trained, human scripted."""
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    if not ray.is_initialized():
        ray.init(num_cpus=cfg.num_cpus, include_dashboard=False, log_to_driver=False)
    register_env("hri_cooperation", make_env)
    config = (
        PPOConfig()
        .environment("hri_cooperation", env_config={"scenario": cfg.scenario})
        .env_runners(num_env_runners=0, num_envs_per_env_runner=1)
        .learners(num_learners=0)
        .multi_agent(
            policies={"human", "robot"},
            policy_mapping_fn=lambda agent_id, episode, **kwargs: agent_id,
            policies_to_train=["robot"],
        )
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={
            "robot": RLModuleSpec(),
            "human": RLModuleSpec(module_class=scripted_human_module(),
                                  model_config={"scenario": cfg.scenario}),
        }))
        .training(train_batch_size_per_learner=cfg.batch_size,
                  minibatch_size=cfg.minibatch_size, num_epochs=cfg.epochs, lr=cfg.lr)
        .debugging(seed=cfg.seed)
    )
    return config.build_algo()


def main(argv: list[str] | None = None) -> list[float]:
    cfg = tyro.cli(Config, args=argv, description=__doc__.splitlines()[0])
    import ray

    t0 = time.perf_counter()
    algo = build(cfg)
    print(f"built PPO in {time.perf_counter() - t0:.1f} s")
    returns = []
    try:
        for i in range(cfg.iterations):
            result = algo.train()
            env_runners = result.get("env_runners", {})
            ret = env_runners.get("agent_episode_returns_mean", {}).get("robot", float("nan"))
            steps = env_runners.get("num_env_steps_sampled_lifetime", 0)
            returns.append(float(ret))
            print(f"iteration {i + 1}: robot return {ret:7.2f}  env steps {steps}")
    finally:
        algo.stop()
        ray.shutdown()
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return returns


if __name__ == "__main__":
    main()
