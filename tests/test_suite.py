"""hri-bench suite v1: the versioned tracks, suite.json/leaderboard.md/figures, determinism.

Suite v2 (the default) has its own tests in tests/test_suite_v2.py; v1 stays selectable and
writes what it always wrote.
"""

import hashlib
import json
import warnings

import numpy as np
import pytest

from hri_bench.cli import main
from hri_bench.suite import (
    INTENTION_BLIND,
    TRACKS,
    episodes_to_converge,
    run_suite,
    select_tracks,
)
from hri_envs.errors import ConfigError

TRACK_KEYS = {"description", "scenario", "runs", "episodes", "settings", "regret",
              "regret_reported", "agents", "failed_agents"}
AGENT_KEYS = {"reward", "regret", "episodes_to_converge", "wrong_rate", "passive_rate",
              "truncation_rate"}
STAT_KEYS = {"mean", "ci95", "iqm", "iqm_ci95", "per_episode"}


# One xdist worker runs every test of this module, so the module-scoped suite run below is
# made once (make test passes --dist loadgroup).
pytestmark = pytest.mark.xdist_group("suite")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """Every track at 10 runs (scale 0.02), serial."""
    out = tmp_path_factory.mktemp("suite")
    return out, run_suite(out, runs_scale=0.02, version="1")


def test_the_suite_has_both_scenarios_times_five_kinds():
    kinds = {"paper", "passive", "drift", "turnback", "heldout"}
    assert set(TRACKS) == {f"{sc}-{k}" for sc in ("hanger", "wheel") for k in kinds}


def test_suite_writes_the_documented_files(tiny):
    out, doc = tiny
    on_disk = json.loads((out / "suite.json").read_text())
    assert on_disk == doc
    assert set(doc) == {"suite_version", "seed", "runs_scale", "agents", "converged_threshold",
                        "references", "tracks"}
    assert list(doc["tracks"]) == list(TRACKS)
    for name, tr in doc["tracks"].items():
        assert set(tr) == TRACK_KEYS
        assert (out / f"{name}.png").stat().st_size > 0
        assert tr["runs"] == 10
        for agent, a in tr["agents"].items():
            assert set(a) == AGENT_KEYS
            assert set(a["reward"]) == STAT_KEYS
            lo, hi = a["reward"]["ci95"]
            assert lo <= a["reward"]["mean"] + 1e-9 and a["reward"]["mean"] <= hi + 1e-9
            assert len(a["reward"]["per_episode"]["mean"]) == tr["episodes"]
            assert (a["regret"] is None) == (not tr["regret_reported"]), (name, agent)
    log = json.loads((out / "suite_log.json").read_text())
    assert log["wall_time_s"] > 0 and set(log["tracks_wall_time_s"]) == set(TRACKS)


#: suite.json and leaderboard.md of the tiny v1 suite above, as the code before suite v2
#: wrote them (commit 8829a29): v1 stays reproducible byte for byte.
V1_SHA256 = {
    "suite.json": "775781b762a5d0110e51fde7004ec1e4e62e15907a330df2e2eceb202ed93832",
    "leaderboard.md": "fafe075a21729a9b6f1609c5cd7e1ee259590088311ef6554353a183f816b472",
}


def test_v1_writes_what_it_wrote_before_v2_byte_for_byte(tiny):
    out, _ = tiny
    assert {name: hashlib.sha256((out / name).read_bytes()).hexdigest()
            for name in V1_SHA256} == V1_SHA256


def test_references_and_regret_where_blind_fits(tiny):
    _, doc = tiny
    tracks = doc["tracks"]
    for sc, r0 in (("hanger", -0.33), ("wheel", -0.25)):
        paper = tracks[f"{sc}-paper"]["agents"]
        # A deterministic human: blind gets exactly its expectation, informed r0 better.
        assert paper["blind"]["regret"]["mean"] == pytest.approx(0.0, abs=1e-12)
        assert paper["informed"]["regret"]["mean"] == pytest.approx(r0, abs=1e-12)
        # Runs with their own humans: no blind/informed agents, regret from the exact value.
        assert {"blind", "informed"}.isdisjoint(tracks[f"{sc}-drift"]["agents"])
        assert tracks[f"{sc}-drift"]["regret_reported"]
        held = tracks[f"{sc}-heldout"]
        assert not held["regret_reported"] and "Boltzmann" in held["regret"]
        assert {"blind", "informed"}.isdisjoint(held["agents"])


def test_blind_is_never_beaten_beyond_its_ci_by_an_intention_blind_agent(tiny):
    _, doc = tiny
    checked = 0
    for name, tr in doc["tracks"].items():
        if not tr["regret_reported"]:
            continue
        for agent in (a for a in INTENTION_BLIND if a in tr["agents"]):
            high = tr["agents"][agent]["regret"]["ci95"][1]
            assert high >= 0.0, (name, agent, tr["agents"][agent]["regret"])
            checked += 1
    assert checked == 8 * 4  # learner, imitator, maxent, passive


def test_leaderboard_sorts_by_regret_and_explains_na(tiny):
    out, doc = tiny
    text = (out / "leaderboard.md").read_text()
    assert "information bound" in text and "ceiling for intention-blind robots" in text
    overview = text.split("## Overview")[1].split("## ")[0]
    assert sum(line.startswith(f"| {t} |") for t in TRACKS for line in overview.splitlines()) \
        == len(TRACKS)
    section = text.split("## wheel-turnback")[1].split("## ")[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    names = [r.split("`")[1] for r in rows]
    regrets = [doc["tracks"]["wheel-turnback"]["agents"][n]["regret"]["mean"] for n in names]
    assert regrets == sorted(regrets) and len(names) == 7
    held = text.split("## hanger-heldout")[1].split("## ")[0]
    assert "Regret n/a:" in held and "| n/a |" in held


def test_serial_and_two_jobs_give_byte_identical_suite_json(tmp_path):
    kw = {"tracks": "wheel-drift,hanger-heldout", "runs_scale": 0.01,
          "agents": ("learner", "passive")}
    run_suite(tmp_path / "a", version="1", **kw)
    run_suite(tmp_path / "b", jobs=2, executor="process", version="1", **kw)
    assert (tmp_path / "a" / "suite.json").read_bytes() == \
        (tmp_path / "b" / "suite.json").read_bytes()


def test_unknown_track_errors_before_any_simulation(tmp_path, monkeypatch, capsys):
    def boom(*args, **kwargs):
        raise AssertionError("simulated")

    monkeypatch.setattr("hri_bench.suite.running.run_study", boom)
    with pytest.raises(SystemExit) as exc:
        main(["suite", "--out", str(tmp_path / "x"), "--suite-version", "1", "--tracks",
              "wheel-paper,wheel-noisy"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "unknown track(s) wheel-noisy of suite v1; allowed: hanger-paper" in err
    assert not (tmp_path / "x").exists()
    with pytest.raises(ConfigError, match="allowed: hanger-paper") as info:
        run_suite(tmp_path / "y", tracks=["hanger-paper", "nope"], version="1")
    assert info.value.field == "tracks"
    with pytest.raises(ConfigError, match="runs_scale must be a number > 0"):
        run_suite(tmp_path / "y", runs_scale=0.0)
    with pytest.raises(ConfigError, match="unknown agent 'nobody'"):
        run_suite(tmp_path / "y", agents=("learner", "nobody"))
    assert not (tmp_path / "y").exists()


def test_select_tracks_keeps_the_suite_order():
    assert [t.name for t in select_tracks("wheel-paper,hanger-drift", "1")] == \
        ["hanger-drift", "wheel-paper"]


def test_episodes_to_converge_by_hand():
    regret = np.array([[0.5, 0.2, 0.0, 0.1, 0.0],
                       [0.5, 0.0, 0.1, 0.0, 0.0]])  # means 0.5, 0.1, 0.05, 0.05, 0
    assert episodes_to_converge(regret) == 3
    assert episodes_to_converge(np.zeros((2, 3))) == 1
    assert episodes_to_converge(np.array([[0.0, 0.0, 0.2]])) is None


def test_suite_cli_writes_files_and_reports_wall_time(tmp_path, capsys):
    out = tmp_path / "s"
    code = main(["suite", "--out", str(out), "--suite-version", "1", "--tracks", "wheel-paper",
                 "--runs-scale", "0.005", "--agents", "learner,passive", "--no-progress"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "suite v1: 1 tracks in" in printed
    doc = json.loads((out / "suite.json").read_text())
    assert list(doc["tracks"]) == ["wheel-paper"] and doc["agents"] == ["learner", "passive"]
    assert set(doc["tracks"]["wheel-paper"]["agents"]) == {"learner", "passive", "informed",
                                                          "blind"}
    assert (out / "leaderboard.md").exists() and (out / "wheel-paper.png").exists()


def test_an_agent_that_raises_is_left_out_and_the_others_are_written(tmp_path, capsys):
    # It once ended the suite with a ZeroDivisionError traceback and no files (issue 24).
    out = tmp_path / "s"
    bad = "tests.helpers_agents:DividesByZero"
    code = main(["suite", "--out", str(out), "--suite-version", "1", "--tracks", "wheel-paper",
                 "--runs-scale", "0.005", "--agents", f"passive,{bad}", "--no-progress"])
    assert code == 1
    err = capsys.readouterr().err
    assert bad in err and "errors.log" in err and "Traceback" not in err
    track = json.loads((out / "suite.json").read_text())["tracks"]["wheel-paper"]
    assert track["failed_agents"] == [bad]
    assert set(track["agents"]) == {"passive", "informed", "blind"}
    log = (out / "errors.log").read_text()
    assert f"track wheel-paper: agent {bad!r} raised" in log and "ZeroDivisionError" in log
    board = (out / "leaderboard.md").read_text()
    assert "raised" in board and f"`{bad}`" in board
    assert (out / "wheel-paper.png").exists()
    # A track on which every agent raised still gets its files, and no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["suite", "--out", str(tmp_path / "all"), "--suite-version", "1",
                     "--tracks", "wheel-drift", "--runs-scale", "0.005", "--agents", bad,
                     "--no-progress"]) == 1
    assert json.loads((tmp_path / "all" / "suite.json").read_text())["tracks"]["wheel-drift"][
        "agents"] == {}
    # A later suite in the same folder (--overwrite: it is not empty) without failures leaves
    # no stale errors.log.
    assert main(["suite", "--out", str(out), "--suite-version", "1", "--tracks", "wheel-paper",
                 "--runs-scale", "0.005", "--agents", "passive", "--no-progress",
                 "--overwrite"]) == 0
    assert not (out / "errors.log").exists()


@pytest.mark.parametrize("agent, message", [
    ("nosuch.mod:Foo", "cannot import agent 'nosuch.mod:Foo': ModuleNotFoundError"),
    ("tests.helpers_agents:NotAnAgent",
     "not a subclass of agents.protocol.Agent or agents.protocol.BatchAgent"),
])
def test_an_agent_that_is_not_one_is_refused_before_any_simulation(agent, message, tmp_path,
                                                                    monkeypatch, capsys):
    def boom(*args, **kwargs):
        raise AssertionError("simulated")

    monkeypatch.setattr("hri_bench.suite.running.run_study", boom)
    with pytest.raises(SystemExit) as exc:
        main(["suite", "--out", str(tmp_path / "x"), "--agents", f"learner,{agent}"])
    assert exc.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
