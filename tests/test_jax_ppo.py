"""The recurrent PPO learner in JAX: a short training beats random, and it plays in studies."""

import json
import subprocess
import sys

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
