"""Clear errors everywhere: every misuse raises the library's error class with a message
that names the culprit and says what is allowed.
"""

import json

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from agents import Learner, LearnerStateError
from hri_envs import wheel_v0
from hri_envs.errors import ActionError, ConfigError
from hri_envs.task.scenarios import scenario_graph


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    graph = scenario_graph("hanger")
    learner = Learner(graph, 2, seed=1)
    path = tmp_path_factory.mktemp("learner") / "state"  # no .npz: must round-trip as given
    learner.save(path)
    return graph, learner, path


def test_save_and_load_use_the_same_path(saved):
    graph, learner, path = saved
    assert path.is_file() and not path.with_suffix(".npz").exists()
    loaded = Learner.load(path, graph)
    np.testing.assert_array_equal(loaded.q_r, learner.q_r)


def test_every_truncation_and_byte_flip_is_a_learner_state_error(saved, tmp_path):
    graph, learner, path = saved
    data = path.read_bytes()
    cases = [data[:n] for n in range(0, len(data), len(data) // 97)]
    rng = np.random.default_rng(0)
    for _ in range(150):
        flipped = bytearray(data)
        flipped[rng.integers(len(data))] ^= int(rng.integers(1, 256))
        cases.append(bytes(flipped))
    bad = tmp_path / "bad"
    errors = 0
    for case in cases:
        bad.write_bytes(case)
        try:
            loaded = Learner.load(bad, graph)
        except LearnerStateError:
            errors += 1
            continue
        # A flip outside the checksummed data (zip timestamps, say) changes nothing.
        for key in ("theta", "pi_h", "q_r", "pi_r"):
            np.testing.assert_array_equal(getattr(loaded, key), getattr(learner, key))
    assert errors > 0.9 * len(cases)


def _rewrite(path, out, *, drop=None, meta_change=None):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files if k != drop}
    if meta_change is not None:
        meta = json.loads(str(arrays["meta"]))
        meta_change(meta)
        arrays["meta"] = np.array(json.dumps(meta))
    with open(out, "wb") as f:
        np.savez(f, **arrays)
    return out


@pytest.mark.parametrize("drop", ["meta", "theta", "pi_r"])
def test_missing_entries_are_named(saved, tmp_path, drop):
    graph, _, path = saved
    bad = _rewrite(path, tmp_path / "bad", drop=drop)
    with pytest.raises(LearnerStateError, match=f"missing entries {drop}"):
        Learner.load(bad, graph)


@pytest.mark.parametrize(("change", "fragment"), [
    (lambda m: m.update(episodes=-3), "episode count -3"),
    (lambda m: m.update(episodes="7"), "episode count '7'"),
    (lambda m: m.pop("config"), "invalid learner parameters"),
    (lambda m: m["config"].update(eta=7.0), "invalid learner parameters"),
])
def test_bad_counts_and_parameters(saved, tmp_path, change, fragment):
    graph, _, path = saved
    bad = _rewrite(path, tmp_path / "bad", meta_change=change)
    with pytest.raises(LearnerStateError, match=fragment):
        Learner.load(bad, graph)


def test_env_steps_reject_bool_actions_and_unknown_agents():
    env = gym.make("hri_envs/Wheel-v0")
    env.reset(seed=0)
    with pytest.raises(ActionError, match="robot action True is a bool.*Discrete"):
        env.step(True)
    par = wheel_v0.parallel_env()
    par.reset(seed=0)
    with pytest.raises(ActionError, match="human action False is a bool"):
        par.step({"human": False, "robot": 0})
    with pytest.raises(ActionError, match=r"unknown agent\(s\) bob.*\['human', 'robot'\]"):
        par.step({"human": 0, "robot": 0, "bob": 1})


@pytest.mark.parametrize(("options", "fragment"), [
    ({"start": np.array([0, 1])}, r"'start' must be one support or 4 of them .*shape \(2,\)"),
    ({"intention": [[0, 1, 2, 0]]}, r"'intention' must be one support or 4 .*shape \(1, 4\)"),
    ({"turn_back": np.array([True, False, True])}, r"'turn_back' must be a bool or 4 bools"),
    ({"turn_back": np.array([1, 0, 1, 0])}, r"'turn_back' .*got int64 of shape \(4,\)"),
])
def test_vector_reset_options_of_the_wrong_shape_or_type_are_named(options, fragment):
    vec = gym.make_vec("hri_envs/Hanger-v0", num_envs=4, vectorization_mode="vector_entry_point")
    with pytest.raises(ConfigError, match=fragment) as exc:
        vec.reset(seed=0, options=options)
    assert exc.value.field == next(iter(options))


@pytest.mark.parametrize("options", [{"start": ["A"]}, {"turn_back": np.array([1, 0])}])
def test_reset_options_of_the_wrong_type_are_named(options):
    key = next(iter(options))
    with pytest.raises(ConfigError, match=f"reset option '{key}'"):
        gym.make("hri_envs/Wheel-v0").reset(seed=0, options=options)


def test_play_ends_cleanly_at_end_of_input(monkeypatch, capsys):
    import io

    from hri_bench.cli import main

    monkeypatch.setattr("sys.stdin", io.StringIO("0\n0\n"))  # two answers, then EOF
    assert main(["play", "wheel", "--episodes", "2"]) == 0
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "missing", "extra"), [
    (["study", "wheel", "--runs", "1"], "matplotlib", "bench"),
    (["study", "wheel", "--runs", "1", "--executor", "ray"], "ray", "ray"),
    (["figures", "--runs", "1"], "tqdm", "bench"),
])
def test_missing_extras_give_one_line_with_the_install_command(argv, missing, extra,
                                                               monkeypatch, tmp_path, capsys):
    from hri_bench.cli import main
    from hri_envs import errors

    monkeypatch.setattr(errors, "_installed", lambda m: m != missing)
    out = tmp_path / "out"
    assert main([*argv, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f".venv/bin/pip install -c constraints.txt -e '.[{extra}]'" in err
    assert not out.exists()  # nothing was simulated or written


def test_a_missing_package_met_later_is_one_line_too(monkeypatch, capsys):
    from hri_bench.cli import commands as cli

    def fail(*args, **kwargs):
        raise ModuleNotFoundError("No module named 'torch'", name="torch")

    monkeypatch.setattr(cli, "_speed", fail)
    assert cli.main(["speed"]) == 1
    assert capsys.readouterr().err == ("hri-bench: hri-bench speed needs torch: .venv/bin/pip "
                                       "install -c constraints.txt -e '.[rl]' (in the "
                                       "hri-envs checkout)\n")
