"""Human populations, Boltzmann and drifting humans, Learner variants and the CLI flags."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the envs)
from agents.config import default_config
from agents.learner import Learner
from hri_bench.cli import main
from hri_bench.run.runner import human_streams, make_schedule
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.errors import ConfigError
from hri_envs.humans.populations import (
    POPULATIONS,
    HumanDraw,
    human_sequence,
    population_spec,
)
from hri_envs.humans.rational import preference_q, rational_human
from hri_envs.humans.scripted import preference_human, preferences_for
from hri_envs.humans.splits import draw_human
from hri_envs.humans.tables import TableHumans
from hri_envs.task.scenarios import scenario_graph

SCENARIOS = ("hanger", "wheel")


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_preference_is_the_strict_argmax_of_its_own_q(scenario: str) -> None:
    """Q_pref ranks the scripted action first by at least 1 in every state, every preference."""
    g = scenario_graph(scenario)
    for pref in preferences_for(scenario):
        human = preference_human(g, pref)
        q = preference_q(human)
        best = np.sort(q, axis=-1)
        assert np.all(np.argmax(q, -1) == human._greedy)  # type: ignore[attr-defined]
        assert (best[..., -1] - best[..., -2]).min() >= 1.0


def test_large_beta_human_equals_the_scripted_human() -> None:
    g = scenario_graph("hanger")
    human = preference_human(g, "over-down-rotate/rotate-over-up")
    assert rational_human(human, math.inf) is human
    noisy = rational_human(human, 200.0)
    assert np.abs(noisy.policy - human.policy).max() < 1e-60
    rng = np.random.default_rng(0)
    states = rng.integers(0, g.n_states, 500)
    start, goal = rng.integers(0, 3, 500), rng.integers(0, 3, 500)
    u = rng.random((2, 500))
    np.testing.assert_array_equal(noisy.act_from_uniforms(states, start, goal, u[0], u[1]),
                                  human.act_from_uniforms(states, start, goal, u[0], u[1]))


def test_small_beta_human_deviates_and_stays_valid() -> None:
    g = scenario_graph("hanger")
    noisy = rational_human(preference_human(g), 1.0)
    assert not noisy.deterministic
    free = ~g.is_support_state
    # β = 1: the preferred action keeps the largest share but well below 1 in free space.
    top = noisy.policy.max(-1)[:, :, free]
    assert 0.2 < top.min() and top.max() < 0.9
    np.testing.assert_allclose(noisy.policy.sum(-1), 1.0)


@pytest.mark.parametrize("beta", [0.0, -1.0, float("nan"), "x"])
def test_bad_rationality_is_refused(beta: object) -> None:
    with pytest.raises(ConfigError, match="human_rationality must be a number > 0 or inf"):
        StudyConfig("hanger", human_rationality=beta)  # type: ignore[arg-type]


def test_unknown_population_lists_the_allowed_ones() -> None:
    with pytest.raises(ConfigError, match="allowed: hanger-all, preferences") as exc:
        StudyConfig("hanger", population="everyone")
    assert exc.value.field == "population"
    with pytest.raises(ConfigError, match="not for 'wheel'"):
        population_spec("hanger-all", "wheel")


def test_population_draws_depend_on_seed_and_run_only() -> None:
    spec = POPULATIONS["mixed-rationality"]
    a = [spec.draw(scenario_graph("hanger"), 5, r) for r in range(6)]
    b = [spec.draw(scenario_graph("hanger"), 5, r) for r in reversed(range(6))][::-1]
    assert a == b
    assert len({d.rationality for d in a}) == 6
    assert all(1.0 <= d.rationality <= 20.0 for d in a)
    assert draw_human(scenario_graph("hanger"), 5, 2, population="mixed-rationality") == a[2]


def test_hanger_all_covers_many_preferences_and_held_out_is_marked() -> None:
    spec = POPULATIONS["hanger-all"]
    prefs = {spec.draw(scenario_graph("hanger"), 0, r).preference for r in range(200)}
    assert len(prefs) >= 30 and prefs <= set(preferences_for("hanger"))
    assert [n for n, p in POPULATIONS.items() if p.held_out] == ["heldout"]


def test_drift_switches_exactly_at_episode_k() -> None:
    base = HumanDraw("straight")
    seq = human_sequence(scenario_graph("wheel"), base, seed=0, run=3, episodes=7, drift=4)
    assert seq[:4] == [base] * 4
    assert seq[4:] == [HumanDraw("detour")] * 3
    assert human_sequence(scenario_graph("wheel"), base, 0, 3, 4, drift=4) == [base] * 4


def test_drifting_human_acts_by_the_new_preference_after_k() -> None:
    """In the runner the human's actions follow the second preference from episode K on."""
    g = scenario_graph("wheel")
    straight, detour = preference_human(g, "straight"), preference_human(g, "detour")
    humans = TableHumans([[straight, straight, detour]])
    s = np.array([int(g.mounting_state[1])])
    picks = []
    for _ in range(4):
        humans.begin_episode(np.array([0]), np.array([2]))
        picks.append(int(humans.preferred_action(s, np.array([0]), np.array([2]))[0]))
    expect = [straight.preferred_action(s, 0, 2)[0]] * 2 + [detour.preferred_action(s, 0, 2)[0]] * 2
    assert picks == expect
    assert picks[1] != picks[2]


def test_per_run_humans_match_the_shared_human_when_identical() -> None:
    """The per-run path and the default path give the same actions for the same human."""
    g = scenario_graph("hanger")
    human = rational_human(preference_human(g, passive=0.2), 3.0)
    runs = [0, 1, 2, 3]
    shared, per_run = TableHumans(human, 4), TableHumans([[human]] * 4)
    shared.seed(human_streams(1, runs))
    per_run.seed(human_streams(1, runs))
    rng = np.random.default_rng(2)
    for _ in range(30):
        s = rng.integers(0, g.n_states, 4)
        start, goal = rng.integers(0, 3, 4), rng.integers(0, 3, 4)
        active = rng.random(4) < 0.8
        seen = {"state": s, "start": start, "intention": goal}
        np.testing.assert_array_equal(shared.act(seen, active), per_run.act(seen, active))


def test_per_run_turning_back_rates_drive_the_schedule() -> None:
    g = scenario_graph("hanger")
    never, always = preference_human(g), preference_human(g, turn_back=1.0)
    humans = TableHumans([[never], [always]])
    sched = make_schedule(g, "random", [0, 1], 6, 0, humans)
    assert not sched.turn_back[0].any() and sched.turn_back[1].all()


@pytest.mark.parametrize(("scenario", "kwargs", "learner", "maxent"), [
    ("hanger", {}, (-12.54, 198.0), (-40.28, 198.0)),
    ("wheel", {}, (-15.0, 204.0), (-34.0, 204.0)),
    ("hanger", {"human_passive": 0.2, "turn_back": 0.3}, (-42.55, 250.0), (-62.24, 239.0)),
    ("wheel", {"human_passive": 0.2, "turn_back": 0.3}, (-54.75, 274.0), (-179.75, 337.0)),
])
def test_default_study_numbers_are_those_before_populations(
        scenario: str, kwargs: dict[str, float], learner: tuple[float, float],
        maxent: tuple[float, float]) -> None:
    """Summed reward and steps of 6 runs x 5 episodes, recorded before the human could vary
    per run: the default path through the runner is unchanged.
    """
    res = run_study(StudyConfig(scenario, agents=("learner", "maxent"), runs=6, episodes=5,
                                **kwargs))  # type: ignore[arg-type]
    for agent, (reward, steps) in (("learner", learner), ("maxent", maxent)):
        m = res.metrics[agent]
        assert m["reward"].sum() == pytest.approx(reward, abs=1e-9)
        assert m["steps"].sum() == steps


def test_population_study_does_not_depend_on_batching(tmp_path) -> None:  # type: ignore[no-untyped-def]
    args = ["study", "hanger", "--runs", "6", "--episodes", "3", "--population", "heldout",
            "--human-drift", "2", "--agents", "learner,oracle", "--no-progress"]
    assert main([*args, "--out", str(tmp_path / "serial")]) == 0
    assert main([*args, "--jobs", "2", "--out", str(tmp_path / "jobs")]) == 0
    for name in ("episodes.csv", "summary.json"):  # no wall time in the summary: same bytes
        assert (tmp_path / "serial" / name).read_bytes() == (tmp_path / "jobs" / name).read_bytes()
    a = json.loads((tmp_path / "serial" / "summary.json").read_text())
    assert a["population"] == "heldout" and a["human_drift"] == 2


def test_oracle_follows_each_runs_own_human() -> None:
    """With deterministic per-run preferences the Oracle still cooperates perfectly."""
    res = run_study(StudyConfig("hanger", agents=("oracle",), runs=6, episodes=3,
                                population="hanger-all"))
    assert np.all(res.metrics["oracle"]["reward"] == 0.0)
    assert len(set(res.humans)) >= 4


def test_boltzmann_human_lowers_the_learners_reward() -> None:
    base = run_study(StudyConfig("hanger", agents=("learner",), runs=20, seed=1))
    noisy = run_study(StudyConfig("hanger", agents=("learner",), runs=20, seed=1,
                                  human_rationality=2.0))
    assert noisy.metrics["learner"]["reward"].mean() < base.metrics["learner"]["reward"].mean()


def test_env_kwargs_reach_the_human() -> None:
    env = gym.make("hri_envs/Hanger-v0", human_rationality=4.0)
    assert env.unwrapped.human.name.endswith("@4")  # type: ignore[attr-defined]
    env = gym.make("hri_envs/Hanger-v0", population="hanger-all")
    names = set()
    for seed in range(8):
        env.reset(seed=seed)
        names.add(env.unwrapped.human.name)  # type: ignore[attr-defined]
    assert len(names) > 3
    env.reset(seed=3)
    first = env.unwrapped.human.name  # type: ignore[attr-defined]
    env.reset(seed=3)
    assert env.unwrapped.human.name == first  # type: ignore[attr-defined]
    with pytest.raises(ConfigError, match="unknown population"):
        gym.make("hri_envs/Hanger-v0", population="nobody")
    with pytest.raises(ConfigError, match="human_rationality"):
        gym.make("hri_envs/Hanger-v0", human_rationality=-2.0)


def test_parallel_env_turn_back_rate() -> None:
    from hri_envs import hanger_v0

    env = hanger_v0.parallel_env(turn_back=1.0)
    env.reset(seed=0)
    assert env._episode.turn_back
    with pytest.raises(ConfigError, match="turn_back must be a probability"):
        hanger_v0.parallel_env(turn_back=1.5)


def test_learner_variants() -> None:
    g = scenario_graph("hanger")
    plain = Learner(g, 2, default_config("hanger"))
    no_prior = Learner(g, 2, default_config("hanger", passive_prior=False))
    other = Learner(g, 2, default_config("hanger",
                                         initial_preference="over-rotate-down/up-over-rotate"))
    np.testing.assert_array_equal(plain.theta, no_prior.theta)
    assert not np.allclose(other.theta, plain.theta)
    # Starting from the human's own preference beats starting from another one.
    pref = "over-rotate-down/up-over-rotate"

    def reward(initial: str) -> float:
        res = run_study(StudyConfig("hanger", agents=("learner",), runs=20, episodes=4,
                                    preference=pref, learner=(("initial_preference", initial),)))
        return float(res.metrics["learner"]["reward"].mean())

    assert reward(pref) > reward("down-over-rotate/over-rotate-up") + 0.1
    with pytest.raises(ConfigError, match="initial_preference must be None or one of"):
        default_config("hanger", initial_preference="sideways")


@pytest.mark.parametrize(("flag", "value", "message"), [
    ("--human-rationality", "0", "argument --human-rationality: expected a number > 0"),
    ("--population", "nobody", "argument --population: unknown population 'nobody'"),
    ("--learner-beta", "1.5", "argument --learner-beta: beta must be in (0, 1]"),
    ("--learner-eta", "2", "argument --learner-eta: eta must be in [0, 1]"),
    ("--human-drift", "0", "argument --human-drift: expected a whole number >= 1"),
])
def test_bad_flags_fail_before_simulating(flag: str, value: str, message: str, tmp_path,  # type: ignore[no-untyped-def]
                                          capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["study", "hanger", "--out", str(tmp_path / "x"), flag, value])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_learner_flags_are_recorded(tmp_path) -> None:  # type: ignore[no-untyped-def]
    main(["study", "hanger", "--runs", "2", "--episodes", "2", "--agents", "learner",
          "--learner-beta", "0.8", "--learner-no-passive-prior", "--no-progress",
          "--out", str(tmp_path)])
    learner = json.loads((tmp_path / "summary.json").read_text())["learner"]
    assert learner["beta"] == 0.8 and learner["passive_prior"] is False
    assert learner["r0"] == -0.33
