"""Standard RL against scripted humans: SB3 training helpers, the SB3 agent adapter in the
benchmark, the sample-efficiency study and the RLlib example (skipped without Ray)."""

import importlib.util
import json
import sys
import tempfile
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3.common.callbacks import BaseCallback

import hri_envs  # noqa: F401  (registers the ids)
from agents.protocol import Batched
from agents.rl import (
    EpisodeCheckpoints,
    MaskedDQN,
    RandomMasked,
    SB3VectorEnv,
    make_sb3_vec_env,
    random_valid_actions,
    train_dqn,
    train_maskable_ppo,
)
from agents.rollout import run_episode
from agents.sb3 import SB3Agent, SB3BatchAgent, detect_algorithm, load_model
from hri_bench.cli import main as bench_main
from hri_bench.report.sample_efficiency import (
    SampleEfficiencyConfig,
    episodes_to_reach,
    plot,
    run_sample_efficiency,
)
from hri_bench.run.agents import make_agent, validate_agent_name
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import graph_for
from hri_envs.humans.scripted import preference_human

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture(scope="module")
def hanger():
    return graph_for("hanger")


def mean_reward(graph, agent, runs=30, episodes=6, seed=11):
    human = preference_human(graph)
    r = np.arange(runs)
    schedule = make_schedule(graph, "random", r, episodes, seed, human)
    return simulate(graph, agent, human, schedule, runs=r, seed=seed, r0=-0.33).reward.mean()


@pytest.fixture(scope="module")
def ppo_zip(tmp_path_factory):
    """MaskablePPO trained a few thousand steps on the vector env, saved as SB3's .zip."""
    model = train_maskable_ppo("hri_envs/Hanger-v0", 4096, n_envs=8, vec="vector", seed=0)
    path = tmp_path_factory.mktemp("models") / "ppo_hanger.zip"
    model.save(path)
    return model, path


class RecordInvalid(BaseCallback):
    """Counts the env steps in which the trained robot chose an invalid action."""

    def __init__(self):
        super().__init__()
        self.invalid = 0
        self.steps = 0

    def _on_step(self):
        for info in self.locals["infos"]:
            self.invalid += bool(info.get("invalid_action", False))
            self.steps += 1
        return True


# ----------------------------------------------------------------------- MaskablePPO
def test_maskable_ppo_beats_a_random_masked_policy(hanger, ppo_zip):
    model, _ = ppo_zip
    trained = mean_reward(hanger, SB3BatchAgent(model, 30, graph=hanger))
    random = mean_reward(hanger, RandomMasked(30, seed=1))
    assert random < -3.0
    assert trained > random + 2.0, (trained, random)


@pytest.mark.parametrize("vec", ["vector", "dummy", "subproc"])
def test_maskable_ppo_trains_on_sb3_vec_envs_without_invalid_actions(vec):
    record = RecordInvalid()
    model = train_maskable_ppo("hri_envs/Wheel-v0", 256, n_envs=2, vec=vec, seed=0,
                               callback=record, ppo_kwargs={"n_steps": 64, "batch_size": 64})
    assert model.num_timesteps >= 256
    assert record.steps >= 256 and record.invalid == 0



@pytest.mark.parametrize("verbose", [0, 1])
def test_training_leaves_no_log_folder_in_the_temp_dir(verbose, tmp_path, monkeypatch, capsys):
    # SB3 makes an empty SB3-<time> folder in the temp dir at every learn() logging nowhere.
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    train_maskable_ppo("hri_envs/Hanger-v0", 64, n_envs=1, vec="dummy", seed=0,
                       verbose=verbose, ppo_kwargs={"n_steps": 64, "batch_size": 64})
    train_dqn("hri_envs/Hanger-v0", 64, seed=0, verbose=verbose,
              dqn_kwargs={"learning_starts": 16})
    assert not list(tmp_path.glob("SB3-*"))
    table = capsys.readouterr().out
    assert ("total_timesteps" in table) == bool(verbose)  # the console table as before

def test_vector_adapter_follows_sb3_autoreset_conventions():
    venv = make_sb3_vec_env("hri_envs/Hanger-v0", n_envs=4, vec="vector", seed=3)
    assert isinstance(venv, SB3VectorEnv)
    obs = venv.reset()
    assert obs["state"].shape == (4,) and obs["action_mask"].shape == (4, 10)
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(300):
        masks = np.stack(venv.env_method("action_masks"))
        assert np.array_equal(masks, obs["action_mask"] > 0)
        obs, reward, done, infos = venv.step(random_valid_actions(rng, masks))
        # Same-step autoreset: an env that ends returns the next episode's first observation
        # at once (no restart step, no transition across the boundary) ...
        assert np.all(obs["state"][done] == 4 * obs["start"][done])
        for i in np.flatnonzero(done):
            ended += 1
            info = infos[i]
            # ... and the final observation is where the episode really ended.
            final = info["terminal_observation"]
            assert set(final) == set(obs)
            if not info["TimeLimit.truncated"]:
                assert final["state"] % 4 == 0 and final["state"] != 4 * final["start"]
            assert info["episode"]["l"] >= 1 and info["episode"]["r"] <= 0
            assert isinstance(info["TimeLimit.truncated"], bool)
    assert ended > 10
    venv.close()


def test_make_sb3_vec_env_rejects_unknown_kinds():
    with pytest.raises(ValueError, match="allowed: vector, dummy, subproc"):
        make_sb3_vec_env(vec="threads")


# ----------------------------------------------------------------------- DQN
def test_masked_dqn_never_acts_invalid_and_learns(hanger):
    record = RecordInvalid()
    model = train_dqn("hri_envs/Hanger-v0", 2500, seed=0, callback=record)
    assert isinstance(model, MaskedDQN)
    assert record.steps == 2500 and record.invalid == 0  # warm-up and epsilon steps included
    assert mean_reward(hanger, SB3BatchAgent(model, 30)) > mean_reward(hanger,
                                                                       RandomMasked(30)) + 2.0


def test_masked_q_network_hides_invalid_actions(hanger):
    model = MaskedDQN("MultiInputPolicy", gym.make("hri_envs/Hanger-v0"), seed=0)
    obs = {"state": np.array([0, 12]), "start": np.array([0, 0]),
           "last_human_action": np.array([0, 0]),
           "action_mask": hanger.valid[[0, 12]].astype(np.int8)}
    tensors, _ = model.policy.obs_to_tensor(obs)
    q = model.q_net(tensors).detach().numpy()
    assert np.all(q[~hanger.valid[[0, 12]]] <= -1e7)
    actions, _ = model.predict(obs, deterministic=False)  # exploration_rate is 1 at start
    assert hanger.valid[[0, 12], actions].all()


def test_masked_dqn_needs_an_action_mask():
    with pytest.raises(ValueError, match="action_mask"):
        MaskedDQN("MultiInputPolicy", gym.make("CartPole-v1"))


# ----------------------------------------------------------------------- the adapter
def test_sb3_agent_plays_a_gymnasium_env_with_valid_actions(ppo_zip):
    _, path = ppo_zip
    env = gym.make("hri_envs/Hanger-v0")
    robot = SB3Agent(str(path), graph=env.unwrapped.graph)
    for seed in range(3):
        result = run_episode(env, robot, seed=seed)
        assert not result.truncated and result.reward > -5
    sampler = SB3Agent(path, deterministic=False, seed=1)
    obs, _ = env.reset(seed=0)
    assert all(obs["action_mask"][sampler.act(obs)] for _ in range(20))


def test_sb3_agent_reloads_the_same_policy(hanger, ppo_zip):
    model, path = ppo_zip
    assert detect_algorithm(path) == "MaskablePPO"
    loaded = load_model(path)
    a = SB3BatchAgent(model, 20, graph=hanger)
    b = SB3BatchAgent(loaded, 20, graph=hanger)
    assert mean_reward(hanger, a, runs=20) == mean_reward(hanger, b, runs=20)


def test_sb3_batch_agent_matches_the_single_stream_agent(hanger, ppo_zip):
    model, _ = ppo_zip
    greedy_batch, greedy_singles = SB3BatchAgent(model, 6), Batched([SB3Agent(model)] * 6)
    assert mean_reward(hanger, greedy_batch, runs=6) == mean_reward(hanger, greedy_singles,
                                                                    runs=6)
    # Sampling from the masked distribution: valid actions, reproducible per (seed, run).
    sampled = [mean_reward(hanger, SB3BatchAgent(model, 6, deterministic=False, seed=5), runs=6)
               for _ in range(2)]
    assert sampled[0] == sampled[1] > -5
    singles = Batched([SB3Agent(model, deterministic=False, seed=r) for r in range(6)])
    assert mean_reward(hanger, singles, runs=6) > -5


@pytest.mark.parametrize("algo", ["PPO", "A2C"])
def test_sb3_adapter_masks_unmasked_actor_critic_models(algo, tmp_path, hanger):
    import stable_baselines3

    cls = getattr(stable_baselines3, algo)
    extra = {"batch_size": 16} if algo == "PPO" else {}
    model = cls("MultiInputPolicy", gym.make("hri_envs/Hanger-v0"), n_steps=16, seed=0,
                device="cpu", **extra)
    model.learn(32)
    path = tmp_path / f"{algo}.zip"
    model.save(path)
    assert detect_algorithm(path) == algo
    for deterministic in (True, False):
        robot = SB3Agent(path, graph=hanger, deterministic=deterministic)
        for s in range(hanger.n_states):
            obs = {"state": s, "start": 0, "last_human_action": 0,
                   "action_mask": hanger.valid[s].astype(np.int8)}
            assert hanger.valid[s, robot.act(obs)]


def test_sb3_adapter_rejects_models_of_the_wrong_scenario(ppo_zip):
    model, _ = ppo_zip
    with pytest.raises(ValueError, match="the wheel has 36 states and 12 actions"):
        SB3Agent(model, graph=graph_for("wheel"))


def test_sb3_adapter_errors_name_what_is_allowed(tmp_path):
    bad = tmp_path / "model.zip"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a stable-baselines3 .zip"):
        detect_algorithm(bad)
    with pytest.raises(ValueError, match="no SB3 model file"):
        validate_agent_name(f"sb3:{tmp_path / 'missing.zip'}")
    with pytest.raises(ValueError, match="allowed: MaskablePPO, PPO, A2C, DQN, MaskedDQN"):
        load_model(bad, algo="SAC")


def test_sb3_agent_runs_inside_hri_bench_study(ppo_zip, tmp_path, hanger):
    _, path = ppo_zip
    name = f"sb3:{path}"
    out = tmp_path / "study"
    code = bench_main(["study", "hanger", "--agents", f"learner,{name}", "--runs", "4",
                       "--episodes", "3", "--out", str(out), "--no-progress"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["agents"]) == {"learner", name}
    assert len(summary["agents"][name]["reward"]["mean"]) == 3
    human = preference_human(hanger)
    assert isinstance(make_agent(name, hanger, human, [0, 1], seed=0, r0=-0.33), SB3BatchAgent)


# ----------------------------------------------------------------------- sample efficiency
def test_episode_checkpoints_call_back_once_per_count():
    seen = []
    callback = EpisodeCheckpoints((5, 10, 40), lambda model, n: seen.append(n))
    model = train_maskable_ppo("hri_envs/Hanger-v0", 50_000, n_envs=4, seed=0, callback=callback,
                               ppo_kwargs={"n_steps": 32, "batch_size": 64})
    assert len(seen) == 3 and seen == sorted(seen) and seen[0] >= 5 and seen[-1] >= 40
    assert model.num_timesteps < 2000  # stopped at the last checkpoint


def test_episodes_to_reach():
    x = np.array([1, 2, 4, 8])
    assert episodes_to_reach(x, np.array([0.1, 0.5, 0.95, 0.9]), 0.9) == 4
    assert episodes_to_reach(x, np.array([0.1, 0.5, 0.6, 0.7]), 0.9) is None


def test_sample_efficiency_study_small(tmp_path):
    cfg = SampleEfficiencyConfig("hanger", runs=6, episodes=3, eval_runs=4, eval_episodes=2,
                                 ppo_checkpoints=(10, 20), dqn_checkpoints=(5,), rl_seeds=(0,))
    result = run_sample_efficiency(cfg)
    assert result.learner_reward.shape == (3,)
    assert result.rl_reward["ppo"].shape == (1, 2) and result.rl_reward["dqn"].shape == (1, 1)
    assert result.references["oracle"] == 0.0
    assert result.references["random"] < result.references["passive"] < 0.0
    assert result.normalized(result.references["oracle"]) == 1.0
    summary = result.to_dict()
    assert set(summary["episodes_to_90pct_oracle"]) == {"learner", "ppo", "dqn"}
    json.dumps(summary)
    assert plot(result, tmp_path / "se.png").stat().st_size > 10_000
    with pytest.raises(ValueError, match="allowed: ppo, dqn"):
        SampleEfficiencyConfig(algorithms=("sac",))


# ----------------------------------------------------------------------- RLlib
def _load_example(name):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                    reason="Ray RLlib is not installed (see pyproject's 'ray' extra)")
def test_rllib_example_builds_and_steps_its_algorithm():
    import ray

    example = _load_example("rllib_multiagent")
    cfg = example.Config(iterations=1, batch_size=64, minibatch_size=32, epochs=1)
    algo = example.build(cfg)
    try:
        result = algo.train()
        runners = result["env_runners"]
        assert runners["num_env_steps_sampled_lifetime"] >= 64
        assert list(algo.config.policies_to_train) == ["robot"]
        from ray.rllib.core.columns import Columns

        env = example.make_env({"scenario": "hanger"})
        graph = env.par_env.unwrapped.graph
        obs, _ = env.reset(seed=0)
        # The trained robot reads the env's "flat" observation and scores every action ...
        flat = obs["robot"]
        assert flat.shape == (graph.n_states + 2 * graph.n_intentions + 2 * graph.n_actions + 1,)
        out = algo.get_module("robot").forward_inference({Columns.OBS: torch.as_tensor(flat[None])})
        logits = out[Columns.ACTION_DIST_INPUTS]
        assert tuple(logits.shape) == (1, graph.n_actions) and bool(torch.isfinite(logits).all())
        # ... and the fixed human module plays the scripted human's preferred action.
        o_h = obs["human"]
        out = algo.get_module("human").forward_inference({Columns.OBS: np.asarray(o_h)[None]})
        state, start, goal = env.par_env.unwrapped.state()[:3]
        want = preference_human(graph).preferred_action(state, start, goal)
        assert np.asarray(out[Columns.ACTIONS]).tolist() == [int(want)]
    finally:
        algo.stop()
        ray.shutdown()


def test_loading_a_saved_model_never_unpickles(ppo_zip, monkeypatch):
    import pickle

    import cloudpickle

    model, path = ppo_zip

    def refuse(*args, **kwargs):
        raise AssertionError("something was unpickled")

    for module in (pickle, cloudpickle):
        monkeypatch.setattr(module, "loads", refuse)
        monkeypatch.setattr(module, "load", refuse)
    loaded = load_model(path)
    env = gym.make("hri_envs/Hanger-v0")
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        masks = env.unwrapped.action_masks()
        a0, _ = model.predict(obs, action_masks=masks, deterministic=True)
        a1, _ = loaded.predict(obs, action_masks=masks, deterministic=True)
        assert int(a0) == int(a1)
        obs, *_ = env.step(int(a0))
