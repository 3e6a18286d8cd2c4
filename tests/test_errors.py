"""One error root: every library exception derives from HriEnvsError, with helpful messages."""

import dataclasses
import subprocess
import sys

import pytest

import hri_envs
import hri_envs.envs
from agents import LearnerConfig, LearnerStateError
from hri_bench.cli import main
from hri_bench.run.study import StudyConfig
from hri_envs import errors
from hri_envs.errors import ConfigError, HriEnvsError
from hri_envs.humans.scripted import preference_human
from hri_envs.task import build_graph, hanger_scenario, wheel_scenario


@pytest.mark.parametrize("name", [n for n in errors.__all__
                                  if isinstance(getattr(errors, n), type)])
def test_every_public_exception_derives_from_the_root(name):
    cls = getattr(errors, name)
    assert issubclass(cls, HriEnvsError)
    assert cls.__doc__
    assert getattr(hri_envs, name) is cls  # exported from the package too


def test_compatibility_with_the_builtin_exceptions_and_old_names():
    assert issubclass(ConfigError, ValueError)
    assert issubclass(errors.ActionError, ValueError)
    assert issubclass(errors.BackendUnavailableError, ConfigError)
    assert issubclass(errors.BackendUnavailableError, NotImplementedError)
    assert issubclass(errors.PhysicsFault, RuntimeError)
    assert LearnerStateError is errors.LearnerStateError
    assert issubclass(LearnerStateError, ValueError)
    assert issubclass(errors.ResetNeeded, RuntimeError)
    assert issubclass(errors.MissingExtraError, ImportError)


def test_ik_failure_is_a_physics_fault():
    pytest.importorskip("mink")
    from hri_envs.physics import IKFailure

    assert issubclass(IKFailure, errors.PhysicsFault)
    assert issubclass(IKFailure, RuntimeError)
    assert IKFailure.__doc__


def test_the_lowest_layer_imports_in_a_fresh_interpreter():
    code = "import hri_envs.humans.scripted, hri_envs.errors; print('ok')"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "ok"


def test_scripted_human_with_a_bad_probability():
    human = preference_human(build_graph(hanger_scenario()))
    with pytest.raises(ConfigError, match=r"passive must be a probability in \[0, 1\]") as err:
        dataclasses.replace(human, passive=1.5)
    assert err.value.field == "passive"


def test_learner_config_with_a_bad_value():
    with pytest.raises(ConfigError, match=r"beta must be in \(0, 1\]") as err:
        LearnerConfig(beta=0.0)
    assert err.value.field == "beta"


def test_study_config_with_a_bad_value():
    with pytest.raises(ConfigError, match="human_passive must be a probability in") as err:
        StudyConfig("wheel", human_passive=2.0)
    assert err.value.field == "human_passive"
    with pytest.raises(ConfigError, match="'all' or one of straight, detour") as err:
        StudyConfig("wheel", preference="zigzag")
    assert err.value.field == "preference"


def test_geometry_with_bad_stands():
    with pytest.raises(ConfigError, match="stands must hold exactly two") as err:
        wheel_scenario(stands=((0.5, 0.5),))
    assert err.value.field == "stands"


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--human-passive", "2"], "argument --human-passive: expected a probability in [0, 1]"),
        (["--preference", "zigzag"], "argument --preference: preference must be 'all' or one"),
    ],
)
def test_cli_names_the_flag_and_what_is_allowed(args, fragment, capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["study", "hanger", *args, "--out", str(tmp_path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert fragment in err
    assert "hri-bench study: error:" in err
