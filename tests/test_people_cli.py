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
