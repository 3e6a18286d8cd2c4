"""Recorded datasets (hri_bench/data/, hri_bench/people/recording.py): scripted
humans recorded through the same path as people, both views, atomic episodes, the env's
replay, fitted populations in studies."""

import json

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")

from hri_bench.data import datasets  # noqa: E402
from hri_bench.data.datasets import COLUMNS, SessionWriter, create_dataset, open_dataset  # noqa: E402
from hri_bench.data.fit import evaluate, fit, split_participants  # noqa: E402
from hri_bench.data.replay import replay  # noqa: E402
from hri_bench.people.recording import RecordingHumans, record_study  # noqa: E402
from hri_bench.run.study import StudyConfig, run_study  # noqa: E402
from hri_envs.errors import ConfigError  # noqa: E402

pytestmark = pytest.mark.xdist_group("people-datasets")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A study's runs recorded as a synthetic dataset, and the same study simulated."""
    root = tmp_path_factory.mktemp("data")
    cfg = StudyConfig("hanger", agents=("learner",), runs=5, episodes=4, preference="all",
                      human_passive=0.1, seed=3)
    dataset = record_study(cfg, "synthetic-hanger", root=root)
    return root, cfg, dataset, run_study(cfg)


def test_the_recording_is_the_study(recorded):
    _, cfg, dataset, study = recorded
    assert dataset.dataset_id == "synthetic-hanger-v0" and dataset.synthetic
    table = dataset.steps()
    assert table.schema.names == [n for n, _, _ in COLUMNS]
    assert set(table.column("synthetic").to_pylist()) == {True}
    rows = table.to_pylist()
    m = study.metrics["learner"]
    for r, participant in enumerate(dataset.participants()):
        for e in range(cfg.n_episodes):
            steps = [x for x in rows if x["participant"] == participant and x["episode"] == e]
            # step counts and rewards are the study's own (same seeds, same loop)
            assert len(steps) == m["steps"][r, e]
            assert sum(x["robot_reward"] for x in steps) == pytest.approx(m["reward"][r, e])
            assert [x["step"] for x in steps] == list(range(len(steps)))
            assert steps[-1]["terminated"] != steps[-1]["truncated"]
            assert all(x["belief"] is not None and len(x["belief"]) == 3 for x in steps)
            assert all(x["client_response_ms"] is None for x in steps)
    sessions = dataset.sessions()
    assert [s["status"] for s in sessions] == ["complete"] * cfg.runs
    assert sessions[0]["agent"] == "learner" and sessions[0]["agent_config"]["gamma"] == 0.9
    assert sessions[0]["hri_envs_version"] and sessions[0]["source"] == "scripted"


def test_the_env_replays_every_recorded_reward(recorded, tmp_path):
    _, _, dataset, _ = recorded
    lines = []
    results = replay(dataset, dataset.participants()[:2], write=lines.append,
                     frames=tmp_path / "frames")
    assert results and all(r.agrees for r in results)
    assert any("belief" in line for line in lines)
    pngs = sorted((tmp_path / "frames").rglob("*.png"))
    assert pngs and pngs[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ConfigError, match="no participant"):
        replay(dataset, ["p000000000000"])


def test_both_views_load(recorded, tmp_path, monkeypatch):
    _, _, dataset, _ = recorded
    out = datasets.export_parquet(dataset, tmp_path / "all.parquet")
    import pyarrow.parquet as pq

    table = pq.read_table(out)
    meta = {k.decode(): v.decode() for k, v in table.schema.metadata.items()}
    assert meta["dataset_id"] == "synthetic-hanger-v0" and meta["synthetic"] == "true"
    assert meta["content_hash"] == dataset.content_hash()
    assert meta["schema"] == datasets.SCHEMA_VERSION
    assert json.loads(meta["participants"]) == dataset.participants()
    minari = pytest.importorskip("minari")
    root = datasets.export_minari(dataset, tmp_path / "minari")
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    md = minari.load_dataset(dataset.minari_id)
    assert md.total_episodes == len(dataset.episode_paths())
    assert md.total_steps == dataset.steps().num_rows
    ours = list(datasets.robot_episodes(dataset))
    for ep, mine in zip(md.iterate_episodes(), ours, strict=True):
        np.testing.assert_array_equal(ep.rewards, mine.rewards)
        np.testing.assert_array_equal(ep.actions, mine.actions)
        np.testing.assert_array_equal(ep.observations["state"], mine.observations["state"])
    env = md.recover_environment()
    assert env.spec.id == "hri_envs/Hanger-v0"
    assert md.observation_space == env.observation_space


def test_content_hash_names_the_data(recorded, tmp_path):
    root, _, dataset, _ = recorded
    assert dataset.content_hash() == open_dataset("synthetic-hanger-v0", root).content_hash()
    copy = create_dataset("other", "hanger", synthetic=True, root=tmp_path)
    assert copy.content_hash() != dataset.content_hash()


def test_a_crash_loses_only_the_episode_in_progress(tmp_path):
    """Two sessions; one human raises in its second episode: its first episode and the
    other session's episodes are on disk, complete, and no temporary file is left."""
    from hri_bench.run.agents import make_agent
    from hri_bench.run.runner import Schedule, run_episodes
    from hri_envs.envs.backends import GraphBatch
    from hri_envs.humans.scripted import preference_human
    from hri_envs.humans.tables import TableHumans
    from hri_envs.task.scenarios import scenario_graph

    g = scenario_graph("hanger")
    dataset = create_dataset("crash", "hanger", synthetic=True, root=tmp_path)

    class Crashing(TableHumans):
        episode_no = -1

        def begin_episode(self, starts, intentions, rows=None):
            self.episode_no += 1
            super().begin_episode(starts, intentions, rows)

        def act(self, observations, active):
            if self.episode_no == 1 and observations["state"][0] != 0:
                raise RuntimeError("the session crashed")
            return super().act(observations, active)

    def session(name, crash):
        human = (Crashing if crash else TableHumans)(preference_human(g, None), 1)
        human.seed(np.random.default_rng(0))
        writer = SessionWriter(dataset, name, {"session_index": 0})
        agent = make_agent("learner", g, human, [0], seed=0, r0=-0.33)
        rec = RecordingHumans(human, [writer], agent=agent, r0=-0.33)
        sched = Schedule(np.array([[1, 0, 2]]), np.array([[0, 2, 1]]), np.zeros((1, 3), bool))
        return rec, writer, run_episodes(g, agent, rec, sched, GraphBatch(g, [0], 0), r0=-0.33)

    _, ok_writer, ok_loop = session("s0001", False)
    _, bad_writer, bad_loop = session("s0002", True)
    next(ok_loop)
    next(bad_loop)
    with pytest.raises(RuntimeError, match="crashed"):
        next(bad_loop)
    bad_writer.finish("failed")
    for _ in ok_loop:
        pass
    ok_writer.finish()
    assert len(dataset.episode_paths(["s0001"])) == 3
    assert len(dataset.episode_paths(["s0002"])) == 1
    assert {s["participant"]: s["status"] for s in dataset.sessions()} == {
        "s0001": "complete", "s0002": "failed"}
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]
    assert dataset.steps().num_rows == sum(pa.parquet.read_metadata(p).num_rows
                                           for p in dataset.episode_paths())


@pytest.mark.parametrize("bad", ["../x", "a/b", "A-v0", "x y", "", "x" * 80, 3, ".hidden"])
def test_dataset_ids_are_checked(bad, tmp_path):
    with pytest.raises(ConfigError) as err:
        create_dataset(bad, "hanger", synthetic=True, root=tmp_path)
    assert err.value.field == "dataset"
    assert not list(tmp_path.iterdir())


def test_people_and_scripted_humans_never_share_a_dataset(tmp_path):
    create_dataset("mine", "hanger", synthetic=False, root=tmp_path)
    with pytest.raises(ConfigError, match="people's hanger"):
        create_dataset("mine", "hanger", synthetic=True, root=tmp_path)
    with pytest.raises(ConfigError):
        create_dataset("mine", "wheel", synthetic=False, root=tmp_path)
    assert create_dataset("mine-v0", "hanger", synthetic=False, root=tmp_path).synthetic is False


def test_held_out_split_is_fixed_and_models_fit(recorded):
    _, _, dataset, _ = recorded
    people = dataset.participants()
    train, test = split_participants(dataset.dataset_id, people)
    assert sorted(train + test) == sorted(people) and len(test) == 1
    assert split_participants(dataset.dataset_id, list(reversed(people))) == (train, test)
    assert split_participants("x-v0", ["s0001"]) == (["s0001"], [])
    bc, irl = fit(dataset, "bc"), fit(dataset, "irl")
    assert bc.train == train and bc.test == test and irl.theta is not None
    scores = evaluate(dataset, [bc, irl])
    assert scores["steps"] > 0
    for kind in ("bc", "irl"):
        assert scores[kind]["log_likelihood"] > scores["uniform"]["log_likelihood"]


def test_the_schema_is_documented():
    from pathlib import Path

    doc = (Path(__file__).parent.parent / "docs" / "people.md").read_text()
    for name, kind, _ in COLUMNS:
        assert f"| `{name}` | {kind} |" in doc, name


# ----------------------------------------------------------------- damaged datasets
def _rewrite(path, name, values=None, type_=None, edit=None):
    """Rewrite one column of an episode file (``values``, or ``edit`` of the old ones)."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    i = table.schema.get_field_index(name)
    old = table.column(name).to_pylist()
    new = edit(old) if edit is not None else values
    type_ = type_ or table.schema.field(name).type
    pq.write_table(table.set_column(i, pa.field(name, type_), pa.array(new, type=type_)), path)


def _flip(path):
    data = bytearray(path.read_bytes())
    for i in range(100, 140):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))


#: name -> (damage(dataset folder, an episode file of s0002), what the error says)
DAMAGES = {
    "truncated": (lambda d, ep: ep.write_bytes(ep.read_bytes()[:200]), "not a readable Parquet"),
    "empty file": (lambda d, ep: ep.write_bytes(b""), "not a readable Parquet"),
    "flipped bytes": (lambda d, ep: _flip(ep), "not a readable Parquet"),
    "text": (lambda d, ep: ep.write_text("hello"), "not a readable Parquet"),
    "a folder": (lambda d, ep: (ep.unlink(), ep.mkdir()), "is not a file"),
    "no column": (lambda d, ep: pa.parquet.write_table(
        pa.parquet.read_table(ep).drop_columns(["state"]), ep), "has no column state"),
    "numbers as text": (lambda d, ep: _rewrite(ep, "state", type_=pa.string(), edit=lambda c: [
        str(x) for x in c]), "column state is string; the schema's is int16"),
    "too big for int16": (lambda d, ep: _rewrite(ep, "state", type_=pa.int32(), edit=lambda c: [
        40000] * len(c)), "column state: values its type int16 cannot hold"),
    "nulls": (lambda d, ep: _rewrite(ep, "state", edit=lambda c: [None] * len(c)),
              "column state has"),
    "no rows": (lambda d, ep: pa.parquet.write_table(pa.parquet.read_table(ep).slice(0, 0), ep),
                "holds no step"),
    "state out of range": (lambda d, ep: _rewrite(ep, "state", edit=lambda c: [
        x + 100 for x in c]), "step 0: state 10"),
    "start 7": (lambda d, ep: _rewrite(ep, "start", edit=lambda c: [7] * len(c)),
                "step 0: start 7 is outside [0, 3)"),
    "action -3": (lambda d, ep: _rewrite(ep, "human_action", edit=lambda c: [-3] * len(c)),
                  "step 0: human_action -3 is outside [0, 10)"),
    "robot action 50": (lambda d, ep: _rewrite(ep, "robot_action", edit=lambda c: [50] * len(c)),
                        "robot_action 50 is outside"),
    "last human action 99": (lambda d, ep: _rewrite(ep, "robot_last_human_action", edit=lambda c: [
        99] * len(c)), "robot_last_human_action 99 is outside [0, 10)"),
    "a state skipped": (lambda d, ep: _rewrite(ep, "next_state", edit=lambda c: [
        (c[0] + 1) % 24] + c[1:]), "step 0: next_state"),
    "steps out of order": (lambda d, ep: _rewrite(ep, "step", edit=lambda c: c[::-1]),
                           "row 0 is step"),
    "ends twice": (lambda d, ep: _rewrite(ep, "terminated", edit=lambda c: [True] * len(c)),
                   "ends (terminated or truncated) before its last step"),
    "wrong mask": (lambda d, ep: _rewrite(ep, "action_mask", edit=lambda c: [
        [1] * len(m) for m in c]), "action_mask is not state"),
    "NaN reward": (lambda d, ep: _rewrite(ep, "robot_reward", edit=lambda c: [
        float("nan")] * len(c)), "robot_reward is nan"),
    "a human reward of 1e308": (lambda d, ep: _rewrite(ep, "human_reward", edit=lambda c: [
        1e308] + c[1:]), "step 0: human_reward is 1e+308; the goal reward is -1, 0 or +1"),
    "a robot reward of +5": (lambda d, ep: _rewrite(ep, "robot_reward", edit=lambda c: c[:2] + [
        5.0] + c[3:]), "step 2: robot_reward is 5.0; every reward rule's rewards are in [-1, 0]"),
    "short belief": (lambda d, ep: _rewrite(ep, "belief", edit=lambda c: [[0.5]] * len(c)),
                     "belief has 1 entries, not 3"),
    "odd layout": (lambda d, ep: _rewrite(ep, "layout", edit=lambda c: [[1.0]] * len(c)),
                   "layout must be"),
    "another participant's": (lambda d, ep: _rewrite(ep, "participant", edit=lambda c: [
        "s0003"] * len(c)), "holds steps of participant 's0003'"),
    "copied in its session": (lambda d, ep: __import__("shutil").copy(
        ep, ep.with_name("episode-0009.parquet")), "is in episode-0002.parquet too"),
    "copied to another": (lambda d, ep: __import__("shutil").copy(
        ep, d / "sessions" / "s0003" / "episode-0009.parquet"), "holds steps of participant"),
    "a value bomb": (lambda d, ep: _rewrite(ep, "layout", edit=lambda c: [
        [0.0] * (5_000_000 // len(c) + 1)] * len(c)),  # a small file, 40 MB once read
        "an episode file holds at most 4000000 values"),
    "session.json of another": (lambda d, ep: (ep.parent / "session.json").write_text(
        (ep.parent / "session.json").read_text().replace('"s0002"', '"s0004"')),
        "is not the folder's"),
}


@pytest.fixture
def damaged(recorded, tmp_path, request):
    """A copy of the recorded dataset with one damage (the test's parameter)."""
    import shutil

    root = tmp_path / "data"
    shutil.copytree(recorded[2].path, root / "synthetic-hanger-v0")
    folder = root / "synthetic-hanger-v0"
    damage, says = DAMAGES[request.param]
    damage(folder, folder / "sessions" / "s0002" / "episode-0002.parquet")
    return root, says


@pytest.mark.parametrize("damaged", list(DAMAGES), indirect=True)
def test_a_damaged_dataset_is_refused_naming_the_file(damaged):
    root, says = damaged
    with pytest.raises(ConfigError) as err:
        open_dataset("synthetic-hanger", root).steps()
    assert err.value.field == "dataset"
    assert says in str(err.value)
    assert "s0002" in str(err.value) or "s0003" in str(err.value)
    for kind in ("bc", "irl"):  # the fits read the same checked steps
        with pytest.raises(ConfigError) as err:
            fit(open_dataset("synthetic-hanger", root), kind)
        assert says in str(err.value)


def test_a_fit_needs_valid_human_actions(recorded, tmp_path):
    """An action in range but not valid in its state (aborted, as the graph says): the
    dataset reads, both fits refuse it naming the step (before, irl fitted to it silently
    and bc named an index of the whole table)."""
    import shutil

    from hri_envs.task.scenarios import scenario_graph

    shutil.copytree(recorded[2].path, tmp_path / "synthetic-hanger-v0")
    dataset = open_dataset(tmp_path / "synthetic-hanger-v0")
    g = scenario_graph("hanger")
    train, _ = split_participants(dataset.dataset_id, dataset.participants())
    ep = tmp_path / "synthetic-hanger-v0" / "sessions" / train[0] / "episode-0001.parquet"
    table = pa.parquet.read_table(ep).slice(0, 1)  # one step, cut off after it
    s = table.column("state")[0].as_py()
    bad = int(np.flatnonzero(~g.valid[s])[0])
    for name, value in (("robot_action", 0), ("human_action", bad),
                        ("next_state", int(g.next_state[s, 0, bad])),
                        ("aborted", bool(g.aborted[s, 0, bad])), ("terminated", False),
                        ("truncated", True)):
        i = table.schema.get_field_index(name)
        table = table.set_column(i, table.schema.field(name),
                                 pa.array([value], type=table.schema.field(name).type))
    pa.parquet.write_table(table, ep)
    dataset.steps()  # a recording may hold an invalid human action
    for kind in ("bc", "irl"):
        with pytest.raises(ConfigError, match=f"participant {train[0]} episode 1 step 0: the "
                                              f"human's action {bad} is not valid"):
            fit(dataset, kind)


def test_minari_export_refuses_observations_outside_the_env_spaces(recorded, tmp_path,
                                                                   monkeypatch):
    """Before: exit 0 with last_human_action 99 in a Discrete(10) space."""
    pytest.importorskip("minari")
    _, _, dataset, _ = recorded
    good = list(datasets.robot_episodes(dataset))
    bad = good[3]
    bad.observations["last_human_action"][2] = 99
    monkeypatch.setattr(datasets, "robot_episodes", lambda _: iter(good))
    with pytest.raises(ConfigError) as err:
        datasets.export_minari(dataset, tmp_path / "minari")
    assert (f"participant {bad.participant} episode {bad.episode + 1}, observation 2 "
            "(0: after reset): last_human_action 99 is outside the env's Discrete(10)"
            in str(err.value))
    assert err.value.field == "dataset" and not list(tmp_path.iterdir())
    bad.observations["last_human_action"][2] = 0
    bad.actions[0] = -1
    with pytest.raises(ConfigError, match="step 0: the robot's action -1 is outside"):
        datasets.export_minari(dataset, tmp_path / "minari")


def _copy(recorded, tmp_path):
    import shutil

    shutil.copytree(recorded[2].path, tmp_path / "synthetic-hanger-v0")
    return open_dataset(tmp_path / "synthetic-hanger-v0")


def test_replay_checks_every_step(recorded, tmp_path):
    """A human reward the rules do not give, in a middle step: before, only the robot's
    rewards and the last step's end were compared, and the episode 'agreed'."""
    dataset = _copy(recorded, tmp_path)
    ep = dataset.path / "sessions" / "s0002" / "episode-0002.parquet"
    _rewrite(ep, "human_reward", edit=lambda c: c[:1] + [c[1] + 1.0] + c[2:])
    lines = []
    results = replay(dataset, ["s0002"], write=lines.append)
    bad = [r for r in results if not r.agrees]
    assert [(r.participant, r.episode) for r in bad] == [("s0002", 1)]
    assert bad[0].differences[0].startswith("step 2: human reward")
    assert any(line.startswith("  step 2:") and "DIFFERS: human reward" in line for line in lines)


def test_replay_stops_where_the_env_ends_the_episode(recorded, tmp_path):
    """A session whose step limit the env enforces before the recording ends (before: the
    env was stepped past its end)."""
    dataset = _copy(recorded, tmp_path)
    long = max(dataset.episode_paths(["s0003"]), key=lambda p: pa.parquet.read_metadata(p).num_rows)
    n = pa.parquet.read_metadata(long).num_rows
    meta_path = long.parent / "session.json"
    meta = json.loads(meta_path.read_text())
    meta_path.write_text(json.dumps({**meta, "max_steps": n - 2}))
    results = replay(dataset, ["s0003"])
    bad = [r for r in results if not r.agrees]
    assert bad and any(f"step {n - 1}: the env has ended the episode" in d
                       for r in bad for d in r.differences)


def test_replay_names_a_session_without_the_env_settings(recorded, tmp_path):
    dataset = _copy(recorded, tmp_path)
    meta_path = dataset.path / "sessions" / "s0001" / "session.json"
    meta = json.loads(meta_path.read_text())
    for bad in ({"r0": "abc"}, {"max_steps": None}, {"r0": 5.0}, {"reward_rule": "nope"}):
        meta_path.write_text(json.dumps({**meta, **bad}))
        with pytest.raises(ConfigError, match="s0001/session.json") as err:
            replay(dataset, ["s0001"])
        assert err.value.field == "dataset"


def test_replay_of_every_session_refuses_one_without_session_json(recorded, tmp_path, capsys):
    """Issue 43: replay replayed the other sessions and exited 0 while 'dataset show'
    refused the dataset; both refuse it now, naming the folder (a session asked for by
    name still replays)."""
    from hri_bench.cli import main

    dataset = _copy(recorded, tmp_path)
    (dataset.path / "sessions" / "s0002" / "session.json").unlink()
    with pytest.raises(ConfigError, match="s0002: episode files without a session.json") as err:
        replay(dataset)
    assert err.value.field == "dataset"
    for argv in (["replay", "synthetic-hanger"], ["dataset", "show", "synthetic-hanger"]):
        with pytest.raises(SystemExit) as exit_:
            main([*argv, "--data", str(tmp_path)])
        assert exit_.value.code == 2, argv
        assert "s0002: episode files without a session.json" in capsys.readouterr().err
    assert all(r.agrees for r in replay(dataset, ["s0001"]))


def test_uniform_accuracy_is_that_of_a_uniform_choice(recorded):
    """Before: the argmax of a flat row is its first valid action (wait), so uniform's
    'accuracy' was the share of waits (0.000 without any)."""
    from hri_envs.task.scenarios import scenario_graph

    _, _, dataset, _ = recorded
    g = scenario_graph("hanger")
    bc, irl = fit(dataset, "bc"), fit(dataset, "irl")
    scores = evaluate(dataset, [bc, irl])
    states = np.array(dataset.steps(scores["held_out"]).column("state").to_pylist())
    assert scores["uniform"]["accuracy"] == pytest.approx(np.mean(1 / g.valid[states].sum(1)))
    for kind in ("bc", "irl"):
        b = scores[kind]["breakdown"]
        assert 0 <= b["unlikely_steps"] <= scores["steps"] and b["waits"] >= b["unlikely_waits"]


def test_an_interrupted_recording_is_marked_and_left_out(tmp_path, monkeypatch):
    """Ctrl-C (or SIGTERM in the CLI) in the middle of 'dataset record': its sessions were
    marked 'failed', and a kill left them 'running'; both were fitted and exported."""
    import threading

    from hri_bench.people import recording

    cfg = StudyConfig("hanger", agents=("learner",), runs=3, episodes=2, seed=1)
    dataset = record_study(cfg, "partial", root=tmp_path)
    whole = dataset.content_hash()
    real = recording.run_episodes

    def stopped_after_one_episode(*args, **kwargs):
        for i, step in enumerate(real(*args, **kwargs)):
            if i == 1:
                raise KeyboardInterrupt
            yield step

    monkeypatch.setattr(recording, "run_episodes", stopped_after_one_episode)
    with pytest.raises(KeyboardInterrupt):
        record_study(cfg, "partial", root=tmp_path)
    status = {s["participant"]: s["status"] for s in dataset.sessions()}
    assert status == {"s0001": "complete", "s0002": "complete", "s0003": "complete",
                      "s0004": "interrupted", "s0005": "interrupted", "s0006": "interrupted"}
    assert dataset.episode_paths(["s0004"])  # its finished episodes are kept ...
    assert dataset.participants(unfinished=False) == ["s0001", "s0002", "s0003"]
    assert dataset.content_hash() == whole  # ... and left out of the data
    assert set(dataset.steps().column("participant").to_pylist()) == {"s0001", "s0002",
                                                                      "s0003"}
    assert {u["participant"] for u in dataset.unfinished()} == {"s0004", "s0005", "s0006"}
    model = fit(dataset, "bc")
    assert sorted(model.train + model.test) == ["s0001", "s0002", "s0003"]
    assert len(replay(dataset, ["s0004"])) >= 1  # replay plays it when asked

    # a recorder killed outright leaves 'running': read as interrupted once no recorder
    # holds the dataset's lock, and so marked on disk by the next recording
    meta = dataset.path / "sessions" / "s0005" / "session.json"
    meta.write_text(meta.read_text().replace('"interrupted"', '"running"'))
    assert {s["participant"]: s["status"] for s in dataset.sessions()}["s0005"] == "interrupted"
    held, release = threading.Event(), threading.Event()

    def recorder():
        with open_dataset(dataset.path).recording():
            held.set()
            release.wait(10)

    thread = threading.Thread(target=recorder)
    thread.start()
    try:
        assert held.wait(10)
        assert '"interrupted"' in meta.read_text()  # marked by the recorder, under the lock
        meta.write_text(meta.read_text().replace('"interrupted"', '"running"'))
        assert dataset.recorder_alive()
        assert {s["participant"]: s["status"] for s in dataset.sessions()}["s0005"] == "running"
        with pytest.raises(ConfigError, match="another hri-bench dataset record is recording"):
            with dataset.recording(timeout_s=0.2):
                pass
    finally:
        release.set()
        thread.join()
    assert not dataset.recorder_alive()
    assert dataset.participants(unfinished=False) == ["s0001", "s0002", "s0003"]


#: Damages to a physical episode file and what the refusal says.
PHYSICAL_DAMAGES = {
    "ends twice": ("terminated", lambda c: [True] * len(c),
                   "step 0: the episode ends (terminated or truncated) before its last step"),
    "ends neither way": ("truncated", lambda c: [False] * len(c),
                         "the last step must be terminated or truncated, not neither"),
    "NaN stiffness": ("stiffness", lambda c: [float("nan")] * len(c),
                      "step 0: stiffness is nan, not a number"),
    "an infinite frame time": ("t_frame", lambda c: c[:1] + [float("inf")] + c[2:],
                               "step 1: t_frame is inf, not a number"),
    "stiffness 2": ("stiffness", lambda c: [2.0] * len(c), "stiffness must be in [0, 1]"),
}


@pytest.fixture(scope="module")
def physical_recorded(tmp_path_factory):
    """One synthetic participant's short physical episode, recorded through the page."""
    from hri_bench.people.synthetic import record_synthetic

    root = tmp_path_factory.mktemp("physical")
    record_synthetic("hanger", "dmg", sessions=1, episodes=1, data=root, at_once=1,
                     max_time_s=2.0)
    return root


@pytest.mark.parametrize("damage", list(PHYSICAL_DAMAGES))
def test_a_damaged_physical_episode_is_refused_naming_the_file(physical_recorded, tmp_path,
                                                               damage):
    import shutil

    root = tmp_path / "data"
    shutil.copytree(physical_recorded, root)
    episode = root / "dmg-v0" / "sessions" / "s0001" / "episode-0001.parquet"
    open_dataset("dmg", root).steps()  # as recorded, it reads
    name, edit, says = PHYSICAL_DAMAGES[damage]
    _rewrite(episode, name, edit=edit)
    with pytest.raises(ConfigError) as err:
        open_dataset("dmg", root).steps()
    assert err.value.field == "dataset" and says in str(err.value)
    assert "episode-0001.parquet" in str(err.value)


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_a_physical_episode_s_observation_size_is_its_env_s(scenario):
    """The schema's size comes from the scenario's physical design (the wheel's robot has
    a mobile base: 10 joints), not from its name."""
    pytest.importorskip("mujoco")
    import warnings

    import gymnasium as gym

    from hri_bench.data.physical import observation_size
    from hri_envs.registration import continuous_id
    from hri_envs.task.scenarios import scenario_graph, spec_of

    graph = scenario_graph(scenario)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(continuous_id(str(spec_of(graph).continuous_id), 1))
    assert env.observation_space.shape == (observation_size(graph),)
    env.close()
