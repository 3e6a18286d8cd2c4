"""The physics backend behind the PettingZoo and Gymnasium interfaces and the runner."""

import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence
from gymnasium.utils.passive_env_checker import env_render_passive_checker
from pettingzoo.test import parallel_api_test, parallel_seed_test
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs import hanger_v0, wheel_v0
from hri_envs.task.graph import TAKE_OFF, TOGGLE, WAIT

pytestmark = [
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
    pytest.mark.filterwarnings("ignore:Observation is not a NumPy array"),
    pytest.mark.filterwarnings("ignore:Observation space for each agent probably"),
    pytest.mark.filterwarnings("ignore:We recommend agents to be named"),
    pytest.mark.filterwarnings("ignore:Agents have different observation space sizes"),
]
PHYSICS_INFO = {"linear_impulse", "angular_impulse", "duration_s", "graph_agrees", "settled",
                "human_action_inferred"}


def test_parallel_api_on_the_physics_backend():
    parallel_api_test(hanger_v0.parallel_env(backend="mujoco", max_cycles=6), num_cycles=12)


def test_parallel_seed_on_the_physics_backend():
    parallel_seed_test(lambda: wheel_v0.parallel_env(backend="mujoco", max_cycles=5))


@pytest.mark.parametrize("env_id", ["hri_envs/HangerPanda-v0", "hri_envs/WheelPanda-v0"])
def test_gymnasium_check_env_on_the_panda(env_id):
    env = gym.make(env_id, max_cycles=3)
    # the "human" mode needs a display: test_render_human.py checks it under Xvfb
    check_env(env.unwrapped, skip_render_check=True)
    env.close()
    env = gym.make(env_id, max_cycles=3, render_mode="rgb_array").unwrapped
    env.reset(seed=0)
    env_render_passive_checker(env)
    env.close()


def test_sb3_check_env_on_the_panda():
    sb3_check_env(gym.make("hri_envs/HangerPanda-v0", max_cycles=3), warn=True)


def test_physics_episodes_are_deterministic():
    def rollout():
        env = gym.make("hri_envs/HangerPanda-v0", human_passive=0.3).unwrapped
        out = [env.reset(seed=5, options={"start": "B", "intention": "A"})]
        for a in (TOGGLE, TAKE_OFF, WAIT, WAIT):
            out.append(env.step(a))
        env.close()
        return out

    assert data_equivalence(rollout(), rollout())


def test_a_physics_episode_through_the_parallel_env():
    env = hanger_v0.parallel_env(backend="mujoco")
    obs, _ = env.reset(seed=0, options={"start": "B", "intention": "A"})
    total = 0.0
    for a_h, a_r in ((TOGGLE, TOGGLE), (TAKE_OFF, TAKE_OFF), (8, WAIT)):
        obs, rew, term, trunc, info = env.step({"human": a_h, "robot": a_r})
        total += rew["robot"]
        assert PHYSICS_INFO <= set(info["robot"]) and info["robot"]["graph_agrees"]
        assert not (term["robot"] or trunc["robot"])
    assert obs["robot"]["state"] == env.graph.waypoint_state(1, 0, 1)  # B column, low
    assert obs["robot"]["last_human_action"] == 8 and "intention" not in obs["robot"]
    assert total == pytest.approx(env.r0)  # the robot waited while the human moved down
    assert info["robot"]["linear_impulse"] > 0 and info["robot"]["duration_s"] > 0.5
    env.close()


def test_rgb_array_frame_is_not_blank():
    env = wheel_v0.parallel_env(backend="mujoco", render_mode="rgb_array")
    env.reset(seed=2)
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert img.std() > 10 and len(np.unique(img.reshape(-1, 3), axis=0)) > 50
    env.close()


def test_a_fault_truncates_the_episode_with_its_reason(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to MUJOCO_LOG.TXT
    env = gym.make("hri_envs/HangerPanda-v0").unwrapped
    env.reset(seed=0)
    env._episode.sim.data.qvel[:] = np.nan
    _, _, terminated, truncated, info = env.step(TOGGLE)
    assert truncated and not terminated and info["truncation_reason"].startswith("unstable")


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])  # .mp4: imageio-ffmpeg, in the extra
def test_episode_video(tmp_path, suffix):
    path = tmp_path / f"ep{{episode}}{suffix}"
    env = hanger_v0.parallel_env(backend="mujoco", physics={"video_path": str(path),
                                                             "video_fps": 4})
    env.reset(seed=0, options={"start": "B", "intention": "A"})
    env.step({"human": TOGGLE, "robot": TOGGLE})
    env.close()
    out = tmp_path / f"ep1{suffix}"
    assert out.is_file() and out.stat().st_size > 1000


@pytest.mark.parametrize(
    ("video_path", "message"),
    [
        (5, "must be a file name"),
        ("/proc/hri-envs/ep.gif", "cannot write in '/proc/hri-envs'"),
        ("ep{episode}.txt", "must end in one of .gif, .mp4"),
        ("ep{0}.gif", "may hold one field, {episode}"),
    ],
)
def test_a_video_that_cannot_be_written_fails_when_the_env_is_built(tmp_path, monkeypatch,
                                                                     video_path, message):
    from hri_envs.errors import ConfigError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=re.escape(message)) as caught:
        hanger_v0.parallel_env(backend="mujoco", physics={"video_path": video_path})
    assert caught.value.field == "physics"


def test_simulate_on_the_physics_backend():
    from baselines import Passive
    from hri_bench.run.runner import make_schedule, simulate
    from hri_envs.envs.config import scenario_graph
    from hri_envs.humans.scripted import preference_human

    g = scenario_graph("hanger")
    human = preference_human(g)
    schedule = make_schedule(g, "table2", [0], 1, seed=0)
    m = simulate(g, Passive(g, 1), human, schedule, runs=[0], seed=0, r0=-0.33,
                 max_steps=30, backend="mujoco")
    assert m.reward.shape == (1, 1) and not m.truncated.any()
    assert set(m.extras) == {"linear_impulse", "angular_impulse", "linear_impulse_true",
                             "angular_impulse_true", "duration_s", "graph_agrees",
                             "inference_accuracy", "hold_accuracy", "physical_fault"}
    assert m.extras["graph_agrees"][0, 0] == 1.0 and m.extras["linear_impulse"][0, 0] > 0
    assert m.extras["hold_accuracy"][0, 0] == 1.0  # the handle sensor read every grasp right
    assert m.extras["inference_accuracy"][0, 0] == 1.0 and m.extras["physical_fault"][0, 0] == 0
    assert m.passive[0, 0] > 0.5 and m.correct[0, 0] > 0  # grasp and let go are correct


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"backend": "mujoco", "physics": {"fps": 3}}, "allowed: video_path, video_fps"),
        ({"backend": "mujoco", "physics": {"video_fps": 0}}, "positive number"),
        ({"physics": {"video_path": "x.gif"}}, "backend='graph' takes no physics options"),
    ],
)
def test_bad_physics_options_raise(kwargs, message):
    from hri_envs.errors import ConfigError

    with pytest.raises(ConfigError, match=message):
        hanger_v0.parallel_env(**kwargs)
    with pytest.raises(ConfigError, match=message):
        gym.make("hri_envs/Wheel-v0", **kwargs)
