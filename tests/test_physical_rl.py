"""The learned physical robot (``rl``): a residual policy over the variable admittance.

Its checkpoints load without pickle and act within the action's range, a zero residual is
the variable admittance exactly (as a robot and as the training env), a checkpoint survives
a round trip, a malformed one is refused naming the field, and the numpy robot acts as the
PPO policy it was exported from.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401
from agents.physical import run_physical_episode
from baselines.physical import PHYSICAL_AGENTS
from baselines.physical.admittance import VariableAdmittance
from baselines.physical.residual import (
    ResidualAdmittance,
    ResidualEnv,
    ResidualPolicy,
    checkpoint_path,
    combine,
    load_policy,
    save_policy,
)
from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import scenario_graph

IDS = {"hanger": "hri_envs/HangerPandaContinuous-v1",
       "wheel": "hri_envs/WheelPandaContinuous-v1"}


def _make(scenario: str, **kwargs: Any) -> gym.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return gym.make(IDS[scenario], max_time_s=2.0, **kwargs)


def _size(scenario: str) -> int:
    env = _make(scenario)
    try:
        return int(env.observation_space.shape[0]) + 7  # type: ignore[index]
    finally:
        env.close()


def _random_policy(size: int, scenario: str, seed: int = 1) -> ResidualPolicy:
    """A policy with every layer random (a non-zero residual) and a non-trivial input
    normalisation."""
    rng = np.random.default_rng(seed)
    zero = ResidualPolicy.zero(size, scenario=scenario, seed=seed)
    weights = [w.copy() for w in zero.weights]
    weights[-1] = rng.normal(0, 0.5, weights[-1].shape)
    return ResidualPolicy(weights, [rng.normal(0, 0.3, b.shape) for b in zero.biases],
                          rng.normal(0, 1, size), rng.uniform(0.5, 2, size), scale=0.4,
                          scenario=scenario)


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_the_shipped_checkpoint_loads_and_acts_within_the_range(scenario: str) -> None:
    assert checkpoint_path(scenario_graph(scenario)).is_file()
    with np.load(checkpoint_path(scenario_graph(scenario)), allow_pickle=False) as data:
        assert "w0" in data.files and "obs_mean" in data.files
    agent = PHYSICAL_AGENTS["rl"](scenario, 0)
    assert isinstance(agent, ResidualAdmittance) and not PHYSICAL_AGENTS["rl"].privileged
    env = _make(scenario)
    obs, _ = env.reset(seed=2)
    agent.begin_episode(env.unwrapped.robot_task())  # type: ignore[attr-defined]
    for _ in range(25):
        action = agent.act(obs)
        assert action.shape == (7,) and action.dtype == np.float32
        assert np.all(np.abs(action) <= 1.0)
        obs, *_ = env.step(action)
    env.close()


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_a_zero_residual_is_the_variable_admittance_exactly(scenario: str) -> None:
    """As a robot: the same action as VariableAdmittance for every observation of two
    episodes (its state reset between them); and as the training env: a zero residual
    steps the env as the variable admittance does."""
    policy = ResidualPolicy.zero(_size(scenario), scenario=scenario, seed=3)
    policy.obs_mean[:] = 0.5  # normalisation does not matter when the last layer is 0
    robot, base = ResidualAdmittance(scenario, policy), VariableAdmittance(scenario)
    env = _make(scenario)
    for seed in (4, 5):
        obs, _ = env.reset(seed=seed)
        task = env.unwrapped.robot_task()  # type: ignore[attr-defined]
        robot.begin_episode(task)
        base.begin_episode(task)
        for _ in range(40):
            a = robot.act(obs)
            np.testing.assert_array_equal(a, base.act(obs))
            obs, *_ = env.step(a)

    wrapped = ResidualEnv(_make(scenario), scenario, scale=0.3)
    for seed in (4, 5):
        reference = run_physical_episode(env, VariableAdmittance(scenario), seed=seed)
        wrapped.reset(seed=seed)
        total, done = 0.0, False
        while not done:
            _, r, term, trunc, info = wrapped.step(np.zeros(7, dtype=np.float32))
            total, done = total + float(r), term or trunc
        assert total == reference.reward
        assert info["episode"]["effort"] == reference.info["episode"]["effort"]
    env.close()
    wrapped.close()


def test_a_residual_moves_the_action_by_its_scale() -> None:
    base = np.array([0.2, -0.9, 0, 0, 0, 0.5, 1.0], dtype=np.float32)
    out = combine(base, np.array([1, -1, 3, 0, 0, -0.5, 1]), 0.3)
    np.testing.assert_allclose(out, [0.5, -1.0, 0.3, 0, 0, 0.35, 1.0], atol=1e-6)
    size = _size("hanger")
    robot = ResidualAdmittance("hanger", _random_policy(size, "hanger"))
    env = _make("hanger")
    obs, _ = env.reset(seed=1)
    robot.begin_episode(env.unwrapped.robot_task())  # type: ignore[attr-defined]
    a = robot.act(obs)
    variable = VariableAdmittance("hanger")
    variable.begin_episode(env.unwrapped.robot_task())  # type: ignore[attr-defined]
    b = variable.act(obs)
    expected = combine(b, robot.policy.residual(np.concatenate([obs, b])), 0.4)
    np.testing.assert_array_equal(a, expected)
    assert not np.array_equal(a, b)
    # once a seat holds the object after it left its start, the base acts alone (here: the
    # start seat holds it and the robot is told it has left it)
    robot.begin_episode(env.unwrapped.robot_task())  # type: ignore[attr-defined]
    robot.base.wrench.left_start = True
    np.testing.assert_array_equal(robot.act(obs), [0, 0, 0, 0, 0, 0, 1])
    assert robot.base.wrench.settling
    env.close()


def test_a_checkpoint_round_trips(tmp_path: Path) -> None:
    size = _size("wheel")
    policy = _random_policy(size, "wheel")
    save_policy(policy, tmp_path / "p.npz")
    again = load_policy(tmp_path / "p.npz")
    assert again.scenario == "wheel" and again.scale == policy.scale
    assert len(again.weights) == len(policy.weights) == 3
    x = np.random.default_rng(0).normal(0, 2, (20, size))
    for row in x:  # weights are stored as float32: equal to float32 precision
        np.testing.assert_allclose(again.residual(row), policy.residual(row), atol=1e-5)
    assert np.abs(policy.residual(x[0])).max() > 0.05
    np.testing.assert_array_equal(again.obs_var, policy.obs_var)


def _write(path: Path, **changes: object) -> Path:
    arrays = dict(ResidualPolicy.zero(20, scenario="hanger").arrays())
    for key, value in changes.items():
        if value is None:
            del arrays[key]
        else:
            arrays[key] = np.asarray(value)
    np.savez(path, **arrays)  # type: ignore[arg-type]
    return path


@pytest.mark.parametrize(("change", "field"), [
    ({"obs_var": None}, "obs_var"),
    ({"b2": None}, "b2"),
    ({"scale": None}, "scale"),
    ({"w1": np.zeros((64, 3))}, "w1"),
    ({"w2": np.zeros((5, 64)), "b2": np.zeros(5)}, "w2"),
    ({"obs_mean": np.zeros(19)}, "obs_var"),
    ({"scale": -1.0}, "scale"),
    ({"scale": np.zeros(2)}, "scale"),
    ({"scenario": 3}, "scenario"),
])
def test_a_malformed_checkpoint_is_refused_naming_the_field(
        tmp_path: Path, change: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_policy(_write(tmp_path / "bad.npz", **change))
    assert err.value.field == field


def test_an_unreadable_or_foreign_checkpoint_is_refused(tmp_path: Path) -> None:
    (tmp_path / "x.npz").write_text("not a zip")
    with pytest.raises(ConfigError, match="cannot read") as err:
        load_policy(tmp_path / "x.npz")
    assert err.value.field == "checkpoint"
    with pytest.raises(ConfigError, match="trained on 'hanger'"):
        ResidualAdmittance("wheel", _write(tmp_path / "h.npz"))
    with pytest.raises(ConfigError, match="allowed: hanger, wheel"):
        ResidualAdmittance("shelf")


def test_the_exported_ppo_policy_acts_as_the_numpy_robot() -> None:
    """A few hundred PPO steps on the training env; the numpy export's residual is the
    deterministic PPO action on the VecNormalize-d observation."""
    pytest.importorskip("stable_baselines3")
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

    from benchmarks.train_physical_rl import export

    # VecMonitor: the env's own info["episode"] (its figures) is not SB3's episode record
    venv = VecNormalize(VecMonitor(DummyVecEnv(
        [lambda: ResidualEnv(_make("hanger"), "hanger", 0.3)])), clip_obs=10.0)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=2, seed=0,
                device="cpu", policy_kwargs={"net_arch": {"pi": [16, 16], "vf": [16, 16]},
                                             "activation_fn": torch.nn.Tanh})
    for param in model.policy.action_net.parameters():
        torch.nn.init.zeros_(param)
    zero = export(model, venv, 0.3, "hanger")
    assert np.all(zero.weights[-1] == 0) and np.all(zero.biases[-1] == 0)
    model.learn(128)
    policy = export(model, venv, 0.3, "hanger")
    assert np.abs(policy.weights[-1]).max() > 0  # it learned something
    raw = np.asarray(venv.get_original_obs())[0]
    ppo, _ = model.predict(venv.normalize_obs(raw[None]), deterministic=True)
    np.testing.assert_allclose(policy.residual(raw), np.clip(ppo[0], -1, 1), atol=1e-5)
    venv.close()
