"""The people-in-the-loop commands: ``hri-bench dataset``, ``replay``, recorded populations
in ``study`` and ``suite`` (hri_bench/cli/people.py, hri_bench/data/fit.py)."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")

from hri_bench.cli import main  # noqa: E402
from hri_bench.people.recording import record_study  # noqa: E402
from hri_bench.run.study import StudyConfig  # noqa: E402

pytestmark = pytest.mark.xdist_group("people-datasets")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A study's runs recorded as a synthetic dataset."""
    root = tmp_path_factory.mktemp("data")
    cfg = StudyConfig("hanger", agents=("learner",), runs=5, episodes=4, preference="all",
                      human_passive=0.1, seed=3)
    return root, cfg, record_study(cfg, "synthetic-hanger", root=root)


def test_a_fitted_population_runs_in_a_study_and_the_suite(recorded, tmp_path, monkeypatch,
                                                           capsys):
    root, _, _ = recorded
    monkeypatch.setenv("HRI_BENCH_DATASETS", str(root))
    for name in ("recorded:synthetic-hanger", "recorded-irl:synthetic-hanger-v0"):
        out = tmp_path / name.split(":")[0]
        assert main(["study", "hanger", "--agents", "learner,oracle", "--runs", "3",
                     "--episodes", "3", "--population", name, "--out", str(out),
                     "--no-progress"]) == 0
        rows = (out / "episodes.csv").read_text().splitlines()
        assert len(rows) == 1 + 2 * 3 * 3 and name in rows[1]
    assert main(["suite", "--out", str(tmp_path / "suite"), "--runs-scale", "0.005",
                 "--tracks", "hanger-paper", "--agents", "learner", "--population",
                 "recorded:synthetic-hanger", "--no-progress"]) == 0
    doc = json.loads((tmp_path / "suite" / "suite.json").read_text())
    assert "hanger-recorded-synthetic-hanger" in doc["tracks"]


@pytest.mark.parametrize("argv, flag", [
    (["study", "hanger", "--population", "recorded:nothing-here"], "--population"),
    (["study", "wheel", "--population", "recorded:synthetic-hanger"], "--population"),
    (["study", "hanger", "--population", "recorded:"], "--population"),
    (["study", "hanger", "--population", "recorded:../../etc"], "--population"),
])
def test_bad_recorded_populations_exit_2(argv, flag, recorded, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("HRI_BENCH_DATASETS", str(recorded[0]))
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--out", str(tmp_path / "o"), "--no-progress"])
    assert exit_.value.code == 2
    assert f"argument {flag}" in capsys.readouterr().err


def test_dataset_commands(recorded, tmp_path, capsys):
    root = str(recorded[0])
    assert main(["dataset", "list", "--data", root]) == 0
    assert "synthetic-hanger-v0" in capsys.readouterr().out
    assert main(["dataset", "show", "synthetic-hanger", "--data", root, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["synthetic"] is True and doc["participants"] == 5
    assert doc["content_hash"].startswith("sha256:")
    assert main(["dataset", "export", "synthetic-hanger", "--data", root, "--out",
                 str(tmp_path / "x.parquet")]) == 0
    assert (tmp_path / "x.parquet").is_file()
    assert main(["dataset", "fit", "synthetic-hanger", "--data", root, "--out",
                 str(tmp_path / "models")]) == 0
    out = capsys.readouterr().out
    assert "held-out log-likelihood" in out and "SYNTHETIC" in out
    with np.load(tmp_path / "models" / "bc.npz", allow_pickle=False) as f:
        assert json.loads(str(f["meta"]))["kind"] == "bc"
    assert main(["replay", "synthetic-hanger", "--data", root, "--participant", "s0001"]) == 0
    assert "the env gives the recorded rewards" in capsys.readouterr().out
    for argv in (["dataset", "show", "nope", "--data", root],
                 ["dataset", "export", "synthetic-hanger", "--data", root],
                 ["replay", "synthetic-hanger", "--data", root, "--participant", "s9999"],
                 ["dataset", "record", "hanger", "--dataset", "../up", "--data", root]):
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 2, argv
    assert not (recorded[0].parent / "up").exists()
    assert os.listdir(root) == ["synthetic-hanger-v0"]


def test_fit_says_when_no_participant_is_held_out(tmp_path, capsys):
    """One participant: the model is fitted to it and nothing is scored (no NaN table)."""
    cfg = StudyConfig("hanger", agents=("learner",), runs=1, episodes=2, seed=3)
    record_study(cfg, "alone", root=tmp_path)
    assert main(["dataset", "fit", "alone", "--data", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "no held-out participant" in out and "nan" not in out
    assert "0 held out" in out and "recorded:alone-v0" in out


def test_minari_export_with_a_relative_data_folder(recorded, tmp_path, monkeypatch, capsys):
    """As README and docs/people.md write it: ``--data out/datasets``, a relative path."""
    pytest.importorskip("minari")
    import shutil

    shutil.copytree(recorded[0], tmp_path / "out" / "datasets")
    monkeypatch.chdir(tmp_path)
    assert main(["dataset", "export", "synthetic-hanger", "--data", "out/datasets",
                 "--format", "minari"]) == 0
    assert "wrote the Minari dataset hri-envs/synthetic-hanger-v0" in capsys.readouterr().out
    root = Path("out/datasets/synthetic-hanger-v0/minari")  # loaded as the docs do
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    data = pytest.importorskip("minari").load_dataset("hri-envs/synthetic-hanger-v0")
    assert data.total_episodes == 20
    assert not [p for p in root.parent.iterdir() if ".build-" in p.name]


def _damaged_copy(recorded, tmp_path, damage):
    """A copy of the recorded dataset under ``tmp_path/data`` with ``damage(episode file)``."""
    import shutil

    root = tmp_path / "data"
    shutil.copytree(recorded[0] / "synthetic-hanger-v0", root / "synthetic-hanger-v0")
    damage(root / "synthetic-hanger-v0" / "sessions" / "s0002" / "episode-0002.parquet")
    return root


def _start_7(path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    i = table.schema.get_field_index("start")
    pq.write_table(table.set_column(i, table.schema.field("start"),
                                    pa.array([7] * table.num_rows, type=pa.int8())), path)


@pytest.mark.parametrize("damage, says", [
    (lambda p: p.write_bytes(p.read_bytes()[:300]), "is not a readable Parquet file"),
    (lambda p: p.write_bytes(b""), "is not a readable Parquet file"),
    (_start_7, "step 0: start 7 is outside [0, 3)"),
])
@pytest.mark.parametrize("argv", [["dataset", "show"], ["dataset", "export", "--out", "x.pq"],
                                  ["dataset", "export", "--format", "minari"],
                                  ["dataset", "fit"], ["replay"]])
def test_damaged_datasets_exit_2_naming_the_file(recorded, tmp_path, capsys, monkeypatch,
                                                 damage, says, argv):
    root = _damaged_copy(recorded, tmp_path, damage)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_:
        main([*argv[:2], "synthetic-hanger", *argv[2:], "--data", str(root)])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "Traceback" not in err
    assert "argument dataset:" in err and "s0002/episode-0002.parquet" in err and says in err
    assert not (tmp_path / "x.pq").exists()


@pytest.mark.parametrize("population", ["recorded:synthetic-hanger",
                                        "recorded-irl:synthetic-hanger"])
def test_a_damaged_recorded_population_is_refused_before_simulating(
        recorded, tmp_path, capsys, monkeypatch, population):
    """Before: the study simulated, the fit failed in each run, and the agents were
    blamed (exit 1)."""
    root = _damaged_copy(recorded, tmp_path, _start_7)
    monkeypatch.setenv("HRI_BENCH_DATASETS", str(root))
    with pytest.raises(SystemExit) as exit_:
        main(["study", "hanger", "--agents", "learner", "--runs", "2", "--episodes", "2",
              "--population", population, "--out", str(tmp_path / "o"), "--no-progress"])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "argument --population" in err
    assert "start 7 is outside" in err and "episode-0002.parquet" in err
    assert not (tmp_path / "o").exists()


def test_a_dataset_id_that_is_a_path_is_refused(recorded, tmp_path, capsys):
    """dataset.json's id names Minari's folders: '../../../tmp/evil' wrote outside the
    export root."""
    import shutil

    folder = tmp_path / "d" / "sneaky-v0"
    shutil.copytree(recorded[0] / "synthetic-hanger-v0", folder)
    meta = json.loads((folder / "dataset.json").read_text())
    (folder / "dataset.json").write_text(json.dumps({**meta, "dataset_id": "../../../x/evil"}))
    for argv in (["dataset", "export", str(folder), "--format", "minari", "--out",
                  str(tmp_path / "m" / "a" / "b")], ["dataset", "show", str(folder)]):
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        err = capsys.readouterr().err
        assert exit_.value.code == 2 and "dataset_id '../../../x/evil' is no dataset id" in err
    assert not (tmp_path / "x").exists() and not (tmp_path / "m").exists()


def test_a_recorded_population_has_a_content_hash_and_replays_say_when_it_changed(
        recorded, tmp_path, capsys, monkeypatch):
    """Before: its hash was null, and a --config replay after the data changed differed
    without a word."""
    import shutil

    from hri_bench.data.datasets import open_dataset

    root = tmp_path / "data"
    shutil.copytree(recorded[0] / "synthetic-hanger-v0", root / "synthetic-hanger-v0")
    monkeypatch.setenv("HRI_BENCH_DATASETS", str(root))
    dataset = open_dataset("synthetic-hanger", root)
    argv = ["--agents", "learner", "--runs", "2", "--episodes", "2", "--no-progress"]
    assert main(["study", "hanger", "--population", "recorded-irl:synthetic-hanger", *argv,
                 "--out", str(tmp_path / "a")]) == 0
    info = json.loads((tmp_path / "a" / "summary.json").read_text())["population_info"]
    assert info["hash"] == dataset.content_hash() and info["fit"] == "irl"
    assert info["dataset_id"] == "synthetic-hanger-v0" and info["members"] == 4
    capsys.readouterr()
    config = ["study", "--config", str(tmp_path / "a" / "summary.json"), "--no-progress"]
    assert main([*config, "--out", str(tmp_path / "b")]) == 0
    assert "warning" not in capsys.readouterr().err  # the same data: nothing to say
    (root / "synthetic-hanger-v0" / "sessions" / "s0003" / "episode-0004.parquet").unlink()
    assert main([*config, "--out", str(tmp_path / "c")]) == 0
    err = capsys.readouterr().err
    assert ("warning: population 'recorded-irl:synthetic-hanger': the recorded dataset's "
            f"finished sessions changed since the replayed study (content {info['hash']} "
            f"then, {open_dataset('synthetic-hanger', root).content_hash()} now)") in err


def test_fit_says_why_irl_scores_below_uniform(tmp_path, capsys):
    """The docs' passive scripted humans: irl's held-out log-likelihood is below uniform's
    because of a few waits it finds near-impossible; the output says so, with the numbers
    (before: the table alone, and uniform's accuracy was the share of waits)."""
    cfg = StudyConfig("hanger", agents=("learner",), runs=5, episodes=4, preference="all",
                      human_passive=0.1, seed=3)
    record_study(cfg, "syn", root=tmp_path)
    assert main(["dataset", "fit", "syn", "--data", str(tmp_path)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "uniform held-out log-likelihood per step -1.2969, accuracy 0.300 (of a uniform " in out
    assert "irl held-out log-likelihood per step -1.7099" in out
    assert ("irl scores below uniform (-1.7099 < -1.2969): 2 of the 26 held-out steps get less "
            "than 0.001 from it (2 of them waits; worst -32.51), 90% of its total; on the other "
            "24 it scores -0.1779, uniform -1.3090.") in out
    assert "τ_H = 25" in out and "bc scores below" not in out


def test_unfinished_sessions_are_flagged(recorded, tmp_path, capsys, monkeypatch):
    """A session left 'running' by a killed recorder: show flags it, fit and export leave
    it out and say so; a recording stopped by Ctrl-C exits 130 marking its sessions."""
    import shutil

    root = tmp_path / "data"
    shutil.copytree(recorded[0] / "synthetic-hanger-v0", root / "synthetic-hanger-v0")
    meta = root / "synthetic-hanger-v0" / "sessions" / "s0005" / "session.json"
    meta.write_text(meta.read_text().replace('"complete"', '"running"'))
    assert main(["dataset", "show", "synthetic-hanger", "--data", str(root)]) == 0
    out = capsys.readouterr().out
    assert "4 participants, 16 episodes" in out and "s0005 #4: interrupted, 4/4 episodes" in out
    assert "1 unfinished session(s)" in out
    assert main(["dataset", "fit", "synthetic-hanger", "--data", str(root)]) == 0
    out = capsys.readouterr().out
    assert "the fit leaves out 1 unfinished session(s): s0005 (interrupted, 4/4 episodes)" in out
    assert "fitted to 3 training participants; 1 held out" in out
    assert main(["dataset", "export", "synthetic-hanger", "--data", str(root), "--out",
                 str(tmp_path / "x.parquet")]) == 0
    assert "the export leaves out 1 unfinished session(s)" in capsys.readouterr().out

    from hri_bench.cli import people

    def stopped(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(people, "record_study", stopped)
    assert main(["dataset", "record", "hanger", "--dataset", "x", "--data", str(root)]) == 130
    assert "marked 'interrupted'" in capsys.readouterr().err


def _enospc(*args, **kwargs):
    raise OSError(28, "No space left on device")


@pytest.mark.parametrize("argv, target, patch", [
    (["dataset", "export", "synthetic-hanger", "--out", "OUT/x.parquet"], "OUT/x.parquet",
     ("pyarrow.parquet.write_table", _enospc)),
    (["dataset", "export", "synthetic-hanger", "--format", "minari", "--out", "OUT/m"], "OUT/m",
     ("minari.create_dataset_from_buffers", _enospc)),
    (["dataset", "fit", "synthetic-hanger", "--out", "OUT/models"], "OUT/models/bc.npz",
     ("numpy.savez", _enospc)),
    (["replay", "synthetic-hanger", "--participant", "s0001", "--frames", "OUT/f"], "OUT/f",
     ("hri_bench.data.replay.png", _enospc)),
    (["dataset", "record", "hanger", "--dataset", "new", "--sessions", "2", "--episodes", "2"],
     "DATA/new-v0/sessions/s0001/episode-0001.parquet",
     ("pyarrow.parquet.write_table", _enospc)),
])
def test_a_full_disk_is_one_line_exit_1(recorded, tmp_path, capsys, monkeypatch, argv, target,
                                        patch):
    """Before: an OSError traceback."""
    if "minari" in patch[0]:
        pytest.importorskip("minari")
    import shutil

    root = tmp_path / "data"
    shutil.copytree(recorded[0] / "synthetic-hanger-v0", root / "synthetic-hanger-v0")
    monkeypatch.setattr(*patch)
    argv = [a.replace("OUT", str(tmp_path / "out")) for a in argv]
    code = main([*argv, "--data", str(root)])
    err = capsys.readouterr().err
    assert code == 1 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    where = target.replace("OUT", str(tmp_path / "out")).replace("DATA", str(root))
    assert f"cannot write {where}" in err and "No space left on device" in err
    if argv[0] == "dataset" and argv[1] == "record":
        status = {json.loads(p.read_text())["status"]
                  for p in (root / "new-v0" / "sessions").glob("*/session.json")}
        assert status == {"failed"}


@pytest.mark.parametrize("argv, flag", [
    (["dataset", "fit", "synthetic-hanger", "--out", "FILE"], "--out"),
    (["dataset", "export", "synthetic-hanger", "--format", "minari", "--out", "FILE"], "--out"),
    (["dataset", "export", "synthetic-hanger", "--out", "DIR"], "--out"),
    (["replay", "synthetic-hanger", "--frames", "FILE"], "--frames"),
])
def test_an_output_path_of_the_wrong_kind_exits_2(recorded, tmp_path, capsys, argv, flag):
    (tmp_path / "file").write_text("x")
    argv = [a.replace("FILE", str(tmp_path / "file")).replace("DIR", str(tmp_path))
            for a in argv]
    with pytest.raises(SystemExit) as exit_:
        main([*argv, "--data", str(recorded[0])])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and f"argument {flag}: " in err and "Traceback" not in err
    assert (tmp_path / "file").read_text() == "x"


def test_unwritable_outputs_are_one_line_exit_1(recorded, tmp_path, capsys):
    """/proc (and, for an ordinary user, a read-only folder) cannot take a new file."""
    root = str(recorded[0])
    for argv in (["dataset", "fit", "synthetic-hanger", "--out", "/proc/hri-x"],
                 ["dataset", "export", "synthetic-hanger", "--out", "/proc/hri-x.parquet"],
                 ["replay", "synthetic-hanger", "--participant", "s0001", "--frames",
                  "/proc/hri-x"],
                 ["dataset", "record", "hanger", "--dataset", "x", "--sessions", "1",
                  "--episodes", "1"]):
        data = "/proc/hri-data" if argv[1] == "record" else root
        code = main([*argv, "--data", data])
        err = capsys.readouterr().err
        assert code == 1 and "cannot write /proc/hri-" in err and "Traceback" not in err, argv
