"""Issue 24: bad input gets an error of hri_envs.errors naming the field (or exit 2 from the
CLI) before anything is simulated, and nothing is silently changed. One test per case the
issue lists; tests/test_fuzz_inputs.py throws generated values at the same doors.
"""

import math

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs import hanger_v0, wheel_v0
from hri_envs.checks import check_flag, check_real, check_whole
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.errors import ActionError, ConfigError, ResetNeeded

# ----------------------------------------------------------------- shared checks


@pytest.mark.parametrize("value", [True, 1.0, 10.5, "3", math.nan, None, [1], 1 + 0j])
def test_a_whole_number_is_an_int_and_nothing_else(value):
    with pytest.raises(ConfigError, match=r"runs must be a whole number >= 1") as err:
        check_whole(value, "runs", minimum=1)
    assert err.value.field == "runs"


@pytest.mark.parametrize("value", [True, np.bool_(False), "0.5", math.nan, math.inf, 1j, None])
def test_a_real_number_is_a_finite_int_or_float(value):
    with pytest.raises(ConfigError, match=r"lr must be a finite number > 0") as err:
        check_real(value, "lr", low=0.0, low_open=True)
    assert err.value.field == "lr"


def test_numbers_of_numpy_pass_unchanged():
    assert check_whole(np.int32(4), "n", minimum=1) == 4
    assert check_real(np.float32(0.5), "p", low=0.0, high=1.0) == 0.5
    assert check_real(math.inf, "beta", low=0.0, low_open=True, allow_inf=True) == math.inf
    assert check_flag(np.True_, "flag") is True
    with pytest.raises(ConfigError, match="flag must be True or False, got 1"):
        check_flag(1, "flag")


# ----------------------------------------------------------------- envs


@pytest.mark.parametrize("make", [
    lambda **kw: gym.make("hri_envs/Hanger-v0", **kw),
    lambda **kw: hanger_v0.parallel_env(**kw),
    lambda **kw: RobotVectorEnv(2, "hanger", **kw),
], ids=["robot", "parallel", "vector"])
@pytest.mark.parametrize("options", [["start"], 5, "start", ("start", "A")])
def test_reset_options_that_are_not_a_dict_name_the_argument(make, options):
    env = make()
    with pytest.raises(ConfigError, match="reset options must be None or a dict") as err:
        env.reset(seed=0, options=options)
    assert err.value.field == "options"


@pytest.mark.parametrize("actions", [[0, 0], None, 0, "human", (0, 0)])
def test_parallel_step_takes_a_dict_of_actions(actions):
    env = hanger_v0.parallel_env()
    env.reset(seed=0)
    with pytest.raises(ActionError, match=r"step\(\) takes a dict of one action per agent"):
        env.step(actions)


@pytest.mark.parametrize("beta", [True, False, "2", "inf", 1j])
def test_human_rationality_must_be_a_number_not_a_bool(beta):
    for make in (lambda: gym.make("hri_envs/Hanger-v0", human_rationality=beta),
                 lambda: RobotVectorEnv(2, "hanger", human_rationality=beta)):
        with pytest.raises(ConfigError, match="human_rationality must be a number > 0") as err:
            make()
        assert err.value.field == "human_rationality"


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"render_intention": "no"}, "render_intention"),
    ({"max_cycles": 10**12}, "max_cycles"),
    ({"max_cycles": 3.0}, "max_cycles"),
    ({"r0": "-0.3"}, "r0"),
    ({"render_mode": ["ansi"]}, "render_mode"),
])
def test_env_arguments_of_the_wrong_type_name_the_field(kwargs, field):
    with pytest.raises(ConfigError) as err:
        hanger_v0.parallel_env(**kwargs)
    assert err.value.field == field


def test_vector_env_numbers_are_checked():
    with pytest.raises(ConfigError, match="num_envs must be a whole number >= 1") as err:
        RobotVectorEnv(True, "hanger")
    assert err.value.field == "num_envs"
    env = RobotVectorEnv(2, "hanger")
    with pytest.raises(ConfigError, match="seed must be a whole number >= 0") as err:
        env.reset(seed=-1)
    assert err.value.field == "seed"


def _finish_aec(env):
    env.reset(seed=0, options={"start": "A", "intention": "B"})
    while env.agents:
        _, _, terminated, truncated, _ = env.last()
        env.step(None if terminated or truncated else 0)


@pytest.mark.parametrize("module", [hanger_v0, wheel_v0])
def test_stepping_a_finished_or_unreset_aec_raw_env_needs_a_reset(module):
    env = module.raw_env()
    with pytest.raises(ResetNeeded):
        env.step(0)
    _finish_aec(env)
    with pytest.raises(ResetNeeded):  # was KeyError: 'robot'
        env.step(0)
    env.reset(seed=1)  # and it plays again
    env.step(0)


def test_a_dead_aec_agent_is_stepped_with_none():
    env = hanger_v0.raw_env(max_cycles=1)
    env.reset(seed=0)
    env.step(0)
    env.step(0)  # the one step: both agents are truncated now
    with pytest.raises(ActionError, match="step it with None"):
        env.step(0)
    env.step(None)
