"""Issue 43's third fault round, the continuous envs (v0 and v1 ids, the single env and the
parallel one): every bad argument, reset option and action gets a ``ConfigError`` naming its
field (an ``ActionError`` for actions) before anything is simulated; nothing NaN, infinite,
parsed from a string or cut to its real part reaches the simulation. Valid input is
untouched (the last test; the v0 numbers are guarded by the golden trajectories).
"""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs.errors import ActionError, ConfigError
from hri_envs.physics.carry.env import CarryEnv
from hri_envs.physics.carry.parallel import CarryParallelEnv

pytest.importorskip("mujoco")

VERSIONS = [0, 1]


def _env(version: int, scenario: str = "hanger", **kwargs: object) -> CarryEnv:
    with warnings.catch_warnings():  # gymnasium says v0 is out of date: it is, on purpose
        warnings.simplefilter("ignore", DeprecationWarning)
        name = "Hanger" if scenario == "hanger" else "Wheel"
        return gym.make(f"hri_envs/{name}PandaContinuous-v{version}", **kwargs).unwrapped


@pytest.fixture(scope="module", params=VERSIONS, ids=["v0", "v1"])
def hanger(request):
    return _env(request.param)


@pytest.fixture(scope="module", params=VERSIONS, ids=["v0", "v1"])
def wheel(request):
    return _env(request.param, "wheel")


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize(("sensor", "text"), [
    ({"noise_n": math.nan}, "sensor 'noise_n' must be a finite number >= 0, got nan"),
    ({"bias_n": math.nan}, "sensor 'bias_n' must be a finite number >= 0, got nan"),
    ({"noise_n": math.inf}, "sensor 'noise_n' must be a finite number >= 0, got inf"),
    ({"bias_n": -math.inf}, "sensor 'bias_n' must be a finite number >= 0, got -inf"),
    ({"delay_s": math.nan}, "sensor 'delay_s' must be a finite number >= 0, got nan"),
    ({"delay_s": math.inf}, "sensor 'delay_s' must be a finite number >= 0, got inf"),
    ({"noise_n": "1"}, "sensor 'noise_n' must be a finite number >= 0"),
    ({"noise_n": True}, "sensor 'noise_n' must be a finite number >= 0"),
    ("noise", "sensor must be None or a mapping of noise_n, bias_n, delay_s"),
    ([("noise_n", 1.0)], "sensor must be None or a mapping"),
    ({"noise": 1.0, 3: 1}, r"unknown sensor key\(s\) 'noise', 3"),
])
def test_a_bad_sensor_is_refused_naming_the_key(version, sensor, text):
    """A NaN or inf noise or bias reached the observation from the first step; a NaN
    delay was a raw ValueError, a str a raw dict error."""
    with pytest.raises(ConfigError, match=text) as err:
        _env(version, sensor=sensor)
    assert err.value.field == "sensor"


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("key", ["max_step_m", "max_step_rad"])
@pytest.mark.parametrize("value", [math.inf, math.nan, 0, -0.01, "0.02", True])
def test_the_action_scale_is_a_finite_positive_number(version, key, value):
    """max_step_m=inf was accepted and the episode ended as 'slipped'."""
    with pytest.raises(ConfigError, match=f"{key} must be a finite number > 0") as err:
        _env(version, **{key: value})
    assert err.value.field == key


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("human", ["weak", 5, [1], {"weak"}, ("preset", "weak")])
def test_a_human_that_is_not_a_mapping_is_refused(version, human):
    with pytest.raises(ConfigError, match=r"human must be None or a mapping of human "
                                          r"parameters \(e.g. \{'preset': 'weak'\}") as err:
        _env(version, human=human)
    assert err.value.field == "human"


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize(("human", "text"), [
    ({"preset": ["weak"]}, r"unknown human preset \['weak'\]"),
    ({"sex": ["male"]}, r"human 'sex' must be one of male, female"),
    ({1: 2, "x": 3}, r"unknown human parameter\(s\) 'x', 1"),
])
def test_human_values_of_the_wrong_type_are_named(version, human, text):
    with pytest.raises(ConfigError, match=text) as err:
        _env(version, human=human)
    assert err.value.field == "human"


def test_a_v1_episodes_human_is_checked_alike():
    env = _env(1)
    with pytest.raises(ConfigError, match="human must be None or a mapping") as err:
        env.reset(seed=0, options={"human": "weak"})
    assert err.value.field == "human"


@pytest.mark.parametrize("version", VERSIONS)
def test_a_reward_that_is_not_a_mapping_is_refused(version):
    with pytest.raises(ConfigError, match="reward must be a mapping of weights") as err:
        _env(version, reward=[1, 2])
    assert err.value.field == "reward"


@pytest.mark.parametrize("options", ["start", 5, ["start"], ("start", "A")])
def test_reset_options_that_are_not_a_dict_name_the_argument(hanger, options):
    with pytest.raises(ConfigError, match="reset options must be None or a dict") as err:
        hanger.reset(seed=0, options=options)
    assert err.value.field == "options"


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
def test_a_bad_reset_seed_is_the_projects_error_naming_the_seed(hanger, seed):
    """As the v0 graph envs (tests/test_bad_input.py), not gymnasium's own error."""
    with pytest.raises(ConfigError, match="seed must be a whole number >= 0 or None") as err:
        hanger.reset(seed=seed)
    assert err.value.field == "seed"


def test_the_hanger_has_no_layout_option(hanger):
    """The option was silently ignored."""
    with pytest.raises(ConfigError, match=r"unknown reset option\(s\) 'layout'; allowed: "
                                          r"start, intention, robot_holds") as err:
        hanger.reset(seed=0, options={"layout": ((0.0, 2.2), (1.6, 2.2))})
    assert err.value.field == "options"


@pytest.mark.parametrize(("layout", "text"), [
    (((math.nan, 2.2), (1.6, 2.2)), r"layout' must be \(\(xB, yB\), \(xC, yC\)\) in \[m\]"),
    (((0.0, math.inf), (1.6, 2.2)), r"layout' must be \(\(xB, yB\), \(xC, yC\)\) in \[m\]"),
    ((("a", "b"), ("c", "d")), r"layout' must be \(\(xB, yB\), \(xC, yC\)\) in \[m\]"),
    (((0.0, 2.2, 0.0), (1.6, 2.2, 0.0)), r"layout' must be \(\(xB, yB\), \(xC, yC\)\)"),
    ("B C", r"layout' must be \(\(xB, yB\), \(xC, yC\)\) in \[m\]"),
    (((1.0, 2.0), (1.0, 2.0)), "the stands are 0 m apart"),
])
def test_a_bad_wheel_layout_is_refused_before_it_reaches_the_observation(wheel, layout, text):
    """A NaN or inf stand reached the observation from step 1; strings and 3-vectors were
    raw TypeErrors and ValueErrors. The checks are the graph envs' (same messages)."""
    with pytest.raises(ConfigError, match=text) as err:
        wheel.reset(seed=0, options={"layout": layout})
    assert err.value.field == "layout"


@pytest.mark.parametrize("action", [
    ["0"] * 7, np.array(["0.1"] * 7), [0j] * 7, np.full(7, 0.5 + 1j), np.full(7, 0.5 + 0j),
    [True] * 7, np.zeros(7, dtype=bool), np.array([None] * 7), "0000000",
])
def test_string_complex_and_bool_actions_are_refused_not_coerced(hanger, action):
    """A list of str was parsed and a complex array cut to its real part."""
    hanger.reset(seed=0)
    with pytest.raises(ActionError, match=r"the robot's action must be 7 finite numbers in "
                                          r"\[-1, 1\]"):
        hanger.step(action)


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("actions", [None, [np.zeros(7), np.zeros(7)], "robot", 0,
                                     (np.zeros(7), np.zeros(7))])
def test_parallel_step_takes_a_dict_of_actions(version, actions):
    env = CarryParallelEnv(version=version)
    env.reset(seed=0)
    with pytest.raises(ActionError, match=r"step\(\) takes a dict of one action per agent"):
        env.step(actions)
    with pytest.raises(ActionError, match=r"the human's action must be 7 finite numbers"):
        env.step({"robot": np.zeros(7), "human": ["0"] * 7})


@pytest.mark.parametrize("version", VERSIONS)
def test_valid_input_still_runs(version):
    """The checks take what they took: numpy numbers, ints, float32 actions, a wheel layout
    as lists, a sensor mapping."""
    env = _env(version, "wheel", sensor={"noise_n": np.float64(0.5), "bias_n": 0, "delay_s": 0.01},
               max_step_m=np.float32(0.02), max_step_rad=1, human={"preset": "weak"})
    obs, _ = env.reset(seed=np.int64(3), options={"layout": [[0.0, 2.2], [1.6, 2.2]],
                                                  "start": "A", "intention": 1})
    assert env.layout == ((0.0, 2.2), (1.6, 2.2))
    for action in (np.zeros(7, dtype=np.float32), [0] * 7, np.ones(7, dtype=np.int8)):
        obs, *_ = env.step(action)
        assert np.all(np.isfinite(obs))
