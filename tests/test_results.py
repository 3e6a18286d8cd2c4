"""The results protocol: the task's metrics on hand-made cases, the cross-track aggregates,
the results file's validator, replays and the custom-agent contract (docs/results.md)."""

from __future__ import annotations

import copy
import hashlib
import json
import math
import os

import numpy as np
import pytest

from agents.protocol import BatchAgent, Batched, read_belief
from baselines import Passive
from hri_bench.cli import main
from hri_bench.report import aggregate
from hri_bench.run import agents as bench_agents
from hri_bench.run import metrics, provenance
from hri_bench.run.agents import contract_keywords, make_agent
from hri_bench.run.isolation import IN_PROCESS, agent_streams
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import StudyConfig, graph_for, run_study
from hri_bench.suite import submission
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from tests.helpers_agents import AlwaysWait


# --------------------------------------------------------------------------- hand-made beliefs
class Believer(Passive):
    """The Passive baseline's actions with a belief of the test's making: ``knows`` puts all
    mass on the episode's goal from step 0; ``uniform`` spreads it over every support;
    ``late`` puts it on a wrong support for the first two decisions, then on the goal."""

    def __init__(self, graph, goals, kind):
        super().__init__(graph, goals.shape[0])
        self.goals, self.kind, self.e, self.t = goals, kind, -1, 0

    def begin_episode(self, starts):
        super().begin_episode(starts)
        self.e, self.t = self.e + 1, 0

    def act(self, observations, active):
        self.t += 1
        return super().act(observations, active)

    def belief(self):
        k = self.graph.n_intentions
        goal = self.goals[:, self.e]
        if self.kind == "uniform":
            return np.full((self.n_runs, k), 1.0 / k)
        target = (goal + 1) % k if self.kind == "late" and self.t < 2 else goal
        return np.eye(k)[target]


@pytest.fixture(scope="module")
def hanger_case():
    graph = graph_for("hanger")
    human = preference_human(graph)
    runs = [0, 1, 2]
    return graph, human, runs, make_schedule(graph, "random", runs, 3, 0, human)


@pytest.mark.parametrize("kind", ["knows", "uniform", "late"])
def test_belief_metrics_on_hand_made_beliefs(kind, hanger_case):
    graph, human, runs, schedule = hanger_case
    agent = Believer(graph, schedule.goal, kind)
    m = simulate(graph, agent, human, schedule, runs=runs, seed=0, r0=-0.33)
    k = graph.n_intentions
    if kind == "knows":  # knows the intention from step 0: 0 steps, log-loss 0, Brier 0
        assert np.all(m.task["map_steps"] == 0)
        assert np.all(m.task["log_loss"] == 0) and np.all(m.task["brier"] == 0)
    elif kind == "uniform":  # never a unique maximum: every decision counts
        assert np.array_equal(m.task["map_steps"], m.steps)
        assert np.allclose(m.task["log_loss"], math.log(k))
        assert np.allclose(m.task["brier"], 1 - 1 / k)
    else:  # wrong for the first two decisions, then right for good
        assert np.all(m.task["map_steps"] == 2)
        assert np.allclose(m.task["log_loss"], 2 * -math.log(1e-15) / m.steps)
        assert np.allclose(m.task["brier"], 2 * 2 / m.steps)


def test_agents_without_a_belief_score_nan_and_effort_is_counted(hanger_case):
    graph, human, runs, schedule = hanger_case
    m = simulate(graph, Passive(graph, 3), human, schedule, runs=runs, seed=0, r0=-0.33)
    assert np.all(np.isnan(m.task["log_loss"])) and np.all(np.isnan(m.task["map_steps"]))
    # Passive waits between grasping and letting go: the human moves the object alone.
    assert np.all(m.task["human_alone"] >= 1) and np.all(m.task["counteract"] == 0)


def test_the_learner_goal_filter_and_qmdp_expose_a_belief_others_do_not(hanger_case):
    graph, human, runs, _ = hanger_case
    for name in ("learner", "goalfilter", "qmdp"):
        agent = make_agent(name, graph, human, runs, seed=0, r0=-0.33)
        agent.begin_episode(np.zeros(3, dtype=np.int64))
        b = read_belief(agent, 3)
        assert b is not None and b.shape == (3, graph.n_intentions)
        assert np.allclose(b[:, 0], 0.0) and np.allclose(b.sum(1), 1.0)  # not the start
    for name in ("passive", "imitator", "maxent", "oracle"):
        assert read_belief(make_agent(name, graph, human, runs, seed=0, r0=-0.33)) is None


@pytest.mark.parametrize("row", [[0.7, 0.7], [np.nan, 1.0], [-0.5, 1.5], [np.inf, -np.inf],
                                 [0.0, np.inf], [0.5, 0.4999]])
def test_a_bad_belief_is_refused_naming_the_agent(row):
    class Bad(Passive):
        name = "bad-belief"

        def belief(self):
            return np.array([row])

    with pytest.raises(ConfigError, match="bad-belief.*probability") as info:
        read_belief(Bad(graph_for("hanger"), 1), 1)
    assert info.value.field == "belief"


def test_a_plain_agent_s_belief_reaches_the_batch():
    class Sure(AlwaysWait):
        def belief(self):
            return np.array([0.0, 1.0, 0.0])

    assert np.array_equal(read_belief(Batched([Sure(), Sure()]), 2), [[0, 1, 0], [0, 1, 0]])
    assert read_belief(Batched([AlwaysWait()])) is None


@pytest.mark.parametrize("second", [[0.5, 0.6, 0.0], [0.5, 0.5]])
def test_a_plain_agent_s_bad_belief_is_refused_once_stacked(second):
    class Sure(AlwaysWait):
        name = "sure"

        def __init__(self, row):
            self.row = row

        def belief(self):
            return np.array(self.row)

    with pytest.raises(ConfigError, match="'sure'") as info:
        read_belief(Batched([Sure([0.0, 1.0, 0.0]), Sure(second)]), 2)
    assert info.value.field == "belief"


# --------------------------------------------------------------------------- learning metrics
def test_learning_episodes_and_asymptote_on_hand_made_regret():
    regret = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                       [0.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.5, 0.5]])
    assert metrics.learning_episodes(regret, 0.5).tolist() == [2, 3, 5, 1, 1]
    assert metrics.asymptote(regret).tolist() == [0.0, 0.0, 1.0, 0.0, 0.5]  # last 1 of 4
    assert metrics.last_k(20) == 5 and metrics.last_k(3) == 1
    # A human who drifts after two episodes: counted again from the switch.
    drifted = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.0]])
    out = metrics.agent_metrics({"reward": -drifted, "truncated": np.zeros((2, 4))},
                                np.zeros((2, 4)), seed=0, threshold=0.5, drift=2)
    assert out["readapt_episodes"]["mean"] == 2.5  # runs: 2 and 3 (never: 2 left + 1)
    assert out["learning_episodes"]["mean"] == 4.5  # 4 and 5 (never)
    assert out["log_loss"] is None and out["score"]["mean"] == -0.375


# --------------------------------------------------------------------------- aggregates
def test_aggregate_iqm_probability_of_improvement_and_profiles():
    rng = np.random.default_rng(0)
    scores = {str(s): {t: {"good": rng.normal(-1, 0.1, 20), "bad": rng.normal(-3, 0.1, 20),
                           "same": np.full(20, -2.0)} for t in ("t1", "t2")} for s in (0, 1)}
    scores["0"]["t1"]["partial"] = np.zeros(20)
    out = aggregate.aggregate(scores, ["good", "bad", "same", "partial"], seed=0)
    assert list(out["agents"]) == ["good", "bad", "same"]
    assert out["partial"] == {"partial": ["t1"]}  # not on every track: not aggregated
    assert out["probability_of_improvement"]["good"]["bad"] == 1.0
    assert out["probability_of_improvement"]["bad"]["good"] == 0.0
    same = out["agents"]["same"]
    assert same["iqm"] == -2.0 and same["iqm_ci95"] == [-2.0, -2.0] and same["seed_std"] == 0
    good = out["agents"]["good"]
    assert good["runs"] == 80 and good["iqm_ci95"][0] <= good["iqm"] <= good["iqm_ci95"][1]
    assert set(good["seeds"]) == {"0", "1"} and good["seed_std"] > 0
    prof = out["profiles"]
    i = prof["tau"].index(min(prof["tau"], key=lambda v: abs(v + 2.0)))
    assert prof["fraction_above"]["good"][i] == 1.0 and prof["fraction_above"]["bad"][i] == 0.0


# --------------------------------------------------------------------------- results files
@pytest.fixture(scope="module")
def suite_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("results") / "s"
    code = main(["suite", "--out", str(out), "--tracks", "hanger-paper", "--runs-scale",
                 "0.006", "--agents", "learner,passive,tests.helpers_agents:RandomMover",
                 "--no-progress", "--suite-version", "2"])
    assert code == 0
    return out


def test_a_suite_made_results_file_validates(suite_dir, capsys):
    doc = submission.load(suite_dir / "results.json")
    assert submission.validate(doc) == []
    assert main(["validate", str(suite_dir / "results.json")]) == 0
    assert "valid" in capsys.readouterr().out
    ident = doc["agents"]["tests.helpers_agents:RandomMover"]
    assert ident["kind"] == "custom" and "tests/helpers_agents.py" in ident["files"]
    assert set(ident["constructor"]) == {"graph", "rng", "max_steps", "r0", "reward",
                                         "episodes"}
    assert doc["agents"]["learner"]["kind"] == "builtin"
    assert set(doc["software"]) >= {"numpy", "gymnasium", "pettingzoo", "mujoco", "hri-envs"}
    learner = doc["statistics"]["0"]["hanger-paper"]["learner"]
    assert learner["log_loss"] is not None and learner["learning_episodes"] is not None
    assert doc["statistics"]["0"]["hanger-paper"]["passive"]["log_loss"] is None
    board = (suite_dir / "leaderboard.md").read_text()
    assert board.index("## Across tracks") < board.index("## Overview")
    assert "Probability of improvement" in board and (suite_dir / "profiles.png").exists()


def _problems(doc, edit):
    bad = copy.deepcopy(doc)
    edit(bad)
    return submission.validate(bad)


def test_edited_numbers_a_wrong_hash_and_missing_runs_are_rejected_by_name(suite_dir):
    doc = submission.load(suite_dir / "results.json")
    stats = ("statistics", "0", "hanger-paper", "learner")

    def edit_stat(d):
        d["statistics"]["0"]["hanger-paper"]["learner"]["score"]["mean"] += 0.01

    assert any(p.startswith(".".join(stats) + ".score.mean: recorded")
               for p in _problems(doc, edit_stat))

    def edit_run(d):
        d["runs"]["0"]["hanger-paper"]["agents"]["passive"]["reward"][0][0] -= 1.0

    assert any("statistics.0.hanger-paper.passive.score.mean" in p
               for p in _problems(doc, edit_run))

    def edit_aggregate(d):
        d["aggregate"]["probability_of_improvement"]["learner"]["passive"] = 0.1

    assert _problems(doc, edit_aggregate) == [
        "aggregate.probability_of_improvement.learner.passive: recorded 0.1, recomputed from the "
        "runs "
        f"{json.dumps(doc['aggregate']['probability_of_improvement']['learner']['passive'])}"]

    def wrong_hash(d):
        d["suite"]["hash"] = "0" * 64

    assert any(p.startswith("suite.hash is 0000") for p in _problems(doc, wrong_hash))

    def wrong_version(d):
        d["suite"]["version"] = "0"

    assert "suite.version is '0'" in _problems(doc, wrong_version)[0]

    def missing_runs(d):
        d["runs"]["0"]["hanger-paper"]["agents"]["learner"]["reward"].pop()

    assert any("runs.0.hanger-paper.agents.learner.reward" in p and "missing runs" in p
               for p in _problems(doc, missing_runs))

    def other_settings(d):
        d["tracks"]["hanger-paper"]["settings"]["turn_back"] = 0.5

    assert _problems(doc, other_settings) == [
        "tracks.hanger-paper.settings.turn_back is 0.5; the track's is 0.0"]

    def no_statistics(d):
        del d["statistics"]

    assert any("'statistics' is a required property" in p
               for p in _problems(doc, no_statistics))


def test_validate_and_leaderboard_commands(suite_dir, tmp_path, capsys):
    doc = submission.load(suite_dir / "results.json")
    folder = tmp_path / "submissions"
    folder.mkdir()
    (folder / "ours.json").write_text(json.dumps(doc))
    bad = copy.deepcopy(doc)
    bad["statistics"]["0"]["hanger-paper"]["passive"]["score"]["iqm"] = 0.0
    (folder / "edited.json").write_text(json.dumps(bad))
    assert main(["validate", str(folder / "edited.json")]) == 1
    assert "passive.score.iqm: recorded 0.0" in capsys.readouterr().err
    assert main(["leaderboard", str(folder), "--out", str(tmp_path / "board")]) == 1
    err = capsys.readouterr().err
    assert "edited.json: refused" in err and "ours.json" not in err
    board = (tmp_path / "board" / "leaderboard.md").read_text()
    assert board.index("## Across tracks") < board.index("## The task's metrics")
    assert "`ours.json`" in board and (tmp_path / "board" / "profiles.png").exists()


def test_leaderboard_of_a_missing_folder_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["leaderboard", str(tmp_path / "nowhere")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: hri-bench leaderboard")
    assert f"error: argument dir: {tmp_path / 'nowhere'} is not a folder" in err


def test_replay_is_byte_identical_and_warns_when_a_custom_agent_changed(suite_dir, tmp_path,
                                                                         capsys, monkeypatch):
    again = tmp_path / "again"
    assert main(["suite", "--config", str(suite_dir / "suite.json"), "--out", str(again),
                 "--no-progress"]) == 0
    assert "warning" not in capsys.readouterr().err
    for name in ("suite.json", "results.json", "leaderboard.md"):
        assert (again / name).read_bytes() == (suite_dir / name).read_bytes(), name
    # The same agent name, other code: the replay says so (the recorded hash differs).
    recorded = json.loads((suite_dir / "suite.json").read_text())
    recorded["provenance"]["agents"]["tests.helpers_agents:RandomMover"]["code_sha256"] = "0" * 64
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps(recorded))
    assert main(["suite", "--config", str(changed), "--out", str(tmp_path / "third"),
                 "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "warning: agent 'tests.helpers_agents:RandomMover': its source files' hash differs" \
        in err
    with pytest.raises(SystemExit) as exc:
        main(["suite", "--config", str(changed), "--out", str(tmp_path / "x"), "--seed", "3"])
    assert exc.value.code == 2
    assert "drop --seed" in capsys.readouterr().err


def test_code_changes_names_the_changed_file(tmp_path, monkeypatch):
    (tmp_path / "mylab_agent.py").write_text(
        "from tests.helpers_agents import AlwaysWait\nclass Mine(AlwaysWait):\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    before = provenance.agent_identity("mylab_agent:Mine")
    assert before["files"] == {"mylab_agent.py": bench_agents._sha256(tmp_path / "mylab_agent.py")}
    assert provenance.code_changes({"mylab_agent:Mine": before}, ["mylab_agent:Mine"]) == []
    (tmp_path / "mylab_agent.py").write_text(
        "from tests.helpers_agents import AlwaysWait\nclass Mine(AlwaysWait):\n    x = 1\n")
    lines = provenance.code_changes({"mylab_agent:Mine": before}, ["mylab_agent:Mine"])
    assert len(lines) == 1 and "(changed: mylab_agent.py)" in lines[0]


# --------------------------------------------------------------------------- the contract
def test_a_custom_agent_gets_the_contract_and_its_generator_is_jobs_independent(monkeypatch):
    # Made in this process (the same keywords and streams as in its own) to look inside it.
    monkeypatch.setenv(IN_PROCESS, "1")
    graph = graph_for("wheel")
    agent = make_agent("tests.helpers_agents:RandomMover", graph, preference_human(graph), [4, 7],
                       seed=5, r0=-0.25, max_steps=60, reward="no-free-toggle", episodes=3)
    first = agent.agents[1]
    assert first.given == {"max_steps": 60, "r0": -0.25, "reward": "no-free-toggle",
                           "episodes": 3}
    assert first.rng.random() == agent_streams(5, [7])[0].random()
    assert first.rng.random() != np.random.default_rng([5, 7]).random()  # not (seed, run)
    monkeypatch.delenv(IN_PROCESS)
    spec = "tests.helpers_agents:RandomMover"
    results = [run_study(StudyConfig("wheel", agents=(spec,), runs=4, episodes=3, seed=2,
                                     jobs=jobs, executor=ex))
               for jobs, ex in ((1, "serial"), (2, "process"))]
    for k in ("reward", "steps", "counteract"):
        assert np.array_equal(results[0].metrics[spec][k], results[1].metrics[spec][k]), k
    assert results[0].metrics[spec]["reward"].std() > 0  # it does draw


def test_old_signatures_keep_working_and_kwargs_get_everything(monkeypatch):
    monkeypatch.setenv(IN_PROCESS, "1")
    graph = graph_for("hanger")
    human = preference_human(graph)
    assert contract_keywords(AlwaysWait) == ()
    assert isinstance(make_agent("tests.helpers_agents:AlwaysWait", graph, human, [0], seed=0,
                                 r0=-0.33).agents[0], AlwaysWait)
    got = make_agent("tests.helpers_agents:TakesKeywords", graph, human, [3], seed=1,
                     r0=-0.33).agents[0].kwargs
    assert set(got) == {"graph", "rng", "r0", "reward", "max_steps", "episodes"}

    class OldBatch(BatchAgent):
        def __init__(self, graph, n_runs):
            super().__init__(n_runs)

    class NewBatch(OldBatch):
        def __init__(self, graph, n_runs, *, rngs, r0):
            super().__init__(graph, n_runs)
            self.rngs, self.r0 = rngs, r0

    class AsksForTheRuns(OldBatch):
        def __init__(self, graph, n_runs, *, rngs, runs):
            super().__init__(graph, n_runs)

    assert contract_keywords(OldBatch) == () and contract_keywords(NewBatch) == ("rngs", "r0")
    with pytest.raises(ConfigError, match="requires runs in its constructor"):
        contract_keywords(AsksForTheRuns)


def test_a_study_records_a_custom_agent_s_code_and_its_replay_warns(tmp_path, capsys):
    spec = "tests.helpers_agents:RandomMover"
    out = tmp_path / "study"
    assert main(["study", "hanger", "--runs", "2", "--episodes", "1", "--agents", spec,
                 "--no-progress", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["agent_configs"][spec]["kind"] == "custom"
    summary["agent_configs"][spec]["code_sha256"] = "f" * 64
    (tmp_path / "edited.json").write_text(json.dumps(summary))
    capsys.readouterr()
    assert main(["study", "--config", str(tmp_path / "edited.json"), "--no-progress", "--out",
                 str(tmp_path / "again")]) == 0
    assert f"warning: agent '{spec}': its source files' hash differs" in capsys.readouterr().err
    assert (tmp_path / "again" / "episodes.csv").read_bytes() == (
        out / "episodes.csv").read_bytes()


def test_a_study_replay_reads_its_config_once_within_the_limit(tmp_path, capsys, monkeypatch):
    """The code-change warning comes from the document --config was read into (at most
    cli.MAX_CONFIG_BYTES), not from reading the file a second time without the limit."""
    import builtins
    import io

    spec = "tests.helpers_agents:RandomMover"
    out = tmp_path / "study"
    assert main(["study", "hanger", "--runs", "2", "--episodes", "1", "--agents", spec,
                 "--no-progress", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    summary["agent_configs"][spec]["code_sha256"] = "f" * 64
    config = tmp_path / "edited.json"
    config.write_text(json.dumps(summary))
    opened = []
    real_open = io.open

    def counting_open(file, *args, **kwargs):
        if str(file) == str(config):
            opened.append(args[0] if args else kwargs.get("mode", "r"))
        return real_open(file, *args, **kwargs)

    real_os_open = os.open

    def counting_os_open(path, flags, *args, **kwargs):
        if str(path) == str(config):
            opened.append("rb" if flags & (os.O_WRONLY | os.O_RDWR) == 0 else "w")
        return real_os_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(io, "open", counting_open)  # what pathlib's read_bytes calls
    monkeypatch.setattr(os, "open", counting_os_open)  # what read_json opens with
    capsys.readouterr()
    assert main(["study", "--config", str(config), "--no-progress", "--out",
                 str(tmp_path / "again")]) == 0
    assert f"warning: agent '{spec}': its source files' hash differs" in capsys.readouterr().err
    assert opened == ["rb"]


def _renamed(value, old, new):
    """``value`` (a JSON document) with every key ``old`` renamed ``new``."""
    if isinstance(value, dict):
        return {(new if k == old else k): _renamed(v, old, new) for k, v in value.items()}
    if isinstance(value, list):
        return [_renamed(v, old, new) for v in value]
    return value


@pytest.mark.parametrize("name", ["pass|ive", "pass\nive", "<b>passive</b>", "`passive`",
                                  " passive", "pa\x00ss"])
def test_agent_names_a_leaderboard_cannot_show_are_refused(suite_dir, tmp_path, name, capsys):
    """Issue 43: validate accepted names holding |, line breaks or HTML (consistent files:
    the statistics match); the suite's own --agents refuses them too."""
    doc = _renamed(submission.load(suite_dir / "results.json"), "passive", name)
    problems = submission.validate(doc)
    assert problems and problems[0].startswith("agents: agent name ")
    assert any(p.startswith("runs.0.hanger-paper.agents: agent name ") for p in problems)
    path = tmp_path / "results.json"
    path.write_text(json.dumps(doc))
    assert main(["validate", str(path)]) == 1
    assert "INVALID" in capsys.readouterr().err
    from hri_bench.run.agents import validate_agent_name

    with pytest.raises(ConfigError, match="agent name") as err:
        validate_agent_name(name)
    assert err.value.field == "agents"


def test_every_agent_name_resolves_to_one_spec_that_answers_every_question(tmp_path):
    """Issue 42: a name's form (registered, sb3:PATH, jaxppo[:PATH], module:Class) is read
    once, by resolve_agent; making, privilege, settings and identity ask its spec."""
    from hri_bench.run.agents import (
        AGENTS,
        AgentForm,
        agent_identity,
        agent_privilege,
        agent_settings,
        resolve_agent,
    )

    assert resolve_agent("learner") is AGENTS["learner"]
    model = tmp_path / "model.zip"
    model.write_bytes(b"0123456789")
    sb3 = resolve_agent(f"sb3:{model}")
    assert isinstance(sb3, AgentForm) and sb3.kind == "sb3" and sb3.intention_blind
    assert agent_settings(f"sb3:{model}", "hanger", -0.33) == {"path": str(model), "bytes": 10}
    assert agent_identity(f"sb3:{model}")["sha256"] == hashlib.sha256(b"0123456789").hexdigest()
    assert resolve_agent("jaxppo").kind == "jaxppo"  # type: ignore[attr-defined]
    custom = resolve_agent("tests.helpers_agents:RandomMover")
    assert isinstance(custom, AgentForm) and custom.kind == "custom"
    assert not agent_privilege("tests.helpers_agents:RandomMover").reference
    assert agent_identity("tests.helpers_agents:RandomMover")["class"] == "RandomMover"
    for bad in ("nobody", f"sb3:{tmp_path / 'missing.zip'}"):
        with pytest.raises(ConfigError) as err:
            resolve_agent(bad)
        assert err.value.field == "agents"
