"""The exact references informed and blind (baselines/bounds.py), regret against blind and
the reward rules (docs/task-model.md, "Reward")."""

import json

import numpy as np
import pytest

from baselines.bounds import Blind, Informed, plan
from hri_bench.cli import main
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from hri_envs.task.actions import TOGGLE, WAIT
from hri_envs.task.episode import step_reward, unneeded_toggle
from hri_envs.task.scenarios import scenario_graph

R0 = -0.25


def _values(graph, human, informed, reward="paper", max_steps=100):
    return plan(graph, human, r0=R0, max_steps=max_steps, informed=informed,
                reward=reward).start_value()


def test_deterministic_human_blind_waits_once_informed_never(wheel):
    # Hand-computed: the straight human reveals the goal with its first "move over"; a robot
    # that sees ι moves with it from the start (0), a blind one must wait that once (r0).
    human = preference_human(wheel, "straight")
    np.testing.assert_allclose(_values(wheel, human, True), 0.0, atol=1e-12)
    np.testing.assert_allclose(_values(wheel, human, False), R0, atol=1e-12)


def test_turning_back_costs_a_blind_robot_one_more_wait(wheel):
    # The blind robot cannot rule the turn out before the turning point, so it waits there
    # too (2 r0 whether or not the human turns); the informed robot sees ι change.
    human = preference_human(wheel, "straight", turn_back=0.5)
    np.testing.assert_allclose(_values(wheel, human, True), 0.0, atol=1e-12)
    np.testing.assert_allclose(_values(wheel, human, False), 2 * R0, atol=1e-12)


def test_passive_human_the_issue_figures(wheel):
    # The free grasp-and-release lets the informed robot avoid every wait (exactly 0); the
    # blind robot pays about two waits' worth (≈ -0.50).
    human = preference_human(wheel, "straight", passive=0.2)
    np.testing.assert_allclose(_values(wheel, human, True), 0.0, atol=1e-12)
    blind = _values(wheel, human, False)
    assert np.all((-0.51 < blind) & (blind < -0.49))


def test_free_toggle_rule_and_its_variant(wheel):
    # The wheel example of docs/task-model.md: "on B, held by the human" (5), robot grasp +
    # human let go pays 0; "on B, held by the robot" (6), robot let go + human wait pays 0.
    reward = wheel.reward(R0)
    assert wheel.state_names[5] == "on B, held by the human"
    assert reward[5, TOGGLE, TOGGLE] == 0.0 and reward[6, TOGGLE, WAIT] == 0.0
    a, b = wheel.support_names.index("A"), wheel.support_names.index("B")
    s6 = int(wheel.next_state[5, TOGGLE, TOGGLE])
    # After carrying A -> B (lifted), the grasp at the goal is unneeded, the let-go needed.
    assert unneeded_toggle(wheel, 5, TOGGLE, a, True)
    assert not unneeded_toggle(wheel, s6, TOGGLE, a, True)
    assert step_reward(wheel, 5, TOGGLE, TOGGLE, s6, R0, reward="no-free-toggle", start=a,
                       lifted=True) == R0
    assert step_reward(wheel, s6, TOGGLE, WAIT, int(wheel.next_state[s6, TOGGLE, WAIT]), R0,
                       reward="no-free-toggle", start=a, lifted=True) == 0.0
    # At the start B the same grasp is what the take-off needs: free under both rules.
    assert not unneeded_toggle(wheel, 5, TOGGLE, b, False)
    with pytest.raises(ConfigError, match="allowed: paper, no-free-toggle"):
        step_reward(wheel, 5, TOGGLE, TOGGLE, s6, R0, reward="free")


def test_no_free_toggle_changes_the_informed_optimum(wheel):
    human = preference_human(wheel, "straight", passive=0.2)
    paper = _values(wheel, human, True)
    strict = _values(wheel, human, True, reward="no-free-toggle")
    np.testing.assert_allclose(paper, 0.0, atol=1e-12)
    assert np.all(strict < -0.05)  # the robot now pays for the waits the toggle used to hide
    assert np.all(_values(wheel, human, False, reward="no-free-toggle") < strict)


def _simulate(graph, agent, human, runs=8, episodes=4, seed=3, **kw):
    schedule = make_schedule(graph, "random", range(runs), episodes, seed, human)
    return simulate(graph, agent, human, schedule, runs=range(runs), seed=seed, r0=R0, **kw)


def test_agents_follow_their_plans(wheel):
    human = preference_human(wheel, "straight")
    m = _simulate(wheel, Informed(wheel, human, 8, r0=R0), human)
    np.testing.assert_array_equal(m.reward, 0.0)
    m = _simulate(wheel, Blind(wheel, human, 8, r0=R0), human)
    np.testing.assert_allclose(m.reward, R0)  # deterministic: every episode exactly r0
    passive = preference_human(wheel, "straight", passive=0.2)
    m = _simulate(wheel, Informed(wheel, passive, 8, r0=R0), passive)
    np.testing.assert_array_equal(m.reward, 0.0)  # value 0 and rewards <= 0: always 0


@pytest.mark.parametrize(("scenario", "preference", "passive", "turn"), [
    ("wheel", "straight", 0.2, 0.0),
    ("wheel", "detour", 0.0, 0.5),
    ("hanger", None, 0.0, 0.5),
])
def test_informed_above_blind_above_intention_blind_agents(scenario, preference, passive, turn):
    cfg = StudyConfig(scenario, agents=("informed", "blind", "learner", "imitator", "passive"),
                      runs=12, episodes=5, preference=preference, human_passive=passive,
                      turn_back=turn, seed=1)
    result = run_study(cfg)
    graph = scenario_graph(scenario)
    human = preference_human(graph, preference, passive=passive, turn_back=turn)
    starts = result.schedule["start"]
    informed = plan(graph, human, r0=cfg.waiting_reward, informed=True).start_value()[starts]
    blind = plan(graph, human, r0=cfg.waiting_reward, informed=False).start_value()[starts]
    assert informed.mean() >= blind.mean()
    for name in ("learner", "imitator", "passive"):
        assert result.metrics[name]["reward"].mean() <= blind.mean() + 1e-9, name
    # The simulated references match their exact values (up to sampling noise).
    assert abs(result.metrics["informed"]["reward"].mean() - informed.mean()) < 0.05
    assert abs(result.metrics["blind"]["reward"].mean() - blind.mean()) < 0.08


def test_study_reports_regret_and_references(tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["study", "wheel", "--runs", "3", "--episodes", "2", "--agents",
                 "informed,blind,oracle", "--out", str(out), "--no-progress",
                 "--reward", "no-free-toggle"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reward_rule"] == "no-free-toggle"
    assert set(summary["references"]) == {"informed", "blind", "oracle"}
    # Deterministic human: blind gets exactly its expectation, informed r0 better per episode.
    np.testing.assert_allclose(summary["agents"]["blind"]["regret"]["mean"], 0.0, atol=1e-12)
    np.testing.assert_allclose(summary["agents"]["informed"]["regret"]["mean"], R0, atol=1e-12)
    printed = capsys.readouterr().out
    assert "regret" in printed and "information bound" in printed


def test_bad_inputs(wheel):
    human = preference_human(wheel, "straight", passive=0.2)
    with pytest.raises(ConfigError, match="allowed: paper, no-free-toggle"):
        plan(wheel, human, r0=R0, informed=True, reward="nope")
    with pytest.raises(ConfigError, match="more than 50 belief nodes"):
        plan(wheel, human, r0=R0, informed=False, max_nodes=50)
    with pytest.raises(ConfigError, match="reward must be one of paper, no-free-toggle"):
        StudyConfig("wheel", reward="free")


def test_envs_take_the_reward_variant():
    import gymnasium as gym

    from hri_envs import wheel_v0
    from hri_envs.envs.vector import RobotVectorEnv

    a, b = 0, 1  # A -> B; at "on B, held by the human" the robot grasps while the human lets go
    for rule, expected in (("paper", 0.0), ("no-free-toggle", R0)):
        par = wheel_v0.parallel_env(reward=rule)
        par.reset(seed=0, options={"start": "A", "intention": "B"})
        par.unwrapped._episode.state = 5
        par.unwrapped._episode.lifted = True
        _, rewards, *_ = par.step({"robot": TOGGLE, "human": TOGGLE})
        assert rewards["robot"] == expected, rule
        env = gym.make("hri_envs/Wheel-v0", reward=rule).unwrapped
        env.reset(seed=0, options={"start": a, "intention": b})
        env._episode.state, env._episode.lifted = 5, True
        env.human = preference_human(env.graph, "straight")  # lets go when arrived
        _, reward, *_ = env.step(TOGGLE)
        assert reward == expected, rule
        vec = RobotVectorEnv(2, "wheel", reward=rule)
        vec.reset(seed=0, options={"start": a, "intention": b})
        vec._state[:], vec._key[:] = 5, vec._table.key(5, vec._start, True)  # held, lifted
        _, reward_v, *_ = vec.step(np.array([TOGGLE, TOGGLE]))
        np.testing.assert_array_equal(reward_v, expected)
    with pytest.raises(ConfigError, match="allowed: paper, no-free-toggle"):
        wheel_v0.parallel_env(reward="free")


def test_planners_are_refused_before_simulating_when_runs_have_their_own_humans(tmp_path):
    from hri_bench.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["study", "hanger", "--agents", "learner,blind", "--population", "theta",
              "--runs", "2", "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    assert not (tmp_path / "out" / "summary.json").exists()
