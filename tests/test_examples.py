"""Every script in examples/ runs, as a user would start it, with small arguments."""

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
HAS_RAY = importlib.util.find_spec("ray") is not None


def run(script, *args, cwd):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
    proc = subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    return proc.stdout


def test_every_example_is_covered():
    scripts = {p.name for p in EXAMPLES.glob("*.py") if p.name != "__init__.py"}
    assert scripts == {"train_maskable_ppo.py", "rllib_multiagent.py", "custom_learner.py",
                       "play_with_robot.py", "physics_table2.py",
                       "train_sac_continuous.py"}


def test_train_maskable_ppo(tmp_path):
    out = run("train_maskable_ppo.py", "--timesteps", "2048", "--runs", "4", "--episodes", "2",
              "--out", str(tmp_path / "ppo"), cwd=tmp_path)
    assert "trained MaskablePPO" in out and "steps/s" in out
    assert (tmp_path / "ppo" / "ppo_hanger.zip").is_file()
    assert "sb3:" in out and "learner" in out


def test_train_masked_dqn_on_the_wheel(tmp_path):
    out = run("train_maskable_ppo.py", "--algo", "dqn", "--scenario", "wheel", "--timesteps",
              "600", "--vec", "dummy", "--runs", "3", "--episodes", "2", "--out",
              str(tmp_path / "dqn"), cwd=tmp_path)
    assert "trained MaskedDQN" in out
    assert (tmp_path / "dqn" / "dqn_wheel.zip").is_file()


def test_custom_learner(tmp_path):
    out = run("custom_learner.py", "--runs", "3", "--episodes", "3", cwd=tmp_path)
    assert "custom_learner:GoalMemory" in out and "learner" in out


def test_play_with_robot_auto(tmp_path):
    out = run("play_with_robot.py", "--auto", "--episodes", "2", "--quiet", cwd=tmp_path)
    assert "robot reward per episode:" in out
    rewards = [float(r) for r in out.strip().splitlines()[-1].split(":")[1].split()]
    assert len(rewards) == 2 and all(-3 < r <= 0 for r in rewards)


def test_physics_table2(tmp_path):
    out = run("physics_table2.py", "--runs", "1", "--episodes", "1", "--agents", "passive",
              "--out", str(tmp_path / "t2"), cwd=tmp_path)
    assert "passive" in out and "graph agrees 1.000" in out
    assert (tmp_path / "t2" / "summary.json").is_file()


def test_train_sac_continuous(tmp_path):
    pytest.importorskip("mujoco")
    pytest.importorskip("stable_baselines3")
    out = run("train_sac_continuous.py", "--steps", "200", "--eval-every", "100",
              "--eval-episodes", "1", "--final-episodes", "3", "--max-time-s", "1.0",
              "--out", str(tmp_path / "sac"), cwd=tmp_path)
    assert "SAC - passive return" in out
    assert (tmp_path / "sac" / "learning_curve.png").is_file()
    summary = (tmp_path / "sac" / "summary.json").read_text()
    assert '"sac_minus_passive_return"' in summary and '"curve"' in summary


@pytest.mark.slow  # tests/test_rl.py builds and trains the same example in-process
@pytest.mark.skipif(not HAS_RAY, reason="Ray RLlib is not installed (see pyproject's 'ray' extra)")
def test_rllib_multiagent(tmp_path):
    out = run("rllib_multiagent.py", "--iterations", "1", "--batch-size", "100",
              "--minibatch-size", "50", "--epochs", "1", cwd=tmp_path)
    assert "iteration 1: robot return" in out
