"""Issue 24: bad input gets an error of hri_envs.errors naming the field (or exit 2 from the
CLI) before anything is simulated, and nothing is silently changed. One test per case the
issue lists; tests/test_fuzz_inputs.py throws generated values at the same doors.
"""

import json
import math
import re

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from agents import Learner, LearnerConfig, LearnerStateError
from agents.protocol import BatchAgent, Batched
from agents.rollout import run_episode
from hri_bench.cli import main
from hri_bench.run.study import StudyConfig, run_study
from hri_envs import hanger_v0, wheel_v0
from hri_envs.checks import check_flag, check_real, check_whole
from hri_envs.envs.partner import PartnerEnv
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.errors import ActionError, ConfigError, ResetNeeded
from hri_envs.humans.protocol import Human
from hri_envs.task.scenarios import scenario_graph
from tests.helpers_agents import AlwaysWait

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


def test_a_finite_rationality_is_bounded_where_it_would_overflow():
    RobotVectorEnv(1, "hanger", human_rationality=1e6)
    with pytest.raises(ConfigError, match="finite values at most 1e"):
        RobotVectorEnv(1, "hanger", human_rationality=1e300)  # NaN policies, once


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"render_intention": "no"}, "render_intention"),
    ({"max_cycles": 10**12}, "max_cycles"),
    ({"max_cycles": 3.0}, "max_cycles"),
    ({"r0": "-0.3"}, "r0"),
    ({"render_mode": ["ansi"]}, "render_mode"),
    ({"physics": ["preset"]}, "physics"),
    ({"reward": np.array([1, 2])}, "reward"),
    ({"backend": None}, "backend"),
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


# ----------------------------------------------------------------- agents


class _Returns(AlwaysWait):
    def __init__(self, value):
        self.value = value

    def act(self, observation):
        return self.value


def _observations(n=2, n_actions=10):
    return {"state": np.zeros(n, np.int64), "start": np.zeros(n, np.int64),
            "last_human_action": np.zeros(n, np.int64),
            "action_mask": np.ones((n, n_actions), np.int8)}


@pytest.mark.parametrize("value", [0.5, 1.9, True, np.True_, "3", 1.0, None, 2**70, [1]])
def test_a_batched_agent_refuses_what_is_not_an_integer(value):
    batch = Batched([AlwaysWait(), _Returns(value)], runs=[4, 7])
    with pytest.raises(ActionError, match=r"act\(\) of agent 'always-wait' returned .* for "
                                          r"run 7; an action is an integer") as err:
        batch.act(_observations(), np.ones(2, bool))
    assert repr(value)[:10] in str(err.value)


def test_a_batched_agent_passes_integers_through():
    batch = Batched([_Returns(np.int32(3)), _Returns(99)])
    assert batch.act(_observations(), np.ones(2, bool)).tolist() == [3, 99]  # range: runner's


@pytest.mark.parametrize(("agent", "shown"), [("ReturnsHalf", "0.5"), ("ReturnsTrue", "True"),
                                              ("ReturnsText", "'3'")])
def test_a_study_refuses_an_agent_that_returns_no_integer(agent, shown):
    name = f"tests.helpers_agents:{agent}"
    cfg = StudyConfig("hanger", agents=(name,), runs=2, episodes=1)
    with pytest.raises(ActionError, match=rf"agent '{name}': act\(\) of agent '.*' returned "
                                          rf"{re.escape(shown)} \(\w+\) for run 0; .*"
                                          r"\(episode 1, step 1\)"):
        run_study(cfg)


def test_run_episode_refuses_a_float_action():
    env = gym.make("hri_envs/Hanger-v0")
    with pytest.raises(ActionError, match="robot action 0.5 is not an integer"):
        run_episode(env, _Returns(0.5))


def test_a_single_of_a_batch_agent_refuses_float_actions():
    class Floats(BatchAgent):
        def begin_episode(self, starts):
            pass

        def act(self, observations, active):
            return np.full(self.n_runs, 1.0)

        def observe(self, *args):
            pass

        def end_episode(self, traces, intentions):
            pass

    obs = {k: v[0] for k, v in _observations(1).items()}
    with pytest.raises(ActionError, match="returned float64 of shape"):
        Floats(1).single().act(obs)


@pytest.mark.parametrize(("field", "value"), [
    ("learning_rate", math.inf), ("learning_rate", "0.1"), ("beta", True), ("gamma", math.nan),
    ("passive_prior", 1), ("pretrain_passes", 3.0), ("pretrain_passes", 10**6),
    ("initial_preference", 5),
])
def test_learner_config_refuses_values_of_the_wrong_kind(field, value):
    with pytest.raises(ConfigError) as err:
        LearnerConfig(**{field: value})
    assert err.value.field == field


@pytest.mark.parametrize("dtype", [np.complex128, np.float32, np.int64])
def test_a_saved_learner_state_of_another_dtype_is_refused(tmp_path, dtype):
    graph = scenario_graph("hanger")
    path = tmp_path / "state"
    Learner(graph, 1, seed=0).save(path)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["theta"] = arrays["theta"].astype(dtype)
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(LearnerStateError, match=f"theta holds {np.dtype(dtype)} values; a "
                                                "learner state holds arrays of real numbers"):
        Learner.load(path, graph)


# ----------------------------------------------------------------- SB3 models


class _Payload:
    def __reduce__(self):  # what a pickle payload does: call something on load
        return (print, ("the payload ran",))


@pytest.fixture(scope="module")
def sb3_zips(tmp_path_factory):
    """An untrained MaskablePPO's .zip, and a copy whose weights carry a pickle payload."""
    import io
    import zipfile

    import torch
    from sb3_contrib import MaskablePPO

    folder = tmp_path_factory.mktemp("sb3")
    good, evil = folder / "model.zip", folder / "payload.zip"
    MaskablePPO("MultiInputPolicy", gym.make("hri_envs/Hanger-v0"), n_steps=64,
                batch_size=32, device="cpu").save(good)
    buf = io.BytesIO()
    torch.save({"x": _Payload()}, buf)
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(evil, "w") as dst:
        for name in src.namelist():
            dst.writestr(name, buf.getvalue() if name == "policy.pth" else src.read(name))
    return good, evil


def test_a_pickle_payload_in_sb3_weights_is_a_clear_error(sb3_zips, capsys):
    from agents.sb3 import load_model

    good, evil = sb3_zips
    load_model(good)
    with pytest.raises(ConfigError, match="hold Python objects other than tensors") as err:
        load_model(evil)
    assert err.value.field == "path"
    assert err.value.__cause__ is None and err.value.__suppress_context__
    assert "weights_only" not in str(err.value)
    assert "the payload ran" not in capsys.readouterr().out


def test_an_sb3_path_that_is_a_directory_is_a_clear_error(tmp_path):
    from agents.sb3 import load_model

    with pytest.raises(ConfigError, match=r"cannot read the SB3 model .* \(Is a directory\)"):
        load_model(tmp_path)


def test_the_cli_refuses_an_sb3_payload_before_simulating(sb3_zips, tmp_path, capsys):
    _, evil = sb3_zips
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as stop:
        main(["study", "hanger", "--agents", f"passive,sb3:{evil}", "--runs", "2",
              "--episodes", "1", "--no-progress", "--out", str(out)])
    assert stop.value.code == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "argument --agents: agent 'sb3:" in err and "Traceback" not in err


# ----------------------------------------------------------------- hri-bench


def _exit_2(argv, capsys):
    """Run hri-bench in-process; it must exit 2 with one error line and no traceback."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2, err
    assert "Traceback" not in err
    return err.strip().splitlines()[-1]


TINY = ["--runs", "2", "--episodes", "1", "--agents", "passive", "--no-progress"]


@pytest.mark.parametrize(("flags", "message"), [
    (["--learner-learning-rate", "inf"],
     "argument --learner-learning-rate: learning_rate must be a finite number > 0, got inf"),
    (["--learner-beta", "nan"], "argument --learner-beta: beta must be in (0, 1], got nan"),
    (["--seed", "-1"], "argument --seed: expected a whole number >= 0, got -1"),
    (["--runs", "1000000"], "argument --runs: runs must be a whole number >= 1 and <= 100,000"),
    (["--runs", "1e15"], "argument --runs: expected a whole number >= 1, got '1e15'"),
    (["--episodes", "9999", "--runs", "1000"], "argument --runs: runs x episodes must be at "
                                               "most 1,000,000"),
    (["--max-steps", "100000"], "argument --max-steps: max_steps must be a whole number >= 1 "
                                "and <= 10,000"),
    (["--agents", "passive,passive"], "argument --agents: agents must name each agent once"),
])
def test_bad_flags_exit_2_before_simulating(flags, message, tmp_path, capsys):
    out = tmp_path / "out"
    line = _exit_2(["study", "hanger", *TINY, "--out", str(out), *flags], capsys)
    assert message in line
    assert not out.exists()


@pytest.mark.parametrize("command", [["figures", "--out", "x"], ["play", "hanger"],
                                     ["suite", "--out", "x"]])
def test_every_seed_flag_refuses_a_negative_seed(command, capsys):
    assert "argument --seed: expected a whole number >= 0" in _exit_2(
        [*command, "--seed", "-1"], capsys)


def test_an_option_written_as_flag_equals_dashes_exits_2(tmp_path, capsys):
    # Python 3.11's argparse turns "--jobs=--" into an empty list, which used to reach
    # "'>' not supported between 'list' and 'int'".
    line = _exit_2(["study", "hanger", *TINY, "--out", str(tmp_path), "--jobs=--"], capsys)
    assert "argument --jobs: expected one argument" in line


@pytest.mark.parametrize("spec", [":", ".:x", "/:x", ".x:Y"])
def test_a_module_class_that_cannot_be_imported_exits_2(spec, tmp_path, capsys):
    line = _exit_2(["study", "hanger", *TINY, "--out", str(tmp_path / "o"), "--population",
                    spec], capsys)
    assert f"argument --population: cannot import human {spec!r}" in line


def test_an_out_folder_that_cannot_be_created_exits_2(capsys):
    line = _exit_2(["study", "hanger", *TINY, "--out", "/proc/hri-envs-x"], capsys)
    assert "argument --out: cannot use '/proc/hri-envs-x' as the study's folder" in line


def test_the_suite_names_runs_scale_for_too_many_runs(tmp_path, capsys):
    line = _exit_2(["suite", "--out", str(tmp_path / "s"), "--runs-scale", "1e9",
                    "--no-progress"], capsys)
    assert "argument --runs-scale: runs must be a whole number" in line


@pytest.fixture(scope="module")
def settings(tmp_path_factory):
    """The settings of a tiny study, as its summary.json records them."""
    out = tmp_path_factory.mktemp("study") / "out"
    assert main(["study", "hanger", *TINY, "--out", str(out)]) == 0
    return json.loads((out / "summary.json").read_text())["settings"]


def _config(tmp_path, settings, **changes):
    path = tmp_path / "summary.json"
    doc = {**settings, **changes}
    for key, value in changes.items():
        if value is _DROP:
            del doc[key]
    path.write_text(json.dumps({"settings": doc}))
    return path


_DROP = object()


@pytest.mark.parametrize(("changes", "message"), [
    ({"runs": True}, "runs must be a whole number >= 1 and <= 100,000, got True"),
    ({"runs": 10.5}, "runs must be a whole number >= 1 and <= 100,000, got 10.5"),
    ({"runs": math.nan}, "runs must be a whole number >= 1 and <= 100,000, got nan"),
    ({"runs": 1e15}, "runs must be a whole number >= 1 and <= 100,000, got 1000000000000000.0"),
    ({"runs": "5"}, "runs must be a whole number >= 1 and <= 100,000, got '5'"),
    ({"runs": _DROP}, "missing setting(s) runs"),
    ({"seed": 1.5}, "seed must be a whole number >= 0, got 1.5"),
    ({"agents": [1, 2]}, "agents must be a non-empty list of agent names"),
    ({"agents": "learner"}, "agents must be a non-empty list of agent names"),
    ({"human_drift": True}, "human_drift (None or episodes) must be a whole number >= 1, "
                            "got True"),
    ({"human_rationality": True}, "human_rationality must be a number > 0 or inf"),
    ({"r0": "-0.3"}, "r0 must be None or a number in (-1, 0), got '-0.3'"),
    ({"human_passive": "0.1"}, "human_passive must be a probability in [0, 1], got '0.1'"),
    ({"learner": [["learning_rate", 1e999]]}, "learning_rate must be a finite number > 0"),
    ({"learner": [[1, 2]]}, "learner must be (name, value) pairs"),
    ({"probes": [{"label": "p"}]}, "probes must be a list of objects with the fields action, "),
    ({"probes": [{"label": "p", "kind": "human", "state": 99, "intention": 0, "action": 0,
                  "relative_to_wait": False}]}, "does not fit the hanger"),
])
def test_a_hand_edited_config_exits_2_naming_the_setting(changes, message, settings, tmp_path,
                                                         capsys):
    path = _config(tmp_path, settings, **changes)
    line = _exit_2(["study", "--config", str(path), "--out", str(tmp_path / "o")], capsys)
    assert line.startswith(f"hri-bench study: error: argument --config: {path}: ")
    assert message in line


def test_the_config_replays_when_nothing_is_wrong(settings, tmp_path):
    path = _config(tmp_path, settings)
    assert main(["study", "--config", str(path), "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 0


@pytest.mark.parametrize(("content", "message"), [
    (None, "not a regular file"),  # /dev/zero: refused before a byte is read
    ('{"settings": ' + "[" * 100_000 + "]" * 100_000 + "}", "its JSON nests deeper than 64"),
    ('{"settings": ' + "[" * 500 + "]" * 500 + "}", "its JSON nests deeper than 64"),
    ('{"settings": {}, "settings": {}}', "the key 'settings' appears twice"),
    ("[1, 2]", "no 'settings' object"),
    ('{"settings": [1]}', "no 'settings' object"),
    ("\x00\x01", "not JSON"),
])
def test_a_config_file_that_is_no_summary_exits_2(content, message, tmp_path, capsys):
    path = "/dev/zero"
    if content is not None:
        path = tmp_path / "summary.json"
        path.write_text(content)
    line = _exit_2(["study", "--config", str(path), "--out", str(tmp_path / "o")], capsys)
    assert message in line


def test_a_config_that_is_a_folder_exits_2(tmp_path, capsys):
    line = _exit_2(["study", "--config", str(tmp_path), "--out", str(tmp_path / "o")], capsys)
    assert "not a regular file (a FIFO, device or folder)" in line


# ----------------------------------------------------------------- humans and partners


class _HumanReturns(Human):
    def __init__(self, value):
        self.value = value

    def begin_episode(self, start, intention):
        pass

    def act(self, observation):
        return self.value

    def observe(self, state, robot_action, human_action, next_state):
        pass

    def end_episode(self):
        pass


@pytest.mark.parametrize("value", [0.5, True, "3"])
def test_a_human_that_returns_no_integer_is_refused_in_every_seat(value):
    env = gym.make("hri_envs/Hanger-v0", human=_HumanReturns(value))
    env.reset(seed=0)
    with pytest.raises(ActionError, match="act\\(\\) of the human in row 0 returned"):
        env.step(0)
    partner = PartnerEnv(hanger_v0.parallel_env(), partner=_HumanReturns(value))
    partner.reset(seed=0)
    with pytest.raises(ActionError, match="act\\(\\) of the human in row 0 returned"):
        partner.step(0)


def test_a_partner_policy_that_returns_no_integer_is_refused():
    partner = PartnerEnv(hanger_v0.parallel_env(), learner="human",
                         partner=lambda observation, rng: 0.5)
    partner.reset(seed=0)
    with pytest.raises(ActionError, match="robot action 0.5 is not an integer"):
        partner.step(0)


@pytest.mark.parametrize("env", [None, 5, "hanger", gym.make("hri_envs/Hanger-v0")])
def test_partner_env_names_an_env_that_is_not_the_two_agent_env(env):
    with pytest.raises(ConfigError, match="PartnerEnv wraps a two-agent env") as err:
        PartnerEnv(env)
    assert err.value.field == "env"


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
@pytest.mark.parametrize("make", ["robot", "parallel", "vector"])
def test_a_bad_reset_seed_is_the_projects_error_naming_the_seed(make, seed):
    from hri_envs import hanger_v0

    env = {"robot": lambda: gym.make("hri_envs/Hanger-v0").unwrapped,
           "parallel": hanger_v0.parallel_env,
           "vector": lambda: gym.make_vec("hri_envs/Hanger-v0", num_envs=2,
                                          vectorization_mode="vector_entry_point")}[make]()
    with pytest.raises(ConfigError, match="seed must be a whole number >= 0 or None") as err:
        env.reset(seed=seed)
    assert err.value.field == "seed"


@pytest.mark.parametrize("layout, text", [
    (((1.0, 2.0), (1.0, 2.0)), "the stands are 0 m apart"),
    (((0.0, 0.2), (1.6, 2.2)), "stand B is 0.2 m from the rack"),
    (((0.0, 2.2), (0.0, 9.0)), "stand C is 9 m from the rack"),
])
def test_a_wheel_layout_its_waypoints_do_not_fit_is_refused_naming_the_stand(layout, text):
    with pytest.raises(ConfigError, match=text) as err:
        gym.make("hri_envs/Wheel-v0").reset(seed=0, options={"layout": layout})
    assert err.value.field == "layout"
    gym.make("hri_envs/Wheel-v0").reset(seed=0, options={"layout": ((0.0, 2.2), (1.6, 2.2))})


@pytest.mark.parametrize("population", [False, True, 3, 1.5, b"train"])
def test_a_population_that_is_not_a_name_is_refused(population):
    """Hypothesis found population=False: a TypeError from deep inside the human's seat."""
    from hri_envs.envs import RobotEnv

    with pytest.raises(ConfigError, match="population must be a name") as exc:
        RobotEnv(population=population)
    assert exc.value.field == "population"
