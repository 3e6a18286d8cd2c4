"""Property-based: generated bad values at every door of the library never give anything
but a named error or documented behaviour (issue 24).

Doors: every constructor argument of RobotEnv, CooperationParallelEnv, RobotVectorEnv and
PartnerEnv, every reset option, every step input, every ``hri-bench study`` flag and every
``--config`` setting. A value is either accepted — and then the env still resets and steps,
and the value is used as given (an action as the integer it is, a setting as the JSON it
was) — or refused with an ``HriEnvsError`` (a ``ConfigError`` names its field), or, on the
command line, exit 2 with no traceback. Nothing is ever simulated by the CLI cases: the
study's runner is replaced by a stop that records the configuration it would have run.

Deterministic (``derandomize=True``) and quick: a few seconds in all.
"""

import contextlib
import io
import itertools
import json
import math
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import hri_envs  # noqa: F401  (registers the ids)
from hri_bench.cli import commands as cli
from hri_bench.cli import parser as cli_parser
from hri_envs.checks import integer_or_none
from hri_envs.envs.config import check_physics_options
from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.envs.partner import PartnerEnv
from hri_envs.envs.robot import RobotEnv
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.errors import ConfigError, HriEnvsError
from hri_envs.humans.populations import POPULATIONS
from hri_envs.humans.scripted import preference_human
from hri_envs.physics.panda.options import OPTION_KEYS
from hri_envs.task.scenarios import scenario_graph

# An overflow or NaN in numpy is a silent wrong result: an error here.
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

FUZZ = settings(max_examples=120, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow])
FEW = settings(FUZZ, max_examples=60)
N_ACTIONS = scenario_graph("hanger").n_actions

# ----------------------------------------------------------------- strategies

#: Anything a caller might pass by mistake.
junk = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(),
    st.text(max_size=8), st.binary(max_size=4), st.complex_numbers(allow_nan=True),
    st.lists(st.integers(-3, 12), max_size=3), st.tuples(st.integers(-3, 3), st.text(max_size=2)),
    st.dictionaries(st.text(max_size=4), st.integers(-3, 3), max_size=2),
    st.sampled_from([np.int64(3), np.int8(-1), np.float32(0.5), np.float64(1.0), np.bool_(True),
                     np.array([1, 2]), np.array(0.5), object(), math.inf, -math.inf, math.nan,
                     "", "0", "1", "A", "inf", "nan", 1e308, 2**63, -1, 0, 1]),
)


def _or_valid(*valid):
    return st.one_of(junk, st.sampled_from(valid))


_GRAPH = scenario_graph("hanger")
_PHYSICS = st.one_of(junk, st.dictionaries(
    st.one_of(st.sampled_from(OPTION_KEYS), st.text(max_size=4)), junk, max_size=3))

#: Plausible values per constructor argument, mixed into the junk.
ARGUMENTS = {
    "scenario": _or_valid("hanger", "wheel"),
    "preference": _or_valid(None, "straight", "down-over-rotate/over-rotate-up"),
    "human_passive": _or_valid(0.0, 0.2, 1),
    "turn_back": _or_valid(0.0, 0.5, 1.0),
    "human": _or_valid(None, preference_human(_GRAPH)),
    "human_rationality": _or_valid(math.inf, 2.0, 1),
    "population": _or_valid(None, *POPULATIONS),
    "r0": _or_valid(None, -0.33, -0.5),
    "max_cycles": _or_valid(1, 10, 100),
    "render_mode": _or_valid(None, "ansi", "rgb_array"),  # "human" would open a window
    "backend": _or_valid("graph"),  # "mujoco" is built in tests/test_physics_envs.py
    "render_intention": _or_valid(True, False),
    "physics": st.one_of(_PHYSICS, st.just({})),
    "observation_format": _or_valid("dict", "classic", "flat"),
    "reward": _or_valid("paper", "no-free-toggle"),
    "human_reward": _or_valid("cooperation", "goal"),
    "autoreset_mode": _or_valid("next_step", "same_step"),
}
ROBOT_ARGS = ("scenario", "preference", "human_passive", "turn_back", "human",
              "human_rationality", "population", "r0", "max_cycles", "render_mode", "backend",
              "render_intention", "physics", "observation_format", "reward")
PARALLEL_ARGS = ("scenario", "r0", "max_cycles", "render_mode", "backend", "render_intention",
                 "physics", "observation_format", "human_reward", "turn_back", "reward")
VECTOR_ARGS = ("scenario", "preference", "human_passive", "turn_back", "human",
               "human_rationality", "population", "r0", "max_cycles", "render_mode", "backend",
               "autoreset_mode", "reward")


def kwargs_of(names):
    """One or two of ``names`` with generated values."""
    keys = st.lists(st.sampled_from(names), min_size=1, max_size=2, unique=True)
    return keys.flatmap(lambda ks: st.fixed_dictionaries({k: ARGUMENTS[k] for k in ks}))


def refused_or(fn):
    """``fn()``'s result, or None when it raised a named error (anything else propagates)."""
    try:
        return fn()
    except HriEnvsError as exc:
        if isinstance(exc, ConfigError):
            assert exc.field, f"ConfigError without a field: {exc}"
        assert str(exc)
        return None


def _play_one_step(env, action):
    env.reset(seed=0)
    env.step(action)
    env.close()


# ----------------------------------------------------------------- constructors


@FUZZ
@given(kwargs_of(ROBOT_ARGS))
def test_robot_env_arguments(kwargs):
    env = refused_or(lambda: RobotEnv(**kwargs))
    if env is not None:
        _play_one_step(env, 0)


@FUZZ
@given(kwargs_of(PARALLEL_ARGS))
def test_parallel_env_arguments(kwargs):
    env = refused_or(lambda: CooperationParallelEnv(**kwargs))
    if env is not None:
        _play_one_step(env, {"human": 0, "robot": 0})


@FUZZ
@given(_or_valid(1, 2, 5), kwargs_of(VECTOR_ARGS))
def test_vector_env_arguments(num_envs, kwargs):
    env = refused_or(lambda: RobotVectorEnv(num_envs, **kwargs))
    if env is not None:
        assert env.num_envs == num_envs  # taken as given, never converted
        _play_one_step(env, np.zeros(env.num_envs, dtype=np.int64))


def _policy(observation, rng):
    return 0


@FUZZ
@given(st.one_of(junk, st.sampled_from(["parallel"])), _or_valid("robot", "human"),
       _or_valid(None, _policy, preference_human(_GRAPH)))
def test_partner_env_arguments(env, learner, partner):
    if isinstance(env, str) and env == "parallel":
        env = CooperationParallelEnv("hanger")
    wrapped = refused_or(lambda: PartnerEnv(env, learner=learner, partner=partner))
    if wrapped is not None:
        _play_one_step(wrapped, 0)


@FUZZ
@given(_PHYSICS)
def test_physics_options_of_the_mujoco_backend(physics):
    refused_or(lambda: check_physics_options(physics, "mujoco"))


# ----------------------------------------------------------------- reset options

_OPTION_VALUES = st.one_of(junk, st.sampled_from(
    ["A", "B", "C", 0, 1, 2, True, False, ((1.0, 2.0), (2.0, 1.0)), [[1, 2], [3, 4]],
     np.array(["A", "B"]), np.array([0, 1]), np.array([True, False]), np.array([1.5, 2.0])]))
OPTIONS = st.one_of(junk, st.dictionaries(
    st.one_of(st.sampled_from(["start", "intention", "turn_back", "layout", "options"]),
              st.text(max_size=3)), _OPTION_VALUES, max_size=3))


@pytest.fixture(scope="module")
def envs():
    return {"robot": RobotEnv("wheel"), "parallel": CooperationParallelEnv("wheel"),
            "vector": RobotVectorEnv(2, "wheel"),
            "partner": PartnerEnv(CooperationParallelEnv("wheel"))}


_STEP = {"robot": 0, "parallel": {"human": 0, "robot": 0}, "partner": 0,
         "vector": np.zeros(2, dtype=np.int64)}


@FUZZ
@given(st.sampled_from(sorted(_STEP)), OPTIONS)
def test_reset_options(envs, kind, options):
    env = envs[kind]
    if refused_or(lambda: env.reset(seed=0, options=options)) is None:
        return
    env.step(_STEP[kind])
    start = options.get("start") if isinstance(options, dict) else None
    if kind == "parallel" and start is not None:  # the start asked for is the start played
        names = env.graph.support_names
        assert env.state()[1] == (names.index(start) if isinstance(start, str) else start)


# ----------------------------------------------------------------- step inputs

_ACTIONS = st.one_of(junk, st.integers(-2, N_ACTIONS + 1))


@FUZZ
@given(st.one_of(_ACTIONS, st.dictionaries(st.sampled_from(["human", "robot", "x"]), _ACTIONS,
                                           max_size=3)))
def test_parallel_step_inputs(envs, actions):
    env = envs["parallel"]
    env.reset(seed=0)
    if refused_or(lambda: env.step(actions)) is None:
        return
    for agent in ("human", "robot"):  # accepted: both were integers of the action space
        number = integer_or_none(actions[agent])
        assert number is not None and 0 <= number < env.graph.n_actions


@FUZZ
@given(st.sampled_from(["robot", "partner"]), _ACTIONS)
def test_single_agent_step_inputs(envs, kind, action):
    env = envs[kind]
    env.reset(seed=0)
    if refused_or(lambda: env.step(action)) is not None:
        number = integer_or_none(action)
        assert number is not None and 0 <= number < env.unwrapped.graph.n_actions


_ARRAYS = hnp.arrays(
    st.sampled_from([np.int64, np.int32, np.uint8, np.float64, np.bool_, np.complex64,
                     np.dtype("U2")]),
    st.sampled_from([(2,), (1,), (3,), (2, 1), ()]), elements=None)


@FUZZ
@given(st.one_of(junk, _ARRAYS))
def test_vector_step_inputs(envs, actions):
    env = envs["vector"]
    env.reset(seed=0)
    if refused_or(lambda: env.step(actions)) is not None:
        a = np.asarray(actions)
        assert a.shape == (2,) and a.dtype.kind in "iu"
        assert ((a >= 0) & (a < env.graph.n_actions)).all()


# ----------------------------------------------------------------- hri-bench study


class WouldSimulate(Exception):
    """Raised instead of simulating: the CLI accepted everything."""

    def __init__(self, cfg):
        super().__init__("would simulate")
        self.cfg = cfg


def _stop(folder, *, progress=False):
    raise WouldSimulate(folder.cfg)


_count = itertools.count()


@pytest.fixture(scope="module")
def outs(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz-cli")


def _cli(argv):
    """(exit code or the accepted StudyConfig, stderr) of ``hri-bench`` run in-process."""
    err = io.StringIO()
    with mock.patch("hri_bench.cli.study_command.run_in", _stop), \
            contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            result = cli.main(argv)
        except SystemExit as stop:
            result = stop.code
        except WouldSimulate as accepted:
            result = accepted.cfg
    assert "Traceback" not in err.getvalue()
    return result, err.getvalue()


_FLAGS = sorted({*(v for k, v in cli_parser.STUDY_ARGUMENTS.items() if v.startswith("--")),
                 *(flag for flag, _, _ in cli_parser.LEARNER_FLAGS.values())})
_TEXT = st.one_of(st.text(max_size=10), st.sampled_from([
    "-1", "0", "1", "2", "1e15", "1000000", "nan", "inf", "-inf", "1.5", "0.5", "-0.5", "",
    "true", "learner", "passive,passive", "x:y", ":x", ".x:y", "sb3:/nonexistent", "hanger",
    "all", "mujoco", "process", "weak-human", "straight", "no-free-toggle", "100000",
    "1" * 30]))


@FUZZ
@given(st.sampled_from(_FLAGS), _TEXT)
def test_study_flags(outs, flag, text):
    out = outs / f"o{next(_count)}"
    result, err = _cli(["study", "hanger", "--runs", "2", "--episodes", "1", "--agents",
                        "passive", "--no-progress", "--out", str(out), f"{flag}={text}"])
    assert result == 2 or not isinstance(result, int), (flag, text, result, err)
    if result == 2:
        assert err.strip().splitlines()[-1].startswith(("hri-bench study: error: argument",
                                                        "hri-bench: error: argument"))


def _json_values():
    leaves = st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(),
                       st.text(max_size=6))
    return st.recursive(leaves, lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=2)),
        max_leaves=6)


@pytest.fixture(scope="module")
def recorded(outs):
    """A tiny study's settings, as its summary.json holds them."""
    from hri_bench.run.study import StudyConfig

    cfg = StudyConfig("hanger", agents=("passive",), runs=2, episodes=1)
    return json.loads(json.dumps(cfg.settings()))


_PLAUSIBLE = st.sampled_from([["learner", "passive"], ["x:y"], 3, 0, -1, 0.5, "inf", "random",
                              "table2", "all", "straight", [["beta", 0.9]], [["beta", "0.9"]],
                              [{"label": "p", "kind": "human", "state": 1, "intention": 1,
                                "action": 0}], "weak-human", "mujoco", "no-free-toggle"])


@FUZZ
@given(st.data())
def test_config_settings(outs, recorded, data):
    field = data.draw(st.sampled_from(sorted(recorded)))
    settings_ = dict(recorded)
    drop = data.draw(st.integers(0, 9), label="drop") == 0  # a setting left out
    if drop:
        del settings_[field]
    else:
        settings_[field] = data.draw(st.one_of(_json_values(), _PLAUSIBLE), label="value")
    path = outs / f"c{next(_count)}.json"
    path.write_text(json.dumps({"settings": settings_}))
    result, err = _cli(["study", "--config", str(path), "--out", str(outs / f"o{next(_count)}"),
                        "--no-progress"])
    if isinstance(result, int):
        assert result == 2, err
        assert err.strip().splitlines()[-1].startswith(
            f"hri-bench study: error: argument --config: {path}: ")
        return
    assert not drop
    # Accepted: the study to run holds the setting exactly as the file wrote it.
    assert json.loads(json.dumps(result.settings()[field])) == settings_[field]


@FEW
@given(st.binary(max_size=40))
def test_config_files_that_are_not_json(outs, content):
    path = Path(outs / f"b{next(_count)}.json")
    path.write_bytes(content)
    result, err = _cli(["study", "--config", str(path), "--out", str(outs / "never")])
    assert result == 2, err
