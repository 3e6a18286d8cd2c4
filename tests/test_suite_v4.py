"""Suite v4 (issue 41): privilege decides who is ranked, intervals hold the references'
noise and admit ties, references are evidence too, the verifier draws the seed, the pilot
reproduces, and the figures survive any runs scale.
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from benchmarks.suite_power import pilot_v3
from hri_bench.cli import main
from hri_bench.report import ranking
from hri_bench.run.isolation import IN_PROCESS
from hri_bench.suite import running, submission, tracks
from hri_bench.suite.results_v4 import _iqm_line

pytestmark = pytest.mark.xdist_group("suite")

CHEATS = "tests.helpers_cheats"
TRACKS = "wheel-test-inconsistent,hanger-paper"


def _suite(out, *agents, scale="0.05", tracks_=TRACKS):
    assert main(["suite", "--out", str(out), "--tracks", tracks_, "--runs-scale", scale,
                 "--agents", ",".join(agents), "--no-progress"]) == 0
    return submission.load(out / "results.json")


@pytest.fixture(scope="module")
def v4_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("suite4") / "s"
    _suite(out, "learner", "goalfilter", "oracle", f"{CHEATS}:ReadsFrames",
           f"{CHEATS}:DeclaresPrivileged")
    return out


# ------------------------------------------------------------------ privilege (item 2)
def test_what_an_agent_declares_decides_whether_it_is_ranked(v4_dir):
    doc = submission.load(v4_dir / "results.json")
    assert doc["schema_version"] == "3" and submission.validate(doc) == []
    privileged, reader = f"{CHEATS}:DeclaresPrivileged", f"{CHEATS}:ReadsFrames"
    assert doc["roles"][privileged] == {"sees_intention": True, "knows_human": False,
                                        "reference": True}
    assert doc["roles"]["oracle"]["reference"] and not doc["roles"][reader]["reference"]
    ranks = doc["aggregate"]["ranks"]
    assert privileged not in ranks and "oracle" not in ranks and "informed" not in ranks
    assert reader in ranks and ranks[reader] == max(ranks.values())  # blind: it waits
    suite_doc = json.loads((v4_dir / "suite.json").read_text())
    assert reader in suite_doc["intention_blind"] and privileged not in suite_doc["agents"]
    assert privileged not in suite_doc["intention_blind"] and privileged in \
        suite_doc["references"]
    board = (v4_dir / "leaderboard.md").read_text()
    refs = board[board.index("### References"):board.index("### Every pair")]
    assert f"`{privileged}` (ref., sees ι)" in refs and "`oracle` (ref., sees ι)" in refs
    # A recorded role its code does not declare is refused.
    forged = copy.deepcopy(doc)
    forged["roles"][privileged]["reference"] = False
    assert any("its code declares" in p for p in submission.validate(forged))


# ------------------------------------------------------------------ intervals (item 6)
def test_the_floor_scores_zero_and_the_reference_one_in_every_replicate(v4_dir):
    doc = submission.load(v4_dir / "results.json")
    per = doc["aggregate"]["headline"]["agents"]
    assert per["passive"]["mean"] == 0.0 and per["passive"]["ci95"] == [0.0, 0.0]
    track = doc["statistics"]["0"]["wheel-test-inconsistent"]["agents"]["qmdp"]["normalised"]
    assert track["mean"] == pytest.approx(1.0) and track["ci95"] == pytest.approx([1.0, 1.0])
    assert "| `passive` (floor) | 0.000 [0.000, 0.000]" in (v4_dir / "leaderboard.md").read_text()


def test_re_estimating_the_reference_widens_the_interval_it_once_treated_as_exact():
    rng = np.random.default_rng(0)
    humans = np.repeat(np.arange(20), 4)
    effect = rng.normal(0, 1.0, 20)[humans]
    ref, floor = -1.0 + effect + rng.normal(0, 0.3, 80), -3.0 + rng.normal(0, 0.3, 80)
    x = -1.2 + effect + rng.normal(0, 0.3, 80)
    fixed = ranking.Track("t", {"a": ranking.normalise(x, ref.mean(), floor.mean())},
                          humans.tolist(), 0)
    noisy = ranking.Track("t", {"a": x, "f": floor}, humans.tolist(), 0, reference=ref,
                          floor=floor)
    a, b = ranking.summarise(fixed, "a"), ranking.summarise(noisy, "a")
    assert b["mean"] == pytest.approx(a["mean"])
    assert np.diff(b["ci95"])[0] < np.diff(a["ci95"])[0] / 2  # the human effect is shared
    assert ranking.summarise(noisy, "f")["ci95"] == [0.0, 0.0]


def test_agents_no_interval_separates_share_a_rank():
    def pair(lo):
        return {"difference": {"ci95": [lo, lo + 1.0]}}

    order = ["a", "b", "c", "d"]
    pairs = {x: {y: pair(-0.5) for y in order if y != x} for x in order}
    pairs["a"]["c"] = pairs["a"]["d"] = pairs["b"]["d"] = pair(0.1)  # a > c, a > d, b > d
    assert ranking.shared_ranks(order, pairs) == {"a": 1, "b": 1, "c": 2, "d": 3}


def test_worse_than_the_floor_counts_humans_and_the_iqm_line_names_flips():
    t = ranking.Track("t", {"a": np.array([0.0, 0.0, 2.0, 2.0]), "p": np.ones(4)},
                      [0, 0, 1, 1], 0)
    assert ranking.worse_than_floor([t], "a", "p") == 0.5
    block = {"a": {"iqm": 0.1}, "b": {"iqm": 0.3}}
    assert "is above `b` by the mean but below it by the IQM" in " ".join(
        _iqm_line(["a", "b"], block, lambda n: f"`{n}`"))
    assert _iqm_line(["b", "a"], block, str)[0].startswith("The IQM orders")


# ------------------------------------------------------------------ evidence (item 7)
def _forge_blind(doc):
    bad = copy.deepcopy(doc)
    block = bad["runs"]["0"]["hanger-paper"]
    block["blind"] = [[round(v - 0.5, 6) for v in row] for row in block["blind"]]
    bad["statistics"], bad["aggregate"] = submission.compute(bad)
    return bad


@pytest.mark.parametrize("forged_name", ["a-forged.json", "z-forged.json"])
def test_a_forged_reference_fails_validation_and_is_refused_beside_a_genuine_file(
        v4_dir, tmp_path, capsys, forged_name):
    doc = submission.load(v4_dir / "results.json")
    folder = tmp_path / "subs"
    folder.mkdir()
    (folder / "m-genuine.json").write_text(json.dumps(doc))
    (folder / forged_name).write_text(json.dumps(_forge_blind(doc)))
    assert main(["validate", str(folder / forged_name)]) == 1
    assert "a forged reference" in capsys.readouterr().err
    assert main(["leaderboard", str(folder), "--out", str(tmp_path / "board")]) == 1
    err = capsys.readouterr().err
    assert f"{forged_name}: refused" in err and "m-genuine.json: refused" not in err
    board = (tmp_path / "board" / "leaderboard.md").read_text()
    assert f"`{forged_name}`" not in board and "`m-genuine.json`" in board


def test_a_forged_simulated_reference_fails_the_replay(v4_dir, capsys, tmp_path):
    doc = submission.load(v4_dir / "results.json")
    bad = copy.deepcopy(doc)
    entry = bad["runs"]["0"]["wheel-test-inconsistent"]["agents"]["qmdp"]
    entry["reward"] = [[round(v + 0.01, 6) for v in row] for row in entry["reward"]]
    bad["statistics"], bad["aggregate"] = submission.compute(bad)
    assert submission.validate(bad) == []  # consistent: only the replay can tell
    path = tmp_path / "forged.json"
    path.write_text(json.dumps(bad))
    assert main(["validate", str(path), "--replay", "3", "--replay-seed", "1"]) == 1
    assert ".agents.qmdp.reward[" in capsys.readouterr().err


def test_a_replay_that_cannot_vouch_for_every_agent_fails_naming_it(v4_dir, tmp_path, capsys):
    doc = submission.load(v4_dir / "results.json")
    other = copy.deepcopy(doc)
    other["agents"]["learner"]["version"] = "0.0.0"
    path = tmp_path / "old.json"
    path.write_text(json.dumps(other))
    assert main(["validate", str(path), "--replay", "1", "--replay-seed", "0"]) == 1
    captured = capsys.readouterr()
    assert "not replayed: agent 'learner'" in captured.out
    assert "REPLAY INCOMPLETE" in captured.err and "'learner'" in captured.err


def test_files_whose_humans_disagree_are_refused(v4_dir):
    from hri_bench.suite.audit import conflicts

    doc = submission.load(v4_dir / "results.json")
    other = copy.deepcopy(doc)
    humans = other["runs"]["0"]["wheel-test-inconsistent"]["humans"]
    humans[0], humans[1] = humans[1], humans[0]
    found = conflicts({"a.json": doc, "b.json": other})
    assert any("disagree on the humans of seed 0, track wheel-test-inconsistent" in c.text
               for c in found)


# ------------------------------------------------------------------ the fresh seed (item 3)
def test_a_file_whose_agent_read_its_way_up_fails_the_fresh_check(tmp_path, monkeypatch,
                                                                  capsys):
    # Made as the benchmark once made agents: in its own process, where the cheat reads ι.
    monkeypatch.setenv(IN_PROCESS, "1")
    doc = _suite(tmp_path / "cheat", "learner", f"{CHEATS}:ReadsFrames")
    monkeypatch.delenv(IN_PROCESS)
    head = doc["aggregate"]["headline"]["agents"]
    assert head[f"{CHEATS}:ReadsFrames"]["mean"] > head["learner"]["mean"]  # it read ι
    path = tmp_path / "cheat" / "results.json"
    assert main(["validate", str(path), "--fresh", "--fresh-seed", "12345"]) == 1
    captured = capsys.readouterr()
    assert "FRESH CHECK FAILED for 'tests.helpers_cheats:ReadsFrames'" in captured.err
    lines = [x for x in captured.out.splitlines() if "OUTSIDE" in x]
    assert len(lines) == 1 and CHEATS in lines[0]
    assert "fresh seed 12345" in captured.err


# ------------------------------------------------------------------ the pilot (item 5)
@pytest.mark.parametrize("track", ["hanger-paper", "hanger-test-misspecified"])
def test_the_frozen_pilot_is_what_the_shipped_pilot_prints(track):
    assert pilot_v3(4, 1000, 1, track, "4", quiet=True) == {track: tracks.PILOT_V4[track]}


@pytest.mark.slow
def test_the_whole_frozen_pilot_is_what_the_shipped_pilot_prints():
    assert pilot_v3(4, 1000, 2, None, "4", quiet=True) == tracks.PILOT_V4


def test_tracks_that_miss_their_power_target_are_named(v4_dir):
    missed = [n for n, t in tracks.TRACKS_V4.items()
              if tracks.detectable_v3(t.pilot_between, t.pilot_within, t.humans, t.blocks)
              > tracks.DELTA_V3]
    assert "wheel-test-scripted" in missed and "hanger-paper" not in missed
    board = (v4_dir / "leaderboard.md").read_text()
    power = board[board.index("## Power"):]
    assert "Tracks that miss it: wheel-test-inconsistent" in power


# ------------------------------------------------------------------ figures (item 8)
def test_a_suite_at_the_smallest_runs_scale_writes_its_figures(tmp_path):
    out = tmp_path / "tiny"
    _suite(out, "learner", "maxent", scale="5e-324",
           tracks_="wheel-test-inconsistent,hanger-test-scripted,hanger-paper")
    assert (out / "ranking.png").stat().st_size > 0
    assert all((out / f"{t}.png").stat().st_size > 0 for t in
               ("wheel-test-inconsistent", "hanger-test-scripted", "hanger-paper"))


def test_the_track_figure_clips_an_agent_far_off_and_says_so():
    def entry(curves):
        return {"regret_reported": False, "agents": {
            a: {"reward": {"per_episode": {"mean": c}}} for a, c in curves.items()}}

    near = {a: [-1.0 + 0.1 * i, -0.8, -0.6 + 0.05 * i, -0.5] for i, a in enumerate("abcde")}
    limits, clipped = running.axis_range(entry({**near, "maxent": [-20.0, -19.0, -18.5,
                                                                   -18.0]}))
    assert clipped == {"maxent": -20.0} and -2.0 < limits[0] < -1.0 and limits[1] < 0.0
    assert running.axis_range(entry({"a": [-1.0, -0.5], "b": [-0.9, -0.4]})) == (None, {})
