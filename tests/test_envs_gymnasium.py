"""The robot-vs-scripted-human Gymnasium env: checkers, seeding, the scripted human, errors."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.utils.passive_env_checker import env_render_passive_checker
from sb3_contrib.common.maskable.utils import get_action_masks
from stable_baselines3.common.env_checker import check_env as sb3_check_env
from stable_baselines3.common.vec_env import DummyVecEnv

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs.envs import RobotEnv
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human

IDS = ["hri_envs/Hanger-v0", "hri_envs/Wheel-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_env(env_id):
    # check_env's own render check also makes the "human" mode, which needs a display; it
    # runs in full under Xvfb in test_render_human.py. Here: the two headless modes.
    check_env(gym.make(env_id).unwrapped, skip_render_check=True)
    for mode, kwargs in (("rgb_array", {}), ("ansi", {"human_passive": 0.3})):
        env = gym.make(env_id, render_mode=mode, **kwargs).unwrapped
        check_env(env, skip_render_check=True)
        env.reset(seed=0)
        env_render_passive_checker(env)


@pytest.mark.parametrize("env_id", IDS)
def test_sb3_check_env(env_id):
    sb3_check_env(gym.make(env_id), warn=True)


@pytest.mark.parametrize("env_id", IDS)
def test_action_masks_through_wrappers_and_sb3_contrib(env_id):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=0)
    mask = env.get_wrapper_attr("action_masks")()
    assert mask.dtype == bool and np.array_equal(mask, obs["action_mask"].astype(bool))
    venv = DummyVecEnv([lambda: gym.make(env_id)])
    venv.reset()
    assert get_action_masks(venv).shape == (1, env.action_space.n)


def _rollout(env, seed, actions, options=None):
    out = [env.reset(seed=seed, options=options)]
    for a in actions:
        step = env.step(int(a))
        out.append(step)
        if step[2] or step[3]:
            out.append(env.reset())
    return out


@pytest.mark.parametrize("env_id", IDS)
def test_reset_seed_reproduces_a_stochastic_human(env_id):
    env = gym.make(env_id, human_passive=0.4, turn_back=0.5, max_cycles=15).unwrapped
    actions = np.random.default_rng(1).integers(env.action_space.n, size=60)
    first = _rollout(env, 11, actions)
    again = _rollout(env, 11, actions)
    other = _rollout(env, 12, actions)
    assert data_equivalence(first, again)
    assert not data_equivalence(first, other)


def _oracle_episode(env, **options):
    """Run one episode with a robot that does what the scripted human wants."""
    obs, _ = env.reset(seed=0, options=options)
    ep, human = env._episode, env.human
    rewards, states = [], [obs["state"]]
    while True:
        a = int(human.preferred_action(np.array([ep.state]), np.array([ep.start]),
                                       np.array([ep.intention]))[0])
        obs, r, term, trunc, info = env.step(a)
        rewards.append(r)
        states.append(obs["state"])
        assert not info["aborted"] and not info["invalid_action"]
        if term or trunc:
            return states, rewards, term


def test_oracle_robot_carries_the_hanger_a_to_b_without_penalty():
    env = RobotEnv("hanger")
    states, rewards, term = _oracle_episode(env, start="A", intention="B")
    assert term and rewards == [0.0] * 7
    # grasp, take off, over, rotate, up (the study's favourite order), put on, let go
    assert states == [0, 3, 12, 16, 17, 19, 7, 4]


def test_turning_back_returns_the_object_to_the_start():
    env = RobotEnv("hanger")
    states, _, term = _oracle_episode(env, start="A", intention="B", turn_back=True)
    assert term and states[-1] == 0 and env.intention == 0
    assert env.human.turn_state[0, 1] in states


def test_ansi_render_hides_the_intention():
    env = gym.make("hri_envs/Wheel-v0", render_mode="ansi")
    env.reset(seed=0, options={"start": "A", "intention": "C"})
    env.step(1)
    text = env.render()
    assert "intention hidden" in text and "robot: grasp" in text


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"r0": 0.5}, ConfigError, r"open interval \(-1, 0\)"),
        ({"preference": "sideways"}, ConfigError, "allowed: straight, detour"),
        ({"human_passive": 1.5}, ConfigError, r"human_passive must be a probability in \[0, 1\]"),
        ({"turn_back": -0.1}, ConfigError, "turn_back must be a probability"),
        ({"backend": "bullet"}, ConfigError, "allowed: graph, mujoco"),
        ({"max_cycles": 2.5}, ConfigError, "max_cycles"),
    ],
)
def test_bad_configuration_raises(kwargs, error, message):
    with pytest.raises(error, match=message):
        gym.make("hri_envs/Wheel-v0", **kwargs)


def test_hanger_preferences_are_checked():
    with pytest.raises(ConfigError, match="down-over-rotate/over-rotate-up"):
        RobotEnv("hanger", preference="straight")
    RobotEnv("hanger", preference="over-down-rotate/up-over-rotate")
    with pytest.raises(ConfigError, match="allowed: hanger, wheel"):
        RobotEnv("kitchen")


def test_human_must_match_the_scenario():
    hanger_human = preference_human(RobotEnv("hanger").graph)
    with pytest.raises(ConfigError, match="built for the hanger"):
        RobotEnv("wheel", human=hanger_human)


def test_bad_actions_and_options_raise():
    env = gym.make("hri_envs/Hanger-v0").unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"robot action 10 .*0\.\.9"):
        env.step(10)
    with pytest.raises(ConfigError, match="allowed: start, intention, turn_back$"):
        env.reset(options={"stands": 2})
