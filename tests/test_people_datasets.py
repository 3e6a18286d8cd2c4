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
