"""hri-bench suite v3 (the default): normalised per-track scores, humans as a sample
(two-stage bootstrap), paired wins/ties/losses, splits that do not leak, merges that cannot
be forged silently (docs/results.md, "Ranking (suite v3)")."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from hri_bench import suite
from hri_bench.cli import main
from hri_bench.report import aggregate, ranking
from hri_bench.suite import DEFAULT_AGENTS_V3, TRACKS_V3, audit, merged, submission, track_config
from hri_envs.errors import ConfigError
from hri_envs.humans.splits import MIXTURES

pytestmark = pytest.mark.xdist_group("suite")


def _tracks(scores_by_track, humans=40, runs=4, headline=True):
    """ranking.Track objects from per-track {agent: (H, R) scores}."""
    ids = np.repeat(np.arange(humans), runs).tolist()
    return [ranking.Track(name, {a: np.asarray(v, float).ravel() for a, v in by.items()},
                          ids, 0, headline=headline) for name, by in scores_by_track.items()]


def test_the_headline_follows_the_paired_track_results_where_the_pooled_iqm_did_not():
    """The issue's case: agent A beats B clearly on seven of eight tracks (B fails badly on a
    fifth of the humans there, a tail the IQM trims) and loses the eighth by a little. The
    old cross-track line (IQM of pooled run scores) ranks B first; the headline ranks A
    first, and its wins/ties/losses say why."""
    rng = np.random.default_rng(0)
    by_track = {}
    for t in range(8):
        noise_a, noise_b = rng.normal(0, 0.02, (2, 40, 4))
        if t < 7:
            bad = np.zeros((40, 1), bool)
            bad[:8] = True  # a fifth of the humans: B fails on them in every run
            b = np.where(bad, -3.0, 0.9) + noise_b
            a = 0.85 + noise_a
        else:
            a, b = 0.87 + noise_a, 0.9 + noise_b
        by_track[f"track-{t}"] = {"A": a, "B": b}
    out = ranking.headline(_tracks(by_track), ["A", "B"])
    assert out["order"] == ["A", "B"]
    pair = out["pairs"]["A"]["B"]
    assert (pair["wins"], pair["ties"], pair["losses"]) == (7, 0, 1)
    assert pair["difference"]["ci95"][0] > 0
    back = out["pairs"]["B"]["A"]
    assert (back["wins"], back["ties"], back["losses"]) == (1, 0, 7)
    # The old line: the IQM of every run of every track pooled, which ranks B first.
    old = aggregate.aggregate({"0": {t: {a: v.ravel() for a, v in by.items()}
                                     for t, by in by_track.items()}}, ["A", "B"], 0)
    assert old["agents"]["B"]["iqm"] > old["agents"]["A"]["iqm"]


def test_humans_are_resampled_so_a_human_effect_widens_the_interval():
    """Humans who differ, runs that do not: resampling runs alone (humans fixed) gives an
    interval of width 0; the two-stage bootstrap does not, and covers the humans' mean."""
    offsets = np.linspace(-0.5, 0.5, 40)
    scores = np.repeat(offsets, 4)
    track = _tracks({"t": {"A": scores.reshape(40, 4)}})[0]
    s = ranking.summarise(track, "A")
    assert s["mean"] == pytest.approx(0.0, abs=1e-12)
    lo, hi = s["ci95"]
    assert lo < -0.05 and hi > 0.05  # about ±0.09: sd 0.29 / √40 × 1.96
    # Each replicate is a weighting of the runs that sums to one.
    w, big = track.weights()
    assert np.allclose(big.sum(1), 1.0) and w.sum() == pytest.approx(1.0)
    # The second stage resamples runs within a human.
    within = _tracks({"t": {"A": np.tile([0.0, 1.0], (40, 2))}})[0]
    lo, hi = ranking.summarise(within, "A")["ci95"]
    assert lo < 0.49 < 0.51 < hi


def test_a_paired_difference_is_resampled_on_the_same_humans_and_runs():
    base = np.random.default_rng(1).normal(0, 1, (40, 4))  # humans differ a lot
    track = _tracks({"t": {"A": base + 0.05, "B": base}})[0]
    c = ranking.compare(track, "A", "B")
    assert c["difference"]["mean"] == pytest.approx(0.05)
    assert c["difference"]["ci95"] == pytest.approx([0.05, 0.05])  # the humans cancel
    assert c["outcome"] == "win" and c["improvement"]["mean"] == 1.0


def test_normalised_scores_and_their_range():
    assert ranking.normalise(np.array([-1.0, -0.3, -0.65]), -0.3, -1.0).tolist() == \
        pytest.approx([0.0, 1.0, 0.5])
    with pytest.raises(ConfigError, match="at least 0.05 above the floor"):
        ranking.normalise(np.zeros(2), -0.99, -1.0)
    w = np.full(8, 1 / 8)
    assert ranking.weighted_iqm(np.arange(8.0), w) == pytest.approx(3.5)
    assert ranking.weighted_iqm(np.array([0, 0, 0, 100.0]), np.full(4, 0.25)) == 0.0


def test_v3_s_headline_tracks_partition_the_test_humans():
    assert "3" in suite.SUITE_VERSIONS
    head = [t for t in TRACKS_V3.values() if t.headline]
    assert len(head) == 8 and all(not t.name.endswith("paper") for t in head)
    for sc in ("hanger", "wheel"):
        seen = []
        for t in (t for t in head if t.scenario == sc):
            spec = MIXTURES[(dict(t.settings)["population"], sc)]
            prints = spec.fingerprints()
            assert len(set(prints)) == t.humans >= 32
            assert t.runs == t.humans * t.blocks and t.blocks >= 2
            seen += prints
        assert sorted(seen) == sorted(MIXTURES[("test-v2", sc)].fingerprints())
    for t in TRACKS_V3.values():  # the floor and the reachable reference on every track
        agents = track_config(t, DEFAULT_AGENTS_V3, version="3").agents
        assert {"passive", "informed"} <= set(agents)
        assert ("blind" in agents) == t.name.endswith("paper") != ("qmdp" in agents)


def test_power_picks_the_fewest_runs_per_human_that_detect_the_target():
    # √((0.04² + 0.25²/R) / 40) · 2.8016 ≤ 0.05 first at R = 6 (0.0486), not at 5 (0.0526).
    assert suite.detectable_v3(0.04, 0.25, 40, 6) == pytest.approx(0.0486, abs=1e-4)
    assert suite.detectable_v3(0.04, 0.25, 40, 5) == pytest.approx(0.0526, abs=1e-4)
    assert suite.power_v3(0.04, 0.25, 40) == 6
    assert suite.power_v3(0.0, 0.05, 40) == suite.MIN_BLOCKS
    # Out of reach (the humans' spread alone detects 2.8016 · 0.3 / √40 = 0.133): two runs
    # per human already come within 5 % of it (0.137), more would buy nothing.
    assert suite.power_v3(0.3, 0.1, 40) == suite.MIN_BLOCKS
    # Out of reach too (0.053), but the runs' spread matters: as many as allowed.
    assert suite.power_v3(0.12, 0.3, 40) == suite.MAX_BLOCKS
    for t in TRACKS_V3.values():  # every track: its pilot's spreads give its runs
        n = suite.power_v3(t.pilot_between, t.pilot_within, t.humans)
        assert t.runs == (n if t.humans == 1 else n * t.humans), t.name


# --------------------------------------------------------------------------- a small v3 suite
@pytest.fixture(scope="module")
def v3_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("suite3") / "s"
    assert main(["suite", "--out", str(out), "--tracks", "wheel-test-inconsistent,hanger-paper",
                 "--runs-scale", "0.05", "--agents", "learner,goalfilter", "--no-progress",
                 "--suite-version", "3"]) == 0
    return out


def test_a_v3_results_file_validates_and_leads_with_the_headline(v3_dir):
    doc = submission.load(v3_dir / "results.json")
    assert doc["schema_version"] == "2" and submission.validate(doc) == []
    block = doc["runs"]["0"]["wheel-test-inconsistent"]
    assert len(block["humans"]) == len(block["agents"]["learner"]["reward"])
    assert doc["tracks"]["wheel-test-inconsistent"]["headline"] is True
    head = doc["aggregate"]["headline"]
    assert head["tracks"] == ["wheel-test-inconsistent"]
    assert set(head["order"]) >= {"learner", "goalfilter", "passive", "informed"}
    board = (v3_dir / "leaderboard.md").read_text()
    assert board.index("## Headline") < board.index("## What the agents fail on") < \
        board.index("## Power") < board.index("## wheel-test-inconsistent")
    assert "W/T/L vs next" in board and (v3_dir / "ranking.png").exists()
    # At a runs scale below 1 the power figures are for the humans met, not the track's 40.
    suite_doc = json.loads((v3_dir / "suite.json").read_text())
    power = suite_doc["tracks"]["wheel-test-inconsistent"]["power"]
    assert power["humans"] == suite_doc["tracks"]["wheel-test-inconsistent"]["runs"] == 16
    assert power["detectable"] == suite.detectable_v3(
        power["pilot_between"], power["pilot_within"], 16, 1)

    def wrong_humans(d):
        d["runs"]["0"]["wheel-test-inconsistent"]["humans"][0] += 1

    bad = copy.deepcopy(doc)
    wrong_humans(bad)
    assert any("humans: not the humans the suite's runs meet" in p
               for p in submission.validate(bad))


def _forged(doc):
    """The learner's rewards raised by 0.3 per episode (never above 0), every statistic
    recomputed with the project's own code: a consistent file."""
    bad = copy.deepcopy(doc)
    for by_track in bad["runs"].values():
        for block in by_track.values():
            entry = block["agents"]["learner"]
            entry["reward"] = [[min(0.0, round(v + 0.3, 6)) for v in row]
                               for row in entry["reward"]]
    bad["statistics"], bad["aggregate"] = submission.compute(bad)
    return bad


def test_a_forged_file_validates_but_replay_and_the_merge_catch_it(v3_dir, tmp_path, capsys):
    doc = submission.load(v3_dir / "results.json")
    forged = _forged(doc)
    assert submission.validate(forged) == []  # consistent: the statistics cannot tell
    folder = tmp_path / "subs"
    folder.mkdir()
    (folder / "genuine.json").write_text(json.dumps(doc))
    (folder / "forged.json").write_text(json.dumps(forged))
    assert main(["validate", str(folder / "forged.json"), "--replay", "2",
                 "--replay-seed", "0"]) == 1
    err = capsys.readouterr().err
    assert "REPLAY FAILED" in err and ".agents.learner.reward[" in err
    assert main(["validate", str(folder / "genuine.json"), "--replay", "2",
                 "--replay-seed", "0"]) == 0
    assert "replayed run(s) identical" in capsys.readouterr().out
    # Both files claim the learner of this hri-envs at seed 0: the merge refuses both.
    assert main(["leaderboard", str(folder), "--out", str(tmp_path / "board")]) == 1
    err = capsys.readouterr().err
    assert "forged.json: refused" in err and "genuine.json: refused" in err
    assert "disagree on agent 'learner'" in err and "run(s) 0, 1" in err
    # Alone, the genuine file merges.
    (folder / "forged.json").unlink()
    assert main(["leaderboard", str(folder), "--out", str(tmp_path / "board")]) == 0
    assert "## Headline" in (tmp_path / "board" / "leaderboard.md").read_text()


def test_replay_skips_agents_whose_code_is_not_installed(v3_dir):
    doc = submission.load(v3_dir / "results.json")
    other = copy.deepcopy(doc)
    other["agents"]["learner"]["version"] = "0.0.0"
    checked, problems, skipped = audit.replay(other, 1, 0)
    assert "learner" in skipped and "version" in skipped["learner"]
    assert problems == [] and not any(c.startswith("learner ") for c in checked)


def test_merging_files_of_another_runs_scale_is_refused_by_name(v3_dir):
    doc = submission.load(v3_dir / "results.json")
    scaled = copy.deepcopy(doc)
    scaled["runs_scale"] = 0.5
    keep, refused = merged._mergeable({"a.json": doc, "b.json": scaled})
    assert list(keep) == ["a.json"]
    assert refused and refused[0].startswith("b.json: refused: runs scale 0.5")
