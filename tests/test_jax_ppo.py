"""The recurrent PPO learner in JAX: a short training beats random, and it plays in studies."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("optax")

from agents.jax_ppo import checkpoint  # noqa: E402
from agents.jax_ppo.agent import JaxPPOAgent  # noqa: E402
from agents.jax_ppo.train import TrainConfig, save, train  # noqa: E402
from hri_bench.cli import main  # noqa: E402
from hri_envs.envs.config import scenario_graph  # noqa: E402
from hri_envs.errors import ConfigError, LearnerStateError  # noqa: E402

# make test runs the JAX modules in one process: the training fixture and its compiled
# update are shared by the tests.

SMOKE = TrainConfig(scenario="hanger", total_steps=256 * 32 * 40, num_envs=256, rollout=32,
                    hidden=16, minibatches=2, lr=3e-3, chunk=20, seed=0)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    result = train(SMOKE)
    path = tmp_path_factory.mktemp("jaxppo") / "hanger.npz"
    save(str(path), result)
    return result, path


def test_training_improves_on_a_random_masked_policy(trained):
    """≈ 330 k steps (well under a minute): better than random valid actions, and better
    than it started."""
    from agents.jax_ppo.train import random_policy_return

    result, _ = trained
    curve = result.curve["episode_return"]
    random_level = random_policy_return(SMOKE, steps=200, n=512)
    last = float(np.mean(curve[-5:]))
    assert last > random_level + 1.0, (last, random_level)
    assert last > float(np.mean(curve[:3])) + 0.5, curve


def test_same_seed_same_weights(trained):
    """Training again with the same config (and seed) gives the same weights bit for bit
    (the compiled update is reused: no second compilation)."""
    again = train(SMOKE)
    for key, value in trained[0].params.items():
        np.testing.assert_array_equal(again.params[key], value)
    assert again.curve["episode_return"] == trained[0].curve["episode_return"]


def test_checkpoint_round_trip_without_pickle(trained, tmp_path):
    result, path = trained
    arrays, config = checkpoint.load(path)
    assert config["scenario"] == "hanger" and config["train"]["seed"] == 0
    for key, value in result.params.items():
        np.testing.assert_array_equal(arrays[key], value)
    with np.load(path, allow_pickle=False) as data:
        assert all(data[k].dtype != object for k in data.files)
    bad = tmp_path / "bad.npz"
    np.savez(bad, x=np.zeros(3))
    with pytest.raises(LearnerStateError):
        checkpoint.load(bad)


def test_agent_acts_validly_and_deterministically(trained):
    _, path = trained
    graph = scenario_graph("hanger")
    with pytest.raises(LearnerStateError):
        JaxPPOAgent(path, scenario_graph("wheel"), 2)
    with pytest.raises(ConfigError):
        JaxPPOAgent(path.parent / "missing.npz", graph, 2)
    from hri_bench.run.runner import make_schedule, simulate
    from hri_envs.humans.scripted import preference_human

    human = preference_human(graph)
    schedule = make_schedule(graph, "random", range(6), 4, seed=0)
    out = [simulate(graph, JaxPPOAgent(path.parent, graph, 6), human, schedule, runs=range(6),
                    seed=0, r0=-0.33).reward for _ in range(2)]
    np.testing.assert_array_equal(out[0], out[1])
    # valid in every state, from any start, whatever the human last did (the mask rules)
    agent = JaxPPOAgent(path.parent, graph, graph.n_states)
    rng = np.random.default_rng(0)
    states = np.arange(graph.n_states)
    for _ in range(5):
        agent.begin_episode(rng.integers(graph.n_intentions, size=graph.n_states))
        obs = {"state": states, "start": rng.integers(graph.n_intentions, size=states.size),
               "last_human_action": rng.integers(graph.n_actions, size=states.size),
               "action_mask": graph.valid.astype(np.int8)}
        action = agent.act(obs, np.ones(states.size, bool))
        assert graph.valid[states, action].all()


def test_jaxppo_in_a_study_and_bad_checkpoints_exit_2(trained, tmp_path, capsys):
    _, path = trained
    out = tmp_path / "study"
    # --jobs 2 from a process whose JAX runtime runs: forked workers could hang (spawned)
    code = main(["study", "hanger", "--agents", f"passive,jaxppo:{path.parent}", "--runs", "4",
                 "--episodes", "2", "--jobs", "2", "--out", str(out), "--no-progress"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert f"jaxppo:{path.parent}" in summary["agents"]
    for bad in (tmp_path / "nowhere", tmp_path / "study" / "summary.json"):
        with pytest.raises(SystemExit) as exc:
            main(["study", "hanger", "--agents", f"jaxppo:{bad}", "--runs", "2",
                  "--episodes", "1", "--out", str(tmp_path / "x"), "--no-progress"])
        assert exc.value.code == 2
        assert "--agents" in capsys.readouterr().err


def test_train_config_names_the_bad_field():
    with pytest.raises(ConfigError) as exc:
        TrainConfig(num_envs=100, minibatches=3).check()
    assert exc.value.field == "minibatches"
    with pytest.raises(ConfigError) as exc:
        train(TrainConfig(population="heldout", total_steps=10))
    assert exc.value.field == "population"


def test_agents_package_needs_jax_in_one_line():
    code = ("import sys; sys.modules['jax'] = None\n"
            "try:\n    import agents.jax_ppo.agent\nexcept ImportError as e:\n    print(e)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.strip()
    assert out.count("\n") == 0 and "[jax]" in out, out


NO_JAX = """
import sys
sys.modules['jax'] = sys.modules['optax'] = None
from hri_bench.cli import main
from hri_bench.report.jax_speed import measure_jax
out = sys.argv[1]
print('passive', main(['study', 'hanger', '--agents', 'passive', '--runs', '2',
                       '--episodes', '1', '--out', out + '/a', '--no-progress']))
print('jaxppo', main(['study', 'hanger', '--agents', 'passive,jaxppo', '--runs', '2',
                      '--episodes', '1', '--out', out + '/b', '--no-progress']))
print('speed', measure_jax('tiny'))
"""


def test_without_jax_the_cli_works_and_the_jax_parts_say_how_to_install(tmp_path):
    """jax blocked: a study runs; a 'jaxppo' agent fails in one line with the install
    command (exit 1, before simulating); the speed figures become that note."""
    run = subprocess.run([sys.executable, "-c", NO_JAX, str(tmp_path)], capture_output=True,
                         text=True, check=True)
    lines = dict(line.split(" ", 1) for line in run.stdout.strip().splitlines())
    assert lines["passive"] == "0" and lines["jaxppo"] == "1", run.stdout
    assert (tmp_path / "a" / "summary.json").exists() and not (tmp_path / "b").exists()
    err = [line for line in run.stderr.splitlines() if "jax" in line]
    assert len(err) == 1 and "[jax]" in err[0] and "pip install" in err[0], run.stderr
    assert "not installed" in lines["speed"] and "[jax]" in lines["speed"]


def test_speed_reports_the_jax_figures_naming_the_device(trained):
    from hri_bench.report.jax_speed import measure_jax

    # the smoke config's update is compiled already (the fixture): time it, not a new one
    figures = measure_jax("tiny", vector_env_steps_per_s=1e6, ppo=SMOKE)
    assert figures["jax_device"].startswith(jax.devices()[0].platform)
    for key in ("jax_env_steps_per_s", "jax_ppo_train_steps_per_s", "jax_env_vs_vector_env"):
        assert isinstance(figures[key], float) and figures[key] > 0, figures


# --------------------------------------------------------------------------- bad settings
@pytest.mark.parametrize(("changes", "field"), [
    ({"ent_coef": float("nan")}, "ent_coef"), ({"ent_coef": -0.01}, "ent_coef"),
    ({"vf_coef": -0.5}, "vf_coef"), ({"vf_coef": float("inf")}, "vf_coef"),
    ({"passive": (0.9, 0.1)}, "passive"), ({"passive": (0.1, 1.5)}, "passive"),
    ({"turn_back": (float("nan"), 0.2)}, "turn_back"), ({"turn_back": (0.1,)}, "turn_back"),
    ({"episodes_per_trial": 0}, "episodes_per_trial"), ({"r0": 0.5}, "r0"),
])
def test_train_config_refuses_values_that_train_nonsense(changes, field):
    """--ent-coef nan used to train NaN weights and exit 0; --passive 0.9 0.1 and
    --episodes-per-trial 0 (read as the default) were accepted."""
    with pytest.raises(ConfigError) as exc:
        TrainConfig(**changes).check()
    assert exc.value.field == field


@pytest.mark.parametrize(("argv", "flag"), [
    (["--ent-coef", "nan"], "--ent-coef"), (["--vf-coef", "-1"], "--vf-coef"),
    (["--passive", "0.9", "0.1"], "--passive"), (["--turn-back", "0", "2"], "--turn-back"),
    (["--episodes-per-trial", "0"], "--episodes-per-trial"), (["--lr", "inf"], "--lr"),
    (["--scenario", "kitchen"], "--scenario"),
])
def test_train_script_refuses_bad_flags_in_one_line_with_exit_2(argv, flag, tmp_path, capsys):
    from benchmarks.train_jax_ppo import run

    assert run([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"argument {flag}: " in err, err
    assert not (tmp_path / "out").exists()


def test_train_script_help_is_plain_text():
    """Its --help comes from TrainConfig's Attributes and main's Args (tyro): no Sphinx roles,
    no double backticks, and a description for every option."""
    import dataclasses
    import os

    import docstring_parser

    from benchmarks.train_jax_ppo import main as script_main

    run = subprocess.run([sys.executable, "benchmarks/train_jax_ppo.py", "--help"],
                         capture_output=True, text=True, check=True,
                         env={**os.environ, "COLUMNS": "200"})
    text = run.stdout
    for markup in (":mod:", ":class:", ":data:", ":func:", ":meth:", "``"):
        assert markup not in text, markup
    described = {p.arg_name: p.description
                 for obj in (TrainConfig, script_main)
                 for p in docstring_parser.parse_from_object(obj).params}
    names = [f.name for f in dataclasses.fields(TrainConfig)] + ["out", "overwrite_shipped"]
    for name in names:
        assert (described.get(name) or "").strip(), f"no help for {name}"
        assert f"--{name.replace('_', '-')}" in text, name
    assert "(default: out/jaxppo)" in text


# --------------------------------------------------------------------------- checkpoints
def test_a_checkpoint_with_non_finite_weights_is_refused(trained, tmp_path, capsys):
    """NaN weights used to play silently (-99.33 per episode): loading names the file and
    the array, a study exits 2; saving them is refused too."""
    result, path = trained
    arrays, config = checkpoint.load(path)
    arrays["pi_w"] = arrays["pi_w"] * np.nan
    with pytest.raises(LearnerStateError, match="pi_w holds NaN"):
        checkpoint.save(tmp_path / "x.npz", arrays, config)
    assert not (tmp_path / "x.npz").exists()
    bad = tmp_path / "nan" / "hanger.npz"
    bad.parent.mkdir()
    arrays[checkpoint.CONFIG_KEY] = np.frombuffer(
        json.dumps({**config}).encode(), dtype=np.uint8)
    np.savez(bad, **arrays)
    with pytest.raises(LearnerStateError, match=r"nan/hanger.npz'?: weight pi_w holds NaN"):
        checkpoint.load(bad)
    with pytest.raises(SystemExit) as exc:
        main(["study", "hanger", "--agents", f"jaxppo:{bad.parent}", "--runs", "2",
              "--episodes", "1", "--out", str(tmp_path / "study"), "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--agents" in err and "hanger.npz" in err and "NaN" in err, err


def test_a_checkpoint_whose_weights_do_not_fit_its_network_is_refused(trained, tmp_path):
    from agents.jax_ppo.agent import load_checked

    _, path = trained
    arrays, config = checkpoint.load(path)
    arrays["gru_wh"] = arrays["gru_wh"][:, :5]
    checkpoint.save(tmp_path / "hanger.npz", arrays, config)
    with pytest.raises(LearnerStateError, match="do not fit its network .*gru_wh"):
        load_checked(tmp_path, scenario_graph("hanger"))


def test_param_shapes_are_init_params_shapes():
    from agents.jax_ppo.network import NetConfig, init_params, param_shapes

    net = NetConfig(24, 3, 10, 16)
    made = init_params(jax.random.key(0), net)
    assert param_shapes(net) == {k: tuple(v.shape) for k, v in made.items()}


# --------------------------------------------------------------------------- outputs
def test_train_script_never_overwrites_the_shipped_checkpoints(tmp_path, capsys):
    """The documented --out agents/jax_ppo/checkpoints replaced the shipped checkpoint; now
    it needs --overwrite-shipped, and other package folders and docs/ are refused."""
    from benchmarks.train_jax_ppo import SHIPPED, check_out, run

    before = {p.name: p.read_bytes() for p in SHIPPED.glob("*.npz")}
    for out in (SHIPPED, Path("agents/jax_ppo/checkpoints"), SHIPPED / "sub"):
        assert run(["--out", str(out), "--total-steps", "1000"]) == 2
        err = capsys.readouterr().err
        assert "argument --out: " in err and ("--overwrite-shipped" in err or "inside" in err)
    for out in (Path("docs"), Path("hri_envs/jax"), Path("agents")):
        assert run(["--out", str(out)]) == 2
        assert "never writes into" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in SHIPPED.glob("*.npz")} == before
    assert check_out(SHIPPED, overwrite_shipped=True) is True  # allowed when asked for


def test_train_script_refuses_a_folder_it_did_not_write(tmp_path, capsys):
    from benchmarks.train_jax_ppo import run

    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert run(["--out", str(out)]) == 2
    assert "did not write (notes.txt)" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "keep me"
    (tmp_path / "file").write_text("x")
    assert run(["--out", str(tmp_path / "file")]) == 2
    capsys.readouterr()
    # Issue 43: a file on the path was a raw [Errno 20], after the whole training.
    for out in (tmp_path / "file" / "x", tmp_path / "file" / "x" / "y"):
        assert run(["--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err == (f"train_jax_ppo.py: error: argument --out: {out} cannot be created: "
                       f"{tmp_path / 'file'} is not a folder; give a folder for the checkpoint "
                       "and its curve\n")


def test_train_script_writes_its_folder_and_may_write_it_again(trained, tmp_path, capsys):
    """The smoke config again (compiled already): the three files and the list of them;
    the folder is then its own (a second scenario or a retraining may write there), until
    someone else's file lands in it."""
    from benchmarks.train_jax_ppo import MARKER, check_out, run

    out = tmp_path / "jaxppo"
    argv = ["--scenario", "hanger", "--total-steps", str(SMOKE.total_steps), "--num-envs",
            str(SMOKE.num_envs), "--rollout", str(SMOKE.rollout), "--hidden",
            str(SMOKE.hidden), "--minibatches", "2", "--lr", str(SMOKE.lr), "--chunk",
            str(SMOKE.chunk), "--seed", "0", "--out", str(out)]
    assert run(argv) == 0, capsys.readouterr().err
    files = {"hanger.npz", "hanger_curve.json", "hanger_curve.png"}
    assert {p.name for p in out.iterdir()} == files | {MARKER}
    assert set(json.loads((out / MARKER).read_text())["files"]) == files
    arrays, _ = checkpoint.load(out / "hanger.npz")
    for key, value in trained[0].params.items():  # same seed, same weights
        np.testing.assert_array_equal(arrays[key], value)
    assert check_out(out, overwrite_shipped=False) is False
    (out / "other.csv").write_text("x")
    with pytest.raises(ConfigError, match="did not write"):
        check_out(out, overwrite_shipped=False)
