"""Third-party multi-agent clients on the shared-space formats, with no glue code.

SuperSuit's padding and vector-env conversions into an SB3 learner ("flat": SuperSuit only
takes Box or Discrete spaces), Tianshou's PettingZooEnv with a masked policy and TorchRL's
PettingZooWrapper ("classic"). The libraries are in the "clients" extra.
"""

import numpy as np
import pytest

from hri_envs import hanger_v0, wheel_v0

MODULES = [pytest.param(hanger_v0, id="hanger"), pytest.param(wheel_v0, id="wheel")]


def test_supersuit_vector_env_into_sb3():
    ss = pytest.importorskip("supersuit")
    sb3 = pytest.importorskip("stable_baselines3")
    env = ss.pad_observations_v0(hanger_v0.parallel_env(observation_format="flat"))
    venv = ss.pettingzoo_env_to_vec_env_v1(env)  # one vector slot per agent
    venv = ss.concat_vec_envs_v1(venv, 2, num_cpus=0, base_class="stable_baselines3")
    assert venv.num_envs == 4  # 2 copies x 2 agents
    assert venv.observation_space.shape == (24 + 3 + 10 + 3 + 1 + 10,)
    # no seed=...: SB3 would call ConcatVecEnv.seed(), which SuperSuit 3.11 does not have
    model = sb3.PPO("MlpPolicy", venv, n_steps=16, batch_size=32, n_epochs=1, verbose=0)
    model.learn(64)
    assert model.num_timesteps >= 64
    obs = venv.reset()
    assert obs.shape == (4, 51) and np.all((obs == 0) | (obs == 1))
    # the robot's slots (odd) have the intention absent, the human's (even) present
    assert np.all(obs[1::2, 40] == 1.0) and np.all(obs[0::2, 40] == 0.0)
    venv.close()


@pytest.mark.parametrize("mod", MODULES)
def test_tianshou_masked_policy_collects_valid_actions(mod):
    pytest.importorskip("tianshou")
    from tianshou.algorithm.multiagent.marl import MultiAgentPolicy
    from tianshou.algorithm.random import MARLRandomDiscreteMaskedOffPolicyAlgorithm
    from tianshou.data import Collector, VectorReplayBuffer
    from tianshou.env import DummyVectorEnv, PettingZooEnv

    def make():
        return PettingZooEnv(mod.env(observation_format="classic", max_cycles=20))

    env = make()
    assert env.agents == ["human", "robot"]
    policy = MultiAgentPolicy({agent: MARLRandomDiscreteMaskedOffPolicyAlgorithm(
        env.action_space).policy for agent in env.agents})
    venv = DummyVectorEnv([make, make])
    buffer = VectorReplayBuffer(400, 2)
    collector = Collector(policy, venv, buffer)
    collector.reset()
    stats = collector.collect(n_episode=4)
    assert stats.n_collected_episodes >= 4
    batch, _ = buffer.sample(0)
    # the masked policy only picks actions the mask allows: no agent acted invalidly
    assert len(batch) > 0 and not np.any(batch.info["invalid_action"])
    legal = batch.obs.mask[np.arange(len(batch)), batch.act]
    assert legal.all()


@pytest.mark.parametrize("parallel", [True, False], ids=["parallel", "aec"])
def test_torchrl_wrapper_passes_check_env_specs(parallel):
    pytest.importorskip("torchrl")
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper
    from torchrl.envs.utils import check_env_specs

    pz = (wheel_v0.parallel_env(observation_format="classic", max_cycles=5) if parallel
          else wheel_v0.env(observation_format="classic", max_cycles=5))
    env = PettingZooWrapper(pz, use_mask=not parallel, categorical_actions=True, seed=0)
    check_env_specs(env, seed=0)
    # 12 joint steps (an AEC step is one agent's turn) cross two episode ends
    td = env.rollout(12 if parallel else 24, break_when_any_done=False)
    obs = td["next", "robot", "observation", "observation"]
    assert obs.shape[-1] == 3 + 36 + 12 + 3 + 1 and bool((obs[..., -1] == 1).all())
    assert int(td["next", "robot", "done"].sum()) >= 2
