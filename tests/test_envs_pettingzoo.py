"""The two-agent PettingZoo env: conformance, determinism, hand-checked steps, bad input."""

import re

import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    render_test,
)

from hri_envs import hanger_v0, wheel_v0
from hri_envs.errors import ActionError, BackendUnavailableError, ConfigError

MODULES = [pytest.param(hanger_v0, id="hanger"), pytest.param(wheel_v0, id="wheel")]
WAIT, TOGGLE, TAKE_OFF, PUT_ON, ROTATE = 0, 1, 2, 3, 4
# hanger action numbering: 5..7 move over to A/B/C, 8 move to 0.585 m, 9 move to 0.87 m
OVER_B, OVER_C, DOWN, UP = 6, 7, 8, 9
R0 = -0.33
# pettingzoo.test's advice for flat observations and "player_0"-style names; the documented
# contract (docs/environments.md, 'Agents' and 'Observations') fixes dict observations (with
# an action mask, ι for the human only) and the names human/robot.
pytestmark = [
    pytest.mark.filterwarnings("ignore:Observation is not a NumPy array"),
    pytest.mark.filterwarnings("ignore:Observation space for each agent probably"),
    pytest.mark.filterwarnings("ignore:We recommend agents to be named"),
    pytest.mark.filterwarnings("ignore:Agents have different observation space sizes"),
]


@pytest.mark.parametrize("mod", MODULES)
def test_parallel_api(mod):
    parallel_api_test(mod.parallel_env(), num_cycles=200)


@pytest.mark.parametrize("mod", MODULES)
def test_parallel_seed(mod):
    parallel_seed_test(mod.parallel_env)


@pytest.mark.parametrize("mod", MODULES)
def test_max_cycles(mod):
    max_cycles_test(mod)


@pytest.mark.parametrize("mod", MODULES)
def test_aec_api(mod):
    api_test(mod.env(), num_cycles=200)


@pytest.mark.parametrize("mod", MODULES)
def test_render(mod):
    # Headless: the "human" mode needs a display, so here it gets None (render() returns
    # None, as render_test expects of "human"); the unmodified render_test with a real
    # window runs under Xvfb in test_render_human.py.
    def env_fn(render_mode=None):
        return mod.env(render_mode=None if render_mode == "human" else render_mode)

    render_test(env_fn)


@pytest.mark.parametrize("mod", MODULES)
def test_rgb_array_is_a_picture(mod):
    env = mod.parallel_env(render_mode="rgb_array")
    env.reset(seed=3)
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert len(np.unique(img.reshape(-1, 3), axis=0)) >= 5


def test_wheel_layout_changes_the_picture_only():
    env = wheel_v0.parallel_env(render_mode="rgb_array")
    layout = ((0.5, 2.0), (1.8, 2.4))
    obs_a, _ = env.reset(seed=1, options={"start": "A", "intention": "B", "layout": layout})
    assert env.layout == layout
    img_a = env.render()
    obs_b, _ = env.reset(seed=1, options={"start": "A", "intention": "B"})
    assert env.layout != layout
    assert data_equivalence(obs_a, obs_b)
    assert not np.array_equal(img_a, env.render())


def test_ansi_hides_the_intention_unless_asked():
    env = hanger_v0.parallel_env(render_mode="ansi")
    env.reset(seed=0, options={"start": "A", "intention": "C"})
    assert "intention hidden" in env.render()
    env = hanger_v0.parallel_env(render_mode="ansi", render_intention=True)
    env.reset(seed=0, options={"start": "A", "intention": "C"})
    assert "intention C" in env.render()


@pytest.mark.parametrize("mod", MODULES)
def test_same_seed_same_actions_same_episode(mod):
    n_a = mod.parallel_env().graph.n_actions
    actions = np.random.default_rng(7).integers(n_a, size=(50, 2))  # masked ones included
    envs = [mod.parallel_env(max_cycles=20), mod.parallel_env(max_cycles=20)]
    outs = [[env.reset(seed=123)] for env in envs]
    for a_h, a_r in actions:
        for env, out in zip(envs, outs, strict=True):
            step = env.step({"human": a_h, "robot": a_r})
            out.append(step)
            if not env.agents:
                out.append(env.reset())
    assert data_equivalence(outs[0], outs[1])
    assert data_equivalence(envs[0].state(), envs[1].state())


def test_spaces_and_observations():
    env = hanger_v0.parallel_env()
    obs, infos = env.reset(seed=0, options={"start": "B", "intention": "A"})
    assert set(env.observation_space("robot").spaces) == {
        "state", "start", "last_human_action", "action_mask"}
    assert set(env.observation_space("human").spaces) == {
        "state", "start", "last_human_action", "action_mask", "intention"}
    assert env.observation_space("robot") is env.observation_space("robot")
    assert env.action_space("human") is env.action_space("human")
    assert env.action_space("robot").n == 10
    assert obs["human"]["intention"] == 0 and "intention" not in obs["robot"]
    assert infos["human"]["intention"] == 0 and "intention" not in infos["robot"]
    assert obs["robot"]["state"] == 4 and obs["robot"]["start"] == 1
    assert obs["robot"]["action_mask"].dtype == np.int8
    for agent in env.agents:
        assert env.observation_space(agent).contains(obs[agent])
    assert env.state().tolist() == [4, 1, 0, WAIT, 0]
    assert env.state_space.contains(env.state())


# ------------------------------------------------------------------ hand-checked hanger steps
def _hanger_at(state):
    """A hanger env started on A (intention B) and driven by both agents to ``state``."""
    env = hanger_v0.parallel_env()
    env.reset(seed=0, options={"start": "A", "intention": "B"})
    route = {3: [(TOGGLE, TOGGLE)], 12: [(TOGGLE, TOGGLE), (TAKE_OFF, TAKE_OFF)],
             14: [(TOGGLE, TOGGLE), (TAKE_OFF, TAKE_OFF), (UP, UP)]}[state]
    for a_r, a_h in route:
        obs, *_ = env.step({"robot": a_r, "human": a_h})
    assert obs["robot"]["state"] == state
    env.last_obs = obs  # what the agents observe there
    return env


def _step(env, a_r, a_h):
    obs, rew, term, trunc, info = env.step({"robot": a_r, "human": a_h})
    return obs["robot"]["state"], rew["robot"], info["robot"]


def test_valid_actions_at_the_low_peg_mounting_point():
    env = _hanger_at(12)
    g = env.graph
    obs = env.last_obs["robot"]
    assert g.state_names[12].startswith("held at A′ column, 0.585 m, peg-facing")
    assert np.flatnonzero(obs["action_mask"]).tolist() == [WAIT, PUT_ON, ROTATE, OVER_B,
                                                           OVER_C, UP]
    labels = [g.agent_action_label(12, a, robot=True) for a in (WAIT, PUT_ON, ROTATE, OVER_B,
                                                                OVER_C, UP)]
    assert labels == ["wait", "put on", "rotate", "move over to B", "move over to C",
                      "move up to 0.87 m"]


def test_valid_actions_at_a_support_held_by_both():
    env = _hanger_at(3)
    mask = env.last_obs["robot"]["action_mask"]
    assert np.flatnonzero(mask).tolist() == [WAIT, TOGGLE, TAKE_OFF]
    assert env.graph.agent_action_label(3, TOGGLE, robot=True) == "let go"


def test_human_override_moves_the_object_and_punishes_the_robot():
    env = _hanger_at(14)  # A column, 0.87 m, peg-facing
    state, reward, info = _step(env, OVER_B, DOWN)
    assert state == 12  # down, as the human wanted
    assert reward == -1.0 and not info["aborted"] and not info["invalid_action"]


def test_aborted_step_changes_only_the_grasp():
    env = _hanger_at(3)
    state, reward, info = _step(env, TOGGLE, TAKE_OFF)  # robot lets go, human takes off
    assert state == 1  # still on A, now held by the human only
    assert reward == -1.0 and info["aborted"] and not info["invalid_action"]


def test_robot_waits_while_the_human_acts():
    env = _hanger_at(12)
    state, reward, info = _step(env, WAIT, UP)
    assert state == 14 and reward == R0 and not info["aborted"]


def test_human_waits_and_nothing_changes():
    env = _hanger_at(12)
    state, reward, _ = _step(env, WAIT, WAIT)
    assert state == 12 and reward == -1.0


def test_robot_leads_while_the_human_waits():
    env = _hanger_at(12)
    state, reward, _ = _step(env, OVER_B, WAIT)
    assert state == 16 and reward == 0.0


def test_masked_robot_action_is_an_aborted_step():
    env = hanger_v0.parallel_env()
    env.reset(seed=0, options={"start": "A", "intention": "B"})
    state, reward, info = _step(env, PUT_ON, TOGGLE)  # the human's grasp still happens
    assert state == 1 and reward == -1.0 and info["aborted"] and info["invalid_action"]


def test_episode_ends_on_the_other_support():
    env = hanger_v0.parallel_env()
    env.reset(seed=0, options={"start": "B", "intention": "C"})
    for a in (TOGGLE, TAKE_OFF, OVER_C, PUT_ON):
        _, _, term, trunc, _ = env.step({"robot": a, "human": a})
        assert not any(term.values()) and not any(trunc.values())
    _, rew, term, _, _ = env.step({"robot": TOGGLE, "human": TOGGLE})
    assert term == {"human": True, "robot": True} and rew["robot"] == 0.0
    assert env.agents == []
    with pytest.raises(RuntimeError, match="reset"):
        env.step({"robot": WAIT, "human": WAIT})


def test_putting_back_on_the_start_ends_only_after_turning_back():
    env = hanger_v0.parallel_env()
    env.reset(seed=0, options={"start": "B", "intention": "A", "turn_back": True})
    for a in (TOGGLE, TAKE_OFF):
        env.step({"robot": a, "human": a})
    for a in (PUT_ON, TOGGLE):  # back onto B after it was lifted
        _, _, term, _, _ = env.step({"robot": a, "human": a})
    assert term["robot"]


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("bad", [10, -1, 99, np.int64(12)])
def test_action_outside_the_space_raises(bad):
    env = hanger_v0.parallel_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=re.escape(f"robot action {int(bad)}")) as err:
        env.step({"human": 0, "robot": bad})
    assert "0..9" in str(err.value)
    assert isinstance(err.value, ActionError)


def test_non_integer_and_missing_actions_raise():
    env = hanger_v0.parallel_env()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="human action 1.5 is not an integer"):
        env.step({"human": 1.5, "robot": 0})
    with pytest.raises(ValueError, match="missing action for agent 'robot'"):
        env.step({"human": 0})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"r0": 0.0}, r"r0 must be a number in the open interval \(-1, 0\)"),
        ({"r0": -1.0}, r"open interval"),
        ({"r0": "x"}, r"open interval"),
        ({"max_cycles": 0}, "max_cycles must be a positive integer"),
        ({"render_mode": "window"}, "allowed: 'ansi', 'rgb_array', 'human', None"),
        ({"backend": "bullet"}, "allowed: graph, mujoco"),
    ],
)
def test_bad_configuration_raises(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        hanger_v0.parallel_env(**kwargs)


def test_missing_mujoco_extra_is_reported(monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "mink" else real(name, *a))
    with pytest.raises(BackendUnavailableError, match=r"needs mink.*-e '\.\[mujoco\]'") as err:
        wheel_v0.parallel_env(backend="mujoco")
    assert isinstance(err.value, NotImplementedError) and isinstance(err.value, ValueError)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"goal": "B"}, "unknown reset option.*'goal'.*allowed: start, intention, turn_back"),
        ({"layout": ((0, 2), (1, 2))}, "unknown reset option"),  # the hanger has no layout
        ({"start": "D"}, "must name a support .*0 or 'A'"),
        ({"start": 3}, "must name a support"),
        ({"start": "A", "intention": 0}, "must differ from the start"),
        ({"turn_back": 1}, "'turn_back' must be a bool"),
    ],
)
def test_bad_reset_options_raise(options, message):
    env = hanger_v0.parallel_env()
    with pytest.raises(ConfigError, match=message):
        env.reset(options=options)


def test_bad_wheel_layout_raises():
    with pytest.raises(ConfigError, match="layout"):
        wheel_v0.parallel_env().reset(options={"layout": (1.0, 2.0)})
