"""hri-bench: the study CLI contract (docs/benchmark.md), figures, play and the speed command."""

import csv
import importlib.util
import json

import numpy as np
import pytest

from agents.learning import partner_mdp
from hri_bench.cli import main
from hri_bench.people.play import play
from hri_bench.report.figures import make_figures
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.envs.config import scenario_graph
from hri_envs.errors import ConfigError

SUMMARY_KEYS = {"scenario", "backend", "schedule", "preference", "r0", "human_passive",
                "turn_back", "max_steps", "runs", "episodes", "seed", "version", "env_ids",
                "settings", "agent_configs", "failed_agents", "agents", "human_rationality",
                "population", "human_drift", "learner", "probability_of_improvement",
                "reward_rule", "regret", "references", "physics_preset", "human_params",
                "population_info", "reference"}


def test_study_writes_the_contracted_files(tmp_path, capsys):
    out = tmp_path / "wheel"
    code = main(["study", "wheel", "--runs", "4", "--episodes", "3", "--out", str(out),
                 "--agents", "learner,imitator,oracle", "--no-progress", "--seed", "7"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary) == SUMMARY_KEYS
    assert summary["scenario"] == "wheel" and summary["r0"] == -0.25 and summary["seed"] == 7
    assert set(summary["agents"]) == {"learner", "imitator", "oracle"}
    for stats in summary["agents"].values():
        assert set(stats) == {"reward", "regret", "correct", "passive", "wrong", "truncated",
                              "overall"}
        assert set(stats["reward"]) == {"mean", "median", "q25", "q75", "iqm", "ci95",
                                        "iqm_ci95", "overall"}
        for key, metric in stats.items():
            if key == "overall":  # totals over all episodes
                continue
            for name, values in metric.items():
                # overall: mean, iqm, the mean's CI and, for the reward, the IQM's CI
                overall = 4 if key == "reward" else 3
                assert len(values) == (overall if name == "overall" else 3)
        fractions = [stats[k]["mean"] for k in ("correct", "passive", "wrong")]
        np.testing.assert_allclose(np.sum(fractions, axis=0), 1.0)
    assert summary["agents"]["oracle"]["reward"]["mean"] == [0.0, 0.0, 0.0]
    # Deterministic straight human: blind expects exactly r0 per episode, the Oracle gets 0.
    assert summary["agents"]["oracle"]["regret"]["mean"] == [-0.25, -0.25, -0.25]
    assert summary["reward_rule"] == "paper" and set(summary["references"]) == {"oracle"}
    with (out / "episodes.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 * 4 * 3  # agents x runs x episodes
    assert {"agent", "run", "episode", "reward", "correct", "passive", "wrong"} <= set(rows[0])
    for png in ("reward.png", "decisions.png"):
        data = (out / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5_000
    assert "wrote" in capsys.readouterr().out


def test_a_study_of_many_agents_writes_its_plots(tmp_path):
    # Each agent's decision bars are paler than the last; six agents once asked matplotlib
    # for a negative alpha and the study wrote nothing.
    out = tmp_path / "six"
    agents = "learner,imitator,oracle,passive,blind,informed"
    code = main(["study", "hanger", "--runs", "2", "--episodes", "2", "--out", str(out),
                 "--agents", agents, "--no-progress"])
    assert code == 0
    assert (out / "decisions.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_same_seed_same_numbers_whatever_the_executor():
    base = {"agents": ("learner", "maxent", "imitator"), "runs": 6, "episodes": 3, "seed": 3}
    serial = run_study(StudyConfig("hanger", **base))
    pooled = run_study(StudyConfig("hanger", **base, jobs=2, executor="process"))
    for agent, metrics in serial.metrics.items():
        for key, values in metrics.items():
            np.testing.assert_array_equal(values, pooled.metrics[agent][key], err_msg=key)
    other_seed = run_study(StudyConfig("hanger", **{**base, "seed": 4}))
    assert not np.array_equal(other_seed.metrics["learner"]["reward"],
                              serial.metrics["learner"]["reward"])


def test_table2_schedule_and_turning_back():
    res = run_study(StudyConfig("hanger", agents=("imitator", "learner"), runs=3,
                                schedule="table2", preference="all"))
    assert res.config.n_episodes == 9
    assert res.schedule["turn_back"][:, 7].all() and not res.schedule["turn_back"][:, :7].any()
    # Episode 8 (A -> (B) A): the Imitator has no notion of intention and keeps pushing to B.
    wrong = {a: res.metrics[a]["wrong"][:, 7].mean() for a in ("imitator", "learner")}
    assert wrong["imitator"] > wrong["learner"]
    assert not res.metrics["learner"]["truncated"].any()


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["study", "kitchen", "--out", "x"], "invalid choice: 'kitchen'"),
        (["study", "wheel", "--out", "x", "--r0", "0.5"], "--r0"),
        (["study", "wheel", "--out", "x", "--runs", "0"], "--runs"),
        (["study", "wheel", "--out", "x", "--agents", "robot9000"], "allowed: learner"),
        (["study", "wheel", "--out", "x", "--schedule", "table2"], "table2"),
        (["study", "wheel", "--out", "x", "--preference", "zigzag"], "--preference"),
        (["study", "wheel", "--out", "x", "--human-passive", "2"], "--human-passive"),
        (["study", "wheel", "--out", "x", "--executor", "slurm"], "choose from"),
        (["study", "wheel", "--out", "x", "--backend", "bullet"], "choose from"),
        (["study", "wheel"], "--out"),
        (["study", "wheel", "--out", "x", "--physics-preset", "weak-human"],
         "argument --physics-preset: backend='graph' takes no physics options"),
        (["study", "wheel", "--out", "x", "--backend", "mujoco", "--physics-preset", "strong"],
         "unknown physics preset 'strong'; allowed: weak-human, noisy-sensor"),
        (["figures", "--out", "x", "--only", "fig99"], "fig99"),
    ],
)
def test_bad_arguments_exit_2_naming_the_argument(args, fragment, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == 2
    assert fragment in capsys.readouterr().err


def test_study_on_the_physics_backend(tmp_path):
    out = tmp_path / "panda"
    code = main(["study", "hanger", "--backend", "mujoco", "--runs", "1", "--episodes", "1",
                 "--agents", "passive", "--out", str(out), "--no-progress"])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["backend"] == "mujoco"
    passive = summary["agents"]["passive"]
    assert passive["linear_impulse"]["mean"][0] > 0.0
    assert passive["graph_agrees"]["mean"][0] == 1.0
    assert passive["inference_accuracy"]["mean"][0] > 0.0
    assert passive["physical_fault"]["mean"][0] == 0.0
    assert summary["physics_preset"] is None
    assert (out / "impulse.png").stat().st_size > 5_000
    with (out / "episodes.csv").open() as f:
        assert "linear_impulse" in next(csv.reader(f))


def test_a_physics_preset_reaches_the_simulator():
    from hri_envs.envs.backends import batch_backend
    from hri_envs.physics.scene.design import hanger_design

    cfg = StudyConfig("hanger", backend="mujoco", physics_preset="noisy-sensor", runs=1)
    batch = batch_backend("mujoco")(scenario_graph("hanger"), [0], 0, physics=cfg.physics)
    noisy = hanger_design().presets["noisy-sensor"]
    assert batch.sim.params.sensor_noise_n == noisy["sensor_noise_n"]


def test_user_agent_by_module_path(tmp_path):
    res = run_study(StudyConfig("wheel", agents=("tests.helpers_agents:AlwaysWait",), runs=2,
                                episodes=2))
    name = "tests.helpers_agents:AlwaysWait"
    assert np.all(res.metrics[name]["passive"] == 1.0)


def test_figures_subset_are_written(tmp_path):
    paths = make_figures(tmp_path, runs=3, only=("fig4", "fig8"), log=lambda _: None)
    assert sorted(p.name for p in paths) == ["fig4.png", "fig8.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_play_in_the_terminal_with_scripted_answers():
    answers = iter(["x", "99", "0"] + ["2"] * 200)  # junk first, then always the second choice
    lines: list[str] = []
    totals = play(scenario_graph("wheel"), episodes=1, read=lambda _: next(answers),
                  write=lines.append, max_steps=6)
    assert len(totals) == 1
    text = "\n".join(lines)
    assert "Robot belief" in text and "robot chooses" in text and "Type a number" in text
    # numbered from 1, as the page of `hri-bench serve` numbers its keys; 0 is refused
    assert "  [1] " in text and "  [0] " not in text
    assert text.count("Type a number from 1 to") == 3  # "x", "99" and "0"


def test_the_play_robot_takes_hold_once_and_waits_while_you_wait():
    """Issue 43: a person who waited on the start support saw the robot grasp, let go, grasp,
    ... until the step limit (the paper's reward makes toggles free, and a wait on the start
    reads as "the goal is here"). Now it grasps once and holds still while they wait; when
    they grasp too, the carry goes on."""
    for scenario in ("hanger", "wheel"):
        answers = iter(["1"] * 12 + ["q"])
        lines: list[str] = []
        play(scenario_graph(scenario), episodes=1, read=lambda _, a=answers: next(a),
             write=lines.append, max_steps=40)
        chosen = [line.split("robot chooses: ")[1] for line in lines if "robot chooses: " in line]
        assert len(chosen) == 13, lines  # the 13th step is shown, then q
        assert chosen.count("grasp") == 1 and "let go" not in chosen, (scenario, chosen)
        assert set(chosen[1:]) == {"wait"}, (scenario, chosen)


SPEED_KEYS = {"parallel_env_steps_per_s", "vector_env_steps_per_s", "learner_update_ms",
              "learner_update_batched_ms_per_run", "hanger_study_s", "machine_ms",
              "learner_threads"}


def _positive_finite(value):
    return isinstance(value, float) and bool(np.isfinite(value)) and value > 0


def test_speed_json_runs_the_real_measurements_on_a_tiny_size(monkeypatch, capsys):
    """``hri-bench speed --json --size tiny`` end to end: every figure measured for real."""
    import hri_bench.report.speed as speed

    studies = []
    real_study = speed.run_study
    monkeypatch.setattr(speed, "run_study", lambda cfg: studies.append(cfg) or real_study(cfg))

    assert main(["speed", "--json", "--jobs", "1", "--size", "tiny", "--no-jax"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    figures = json.loads(lines[-1])
    assert set(figures) == SPEED_KEYS
    threads = figures.pop("learner_threads")
    assert threads == partner_mdp.threads() and type(threads) is int and threads >= 1
    assert all(_positive_finite(v) for v in figures.values()), figures
    for key in SPEED_KEYS:  # one readable line per figure before the JSON
        assert sum(line.split()[0] == key for line in lines[:-1]) == 1
    # The hanger study: the nine study preferences, Learner only, at the tiny size.
    assert [c.preference for c in studies] == list(speed.HANGER_STUDY_PREFERENCES)
    assert len(set(speed.HANGER_STUDY_PREFERENCES)) == 9
    tiny = speed.SIZES["tiny"]
    assert all(c.scenario == "hanger" and c.agents == ("learner",) and c.runs == tiny.study_runs
               and c.n_episodes == tiny.study_episodes and c.executor == "serial"
               for c in studies)


def test_speed_sizes_are_checked_and_the_full_size_is_the_published_one():
    import hri_bench.report.speed as speed

    full = speed.SIZES["full"]
    assert (full.vector_envs, full.batch_runs, full.study_runs, full.study_episodes) == (
        1024, 100, 100, 8)
    with pytest.raises(ConfigError, match="size must be one of") as exc:
        speed.measure(size="huge")
    assert exc.value.field == "size"
    with pytest.raises(ConfigError, match="scenario must be 'wheel'"):
        speed.learner_update_ms("hanger", repeats=1)


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_env_speed_measurements_step_the_envs_with_valid_actions(scenario, monkeypatch):
    from hri_envs.envs import speed as env_speed
    from hri_envs.envs.parallel import CooperationParallelEnv
    from hri_envs.envs.vector import RobotVectorEnv

    seen = {"parallel": 0, "vector": 0, "invalid": 0, "ended": 0}

    def counting(cls, key):
        real = cls.step

        def step(self, actions):
            out = real(self, actions)
            seen[key] += 1
            infos = out[-1]
            if key == "parallel":
                seen["invalid"] += sum(infos[a]["invalid_action"] for a in ("human", "robot"))
                seen["ended"] += out[2]["robot"] or out[3]["robot"]
            else:
                seen["invalid"] += int(infos["invalid_action"].sum())
            return out

        monkeypatch.setattr(cls, "step", step)

    counting(CooperationParallelEnv, "parallel")
    counting(RobotVectorEnv, "vector")
    par = env_speed.parallel_env_steps_per_s(scenario, steps=300, repeats=2)
    vec = env_speed.vector_env_steps_per_s(num_envs=3, scenario=scenario, steps=40, repeats=2)
    assert par.steps == 300 and vec.steps == 3 * 40
    assert seen["parallel"] == 2 * 300 and seen["vector"] == 2 * 40  # every repeat ran in full
    assert seen["invalid"] == 0  # the precomputed action tables hold valid actions only
    assert seen["ended"] > 0  # episodes end and the env resets within the measurement
    for res in (par, vec):
        assert _positive_finite(res.steps_per_s) and _positive_finite(res.seconds)
        assert res.steps_per_s == pytest.approx(res.steps / res.seconds)


def test_learner_update_ms_is_the_mean_time_of_real_updates(monkeypatch):
    """The timing arithmetic on a fake clock: each real Learner update "takes" 2.5 ms."""
    from types import SimpleNamespace

    import hri_bench.report.speed as speed
    from agents.learner import Learner
    from hri_bench.run.study import graph_for

    clock, updates = [0.0], []
    real_update = Learner.end_episode

    def update(self, traces, intentions):
        updates.append((traces, np.asarray(intentions)))
        real_update(self, traces, intentions)
        clock[0] += 2.5e-3

    monkeypatch.setattr(Learner, "end_episode", update)
    monkeypatch.setattr(speed, "time", SimpleNamespace(perf_counter=lambda: clock[0]))
    assert speed.learner_update_ms("wheel", repeats=4) == pytest.approx(2.5)
    assert len(updates) == 1 + 4  # one warm-up, not timed, then the timed repeats
    g = graph_for("wheel")
    for traces, intentions in updates:
        (trace,) = traces
        s = trace.states
        # A real episode of the graph: from resting on A to resting on B (the intention).
        assert intentions.tolist() == [1]
        assert s[0] == g.support_state(0, 0) and s[-1] == g.support_state(1, 0)
        assert all(np.any(g.next_state[a] == b) for a, b in zip(s[:-1], s[1:], strict=True))


@pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                    reason="Ray is not installed (pyproject's 'ray' extra)")
def test_ray_executor_gives_the_same_numbers():
    import ray

    base = {"agents": ("learner", "imitator"), "runs": 4, "episodes": 2, "seed": 5}
    serial = run_study(StudyConfig("wheel", **base))
    try:
        on_ray = run_study(StudyConfig("wheel", **base, jobs=2, executor="ray"))
    finally:
        ray.shutdown()
    for agent, metrics in serial.metrics.items():
        for key, values in metrics.items():
            np.testing.assert_array_equal(values, on_ray.metrics[agent][key], err_msg=key)


class _FailsOnSecondStep:
    """A graph backend whose run 0 fails physically on its second step of every episode."""

    def __new__(cls, graph, runs, seed, physics=None):
        from hri_envs.envs.backends import BatchStep, GraphBatch

        class Failing(GraphBatch):
            def begin(self, rows, start):
                self.t = 0
                return super().begin(rows, start)

            def transition(self, state, a_r, a_h, active):
                step = super().transition(state, a_r, a_h, active)
                self.t += 1
                fail = np.zeros(len(state), dtype=bool)
                fail[0] = self.t == 2
                return BatchStep(step.next_state, step.human_seen, fail, {}, fail)

        return Failing(graph, runs, seed, physics)


def test_a_physical_failure_costs_r_minus_and_the_other_runs_go_on(request):
    from hri_bench.run.agents import make_agent
    from hri_bench.run.runner import make_schedule, simulate
    from hri_envs.envs import backends
    from hri_envs.humans.scripted import preference_human

    backends.register_backend(backends.BackendSpec(
        "failing", "hri_envs.envs.episode:Episode", "tests.test_bench:_FailsOnSecondStep"))
    request.addfinalizer(lambda: backends.BACKENDS.unregister("failing"))
    graph = scenario_graph("hanger")
    human = preference_human(graph)
    schedule = make_schedule(graph, "random", [0, 1], 2, 0)
    kw = {"runs": [0, 1], "seed": 0, "r0": -0.33}
    ok = simulate(graph, make_agent("passive", graph, human, [0, 1], seed=0, r0=-0.33), human,
                  schedule, **kw)
    bad = simulate(graph, make_agent("passive", graph, human, [0, 1], seed=0, r0=-0.33), human,
                   schedule, backend="failing", **kw)
    # Run 0 ends after its failed second step, which earns -1 instead of the graph's reward.
    assert (bad.steps[0] == 2).all() and bad.truncated[0].all()
    assert (bad.steps[1] == ok.steps[1]).all() and not bad.truncated[1].any()
    np.testing.assert_allclose(bad.reward[1], ok.reward[1])
    # Step 1: the human grasps while the robot waits (a grasp costs nothing); step 2: r⁻.
    np.testing.assert_allclose(bad.reward[0], 0.0 - 1.0)


def test_env_speed_measurements_read_the_given_clock():
    """``clock=`` (e.g. time.thread_time on a loaded machine) is what the repeats are timed by."""
    from hri_envs.envs import speed as env_speed

    ticks = iter(range(0, 1000, 2))  # every repeat lasts 2 "seconds" of this clock

    def clock():
        return float(next(ticks))

    par = env_speed.parallel_env_steps_per_s("hanger", steps=50, repeats=2, clock=clock)
    vec = env_speed.vector_env_steps_per_s(num_envs=4, steps=10, repeats=3, clock=clock)
    assert (par.seconds, par.steps_per_s) == (2.0, 25.0)
    assert (vec.seconds, vec.steps_per_s) == (2.0, 20.0)
