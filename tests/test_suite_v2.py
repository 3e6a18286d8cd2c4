"""hri-bench suite v2 (the default until v3): the test split as headline, a reference on every track
(blind exact or a labelled bracket), every agent's gap to it with 95 % CIs, power-chosen runs.
"""

import json

import pytest

from hri_bench import suite
from hri_bench.cli import main
from hri_bench.core import stats
from hri_bench.suite import (
    DEFAULT_AGENTS_V2,
    INTENTION_BLIND,
    MAX_RUNS,
    MIN_RUNS,
    PILOT_SD,
    TRACKS_V2,
    run_suite,
    select_tracks,
    track_config,
)
from hri_envs.humans.splits import MIXTURES

pytestmark = pytest.mark.xdist_group("suite")


@pytest.fixture(scope="module")
def tiny2(tmp_path_factory):
    """Every v2 track at 5 % of its runs (at least 2), serial."""
    out = tmp_path_factory.mktemp("suite2")
    return out, run_suite(out, runs_scale=0.05, version="2")


def test_v2_keeps_the_test_split_as_headline_and_v4_is_the_default(tmp_path, monkeypatch):
    assert suite.LATEST == "4"
    headline = [t.name for t in TRACKS_V2.values() if t.headline]
    assert headline == ["hanger-test", "wheel-test"]
    for sc in ("hanger", "wheel"):
        for part in ("misspecified", "adaptive", "inconsistent"):
            assert f"{sc}-test-{part}" in TRACKS_V2
    assert set(TRACKS_V2) == set(PILOT_SD)
    # --suite-version 2 still runs v2, with the goal filter (what run_suite is given).
    given = {}

    def record(out, **kwargs):
        given.update(kwargs)
        raise AssertionError("recorded")

    monkeypatch.setattr("hri_bench.cli.commands.run_suite", record)
    with pytest.raises(AssertionError, match="recorded"):
        main(["suite", "--out", str(tmp_path / "s"), "--no-progress", "--suite-version", "2"])
    assert given["version"] == "2" and "goalfilter" in given["agents"]
    assert "countqmdp" not in given["agents"]
    # Every v2 track has an upper bound (informed), and blind or the bracket's lower end.
    for track in TRACKS_V2.values():
        agents = track_config(track, DEFAULT_AGENTS_V2, version="2").agents
        assert "informed" in agents
        assert ("blind" in agents) == track.name.endswith("-paper")
        assert ("qmdp" in agents) != ("blind" in agents)


def test_run_counts_come_from_the_power_analysis():
    # By hand: (z_0.975 + z_0.8)² · (0.3 / 0.05)² = (1.95996 + 0.84162)² · 36 = 282.6.
    assert stats.runs_for_difference(0.3, 0.05) == 283
    assert stats.detectable_difference(0.3, 283) == pytest.approx(0.05, abs=2e-4)
    for name, track in TRACKS_V2.items():
        need = stats.runs_for_difference(PILOT_SD[name], suite.DELTA)
        pop = dict(track.settings).get("population")
        if pop is None:
            assert track.runs == min(max(MIN_RUNS, need), MAX_RUNS), name
            continue
        size = MIXTURES[(pop, track.scenario)].size
        # Whole blocks of members (each member met equally often), at least two per member.
        assert track.runs % size == 0 and track.runs >= 2 * size, name
        assert track.runs >= min(need, MAX_RUNS - size + 1), name
        assert track.runs <= max(MAX_RUNS, 2 * size), name


def test_every_track_reports_each_agents_gap_to_its_reference(tiny2):
    out, doc = tiny2
    assert json.loads((out / "suite.json").read_text()) == doc
    results = json.loads((out / "results.json").read_text())
    assert doc["suite_version"] == "2" and list(doc["tracks"]) == list(TRACKS_V2)
    board = (out / "leaderboard.md").read_text()
    for name, tr in doc["tracks"].items():
        ref = tr["reference"]
        if name.endswith("-paper"):
            assert ref["kind"] == "exact" and ref["lower"] == "blind"
            assert tr["regret_reported"]
        else:
            assert ref["kind"] == "bracket" and (ref["lower"], ref["upper"]) == (
                "qmdp", "informed")
            pop = tr["population"]
            spec = MIXTURES[(pop["name"], tr["scenario"])]
            assert pop["hash"] == spec.content_hash() and pop["held_out"]
        assert ref["lower_reward"] <= ref["upper_reward"] + 1e-9, name
        assert set(tr["agents"]) >= {*DEFAULT_AGENTS_V2, "informed", ref["lower"]}
        for agent, a in tr["agents"].items():
            for key in ("gap_to_upper", "gap_to_lower"):
                gap = a[key]
                lo, hi = gap["ci95"]
                assert lo <= gap["mean"] + 1e-9 <= hi + 2e-9, (name, agent, key)
            # Paired gaps of run means: the bound's mean reward minus the agent's.
            for key, bound in (("gap_to_upper", "upper_reward"), ("gap_to_lower",
                                                                   "lower_reward")):
                assert a[key]["mean"] == pytest.approx(
                    ref[bound] - a["reward"]["mean"], abs=1e-9), (name, agent, key)
        # The runs reported are the runs simulated (results.json's per-run rows), 5 % of
        # the track's, and the power block's detectable difference is for those runs.
        assert len(results["runs"]["0"][name]["agents"]["informed"]["reward"]) == tr["runs"]
        assert tr["runs"] == max(2, round(TRACKS_V2[name].runs * 0.05))
        assert tr["power"]["detectable"] == round(
            stats.detectable_difference(PILOT_SD[name], tr["runs"]), 4)
        # The leaderboard labels the reference and shows every ranked agent's gap.
        line = next(x for x in board.splitlines() if x.startswith(f"| {name} |")
                    or x.startswith(f"| **{name}** |"))
        assert ("exact: blind" if ref["kind"] == "exact" else "bracket: blind in [") in line
        assert line.count("[") == len(DEFAULT_AGENTS_V2) + (ref["kind"] == "bracket")


def test_no_intention_blind_agent_beats_blind_or_the_bracket_upper_bound(tiny2):
    _, doc = tiny2
    checked = 0
    for name, tr in doc["tracks"].items():
        for agent in (a for a in INTENTION_BLIND if a in tr["agents"]):
            entry = tr["agents"][agent]
            # informed minus the agent, paired runs: the agent is not above it beyond its CI.
            assert entry["gap_to_upper"]["ci95"][1] >= 0.0, (name, agent)
            if tr["reference"]["kind"] == "exact":
                assert entry["regret"]["ci95"][1] >= 0.0, (name, agent)
            checked += 1
    assert checked == len(TRACKS_V2) * (len(DEFAULT_AGENTS_V2) - 1) + 8  # - oracle, + qmdp


def test_an_unknown_version_or_a_track_of_another_version_fails_naming_the_flag(
        tmp_path, monkeypatch, capsys):
    def boom(*args, **kwargs):
        raise AssertionError("simulated")

    monkeypatch.setattr("hri_bench.suite.running.run_study", boom)
    for argv, flag, text in (
            (["--suite-version", "5"], "--suite-version", "invalid choice: '5'"),
            (["--tracks", "wheel-heldout", "--suite-version", "2"], "--tracks",
             "unknown track(s) wheel-heldout of suite v2; allowed: hanger-test"),
            (["--population", "test"], "--population", "a suite track of its own takes")):
        with pytest.raises(SystemExit) as exc:
            main(["suite", "--out", str(tmp_path / "x"), *argv])
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert f"argument {flag}: {text}" in err, err
    assert not (tmp_path / "x").exists()
    assert [t.name for t in select_tracks("wheel-paper,hanger-test", "2")] == [
        "hanger-test", "wheel-paper"]


@pytest.mark.parametrize("argv, flag, text", [
    (["--population", "tset"], "--population", "unknown population 'tset'"),
    (["--population", "impatient", "--human-param", "k=0"], "--human-param", "k must be"),
    (["--population", "trust", "--human-param", "speed=2"], "--human-param",
     "has no parameter 'speed'"),
    (["--human-param", "k=3"], "--human-param", "no population is given"),
    (["--human-param", "k"], "--human-param", "give NAME=VALUE"),
    (["--agents", "blind,learner", "--human-rationality", "5"], "--agents",
     "humans are Boltzmann"),
    (["--agents", "blind,learner", "--population", "test"], "--agents",
     "runs have humans of their own"),
    (["--agents", "qmdp,learner", "--turn-back", "0.3"], "--agents", "turn back halfway"),
    (["--population", "test", "--human-passive", "0.2"], "--human-passive", "frozen member"),
])
def test_bad_humans_and_references_fail_before_simulating(argv, flag, text, tmp_path,
                                                          monkeypatch, capsys):
    from hri_bench.run import study, studyio  # noqa: F401  (imported first: it binds run_study)

    def boom(*args, **kwargs):
        raise AssertionError("simulated")

    # studyio imports run_study by name: had it been imported first here, every later
    # study of this worker would run ``boom`` (test_bench failed so under xdist).
    monkeypatch.setattr(study, "run_study", boom)
    with pytest.raises(SystemExit) as exc:
        main(["study", "wheel", "--runs", "2", "--out", str(tmp_path / "o"), "--no-progress",
              *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}:" in err and text in err, err
    assert not (tmp_path / "o").exists()


def test_v2_serial_and_two_jobs_give_byte_identical_suite_json(tmp_path):
    kw = {"tracks": "hanger-test-inconsistent", "runs_scale": 0.2,
          "agents": ("learner", "goalfilter"), "version": "2"}
    run_suite(tmp_path / "a", **kw)
    run_suite(tmp_path / "b", jobs=2, executor="process", **kw)
    assert (tmp_path / "a" / "suite.json").read_bytes() == \
        (tmp_path / "b" / "suite.json").read_bytes()
