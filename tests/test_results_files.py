"""Results files and leaderboards that reach the CLI (issue 34): files that are not regular
files, bombs, deep nesting and repeated keys refused early in one line (``validate``,
``leaderboard``, ``suite --config``, ``study --config``); ``suite --config`` checked as the
flags are; ``leaderboard DIR`` on a suite's folder (its other files skipped, its
``leaderboard.md`` kept), of other runs scales and suites (refused by name), with bad or full
``--out``; names escaped in every leaderboard.
"""

import copy
import errno
import gzip
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hri_bench.cli import main
from hri_bench.suite import running, submission
from hri_bench.suite.markdown import code, escape

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["suite", "--suite-version", "1", "--tracks", "hanger-paper", "--agents", "passive",
         "--no-progress"]


def _suite(out, scale="0.01", *extra):
    assert main([*SMALL, "--runs-scale", scale, *extra, "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def suites(tmp_path_factory):
    """Small v1 suites at runs scales 0.01, 0.02, 0.001, 0.0001 and a v2 one."""
    root = tmp_path_factory.mktemp("results-files")
    made = {s: _suite(root / f"v1-{s}", s) for s in ("0.01", "0.02", "0.001", "0.0001")}
    made["v2"] = _suite(root / "v2", "0.01", "--suite-version", "2")
    return made


def _one_line(err):
    err = err.strip()
    assert "Traceback" not in err and "\n" not in err, err
    return err


# ------------------------------------------------------------------ files refused early
def _bad_files(folder):
    folder.mkdir(exist_ok=True)
    bomb = folder / "bomb.json.gz"
    bomb.write_bytes(gzip.compress(b"[" + b" " * (3 * 2**20) + b"]", 9))  # 3 MiB from 3 KiB
    deep = folder / "deep.json"
    deep.write_text("[" * 5000 + "]" * 5000)
    twice = folder / "twice.json"
    twice.write_text('{"format": "hri-bench-results", "format": "hri-bench-results"}')
    return {"bomb": (bomb, "decompresses to more than 2 MiB"),
            "deep": (deep, "its JSON nests deeper than 64 levels"),
            "twice": (twice, "the key 'format' appears twice in one JSON object"),
            "zero": (Path("/dev/zero"), "not a regular file (a FIFO, device or folder)")}


@pytest.mark.parametrize("kind", ["bomb", "deep", "twice", "zero"])
def test_validate_refuses_bad_files_in_one_line(kind, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(submission, "MAX_BYTES", 2 * 2**20)
    path, says = _bad_files(tmp_path)[kind]
    assert main(["validate", str(path)]) == 1
    err = _one_line(capsys.readouterr().err)
    assert err.startswith(f"hri-bench validate: {path}: {says}"), err


def test_leaderboard_refuses_each_bad_file_by_name(tmp_path, suites, capsys, monkeypatch):
    monkeypatch.setattr(submission, "MAX_BYTES", 2 * 2**20)
    folder = tmp_path / "submissions"
    bad = _bad_files(folder)
    (folder / "ours.json").write_bytes((suites["0.01"] / "results.json").read_bytes())
    assert main(["leaderboard", str(folder)]) == 1
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert "Traceback" not in captured.err
    for kind in ("bomb", "deep", "twice"):
        path, says = bad[kind]
        assert any(line.startswith(f"{path}: ") and says in line for line in err), err
    assert "merged 1 of 4 results file(s)" in captured.out


def _cli(args, timeout=60):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    try:
        return subprocess.run([sys.executable, "-m", "hri_bench.cli", *args], env=env,
                              capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    except subprocess.TimeoutExpired:
        pytest.fail(f"hri-bench {' '.join(args)} hung on a FIFO")


@pytest.mark.parametrize("command", ["validate", "suite", "study"])
def test_a_fifo_is_refused_not_waited_on(command, tmp_path):
    fifo = tmp_path / "results.json"
    os.mkfifo(fifo)
    args = {"validate": ["validate", str(fifo)],
            "suite": ["suite", "--config", str(fifo), "--out", str(tmp_path / "o")],
            "study": ["study", "--config", str(fifo), "--out", str(tmp_path / "o")]}[command]
    done = _cli(args)
    assert done.returncode == (1 if command == "validate" else 2), done.stderr
    assert "not a regular file (a FIFO, device or folder)" in done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("kind", ["bomb", "deep", "twice", "zero"])
def test_suite_config_refuses_bad_files(kind, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(submission, "MAX_BYTES", 2 * 2**20)
    path, says = _bad_files(tmp_path)[kind]
    with pytest.raises(SystemExit) as exc:
        main(["suite", "--config", str(path), "--out", str(tmp_path / "o")])
    assert exc.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"hri-bench suite: error: argument --config: {path}: ")
    assert says in line


# ------------------------------------------------------------------ suite --config's settings
@pytest.mark.parametrize("setting, value, says", [
    ("seeds", [0, 0], "its seeds [0, 0]: expected distinct whole numbers >= 0 (as --seeds)"),
    ("seeds", ["a"], "its seeds ['a']: expected distinct whole numbers >= 0 (as --seeds)"),
    ("seeds", [], "its seeds []: expected distinct whole numbers >= 0"),
    ("seeds", [-1], "its seeds [-1]: expected distinct whole numbers >= 0"),
    ("seeds", [True], "its seeds [True]: expected distinct whole numbers >= 0"),
    ("seeds", "01", "its seeds '01': expected distinct whole numbers >= 0"),
    ("agents", [], "its agents []: expected a non-empty list of distinct agent names "
                   "(as --agents)"),
    ("agents", ["passive", "passive"], "its agents ['passive', 'passive']: expected"),
    ("agents", "passive", "its agents 'passive': expected a non-empty list"),
    ("runs_scale", 0, "its runs_scale 0: expected a number > 0 (as --runs-scale)"),
    ("runs_scale", "1", "its runs_scale '1': expected a number > 0"),
])
def test_suite_config_settings_are_checked_as_the_flags(setting, value, says, suites, tmp_path,
                                                        capsys):
    doc = json.loads((suites["0.01"] / "suite.json").read_text())
    if setting == "seeds":
        doc.pop("seed")
    doc[setting] = value
    path = tmp_path / "suite.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(SystemExit) as exc:
        main(["suite", "--config", str(path), "--out", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f"argument --config: {path}: {says}" in err
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ leaderboard DIR
def test_the_leaderboard_of_a_suite_folder_skips_its_files_and_keeps_its_board(suites,
                                                                               tmp_path, capsys):
    out = tmp_path / "suite"
    out.mkdir()
    for p in suites["0.01"].iterdir():
        (out / p.name).write_bytes(p.read_bytes())
    board = (out / "leaderboard.md").read_bytes()
    for _ in range(2):  # again: it replaces its own merged leaderboard
        assert main(["leaderboard", str(out)]) == 0
        captured = capsys.readouterr()
        assert captured.err == ""
        assert f"{out / 'suite.json'}: skipped: not a results file" in captured.out
        assert f"{out / 'suite_log.json'}: skipped: not a results file" in captured.out
        assert "merged 1 of 1 results file(s)" in captured.out
    assert (out / "leaderboard.md").read_bytes() == board  # the suite's own, untouched
    merged = (out / "merged" / "leaderboard.md").read_text()
    assert merged.startswith("# hri-envs leaderboard (suite v1)")
    assert sorted(p.name for p in (out / "merged").iterdir()) == ["leaderboard.md",
                                                                  "profiles.png"]


def test_the_leaderboard_refuses_an_out_it_did_not_write(suites, tmp_path, capsys):
    folder = suites["0.01"]
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    for out in (folder, tmp_path / "file"):
        if out.name == "file":
            out.write_text("x")
        with pytest.raises(SystemExit) as exc:
            main(["leaderboard", str(folder), "--out", str(out)])
        assert exc.value.code == 2
        line = capsys.readouterr().err.strip().splitlines()[-1]
        assert line.startswith("hri-bench leaderboard: error: argument --out: ")
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "leaderboard.md").write_text("# my notes\n")
    with pytest.raises(SystemExit):
        main(["leaderboard", str(folder), "--out", str(tmp_path / "other")])
    assert "leaderboard.md (not one hri-bench leaderboard wrote)" in capsys.readouterr().err
    assert main(["leaderboard", str(folder), "--out", str(tmp_path / "new")]) == 0


def test_a_full_disk_under_the_leaderboard_is_one_line(suites, tmp_path, capsys, monkeypatch):
    real = os.fsync

    def full(fd):
        if "leaderboard.md" in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd)

    monkeypatch.setattr(os, "fsync", full)
    out = tmp_path / "board"
    assert main(["leaderboard", str(suites["0.01"]), "--out", str(out)]) == 1
    err = _one_line(capsys.readouterr().err)
    assert err == f"hri-bench leaderboard: cannot write {out / 'leaderboard.md'}: " \
                  "No space left on device"
    assert not (out / ".lock").exists()


@pytest.mark.parametrize("first, second, says", [
    ("0.01", "0.02", "refused: runs scale 0.02, 1.json has 0.01: results of different run "
                     "counts are not merged"),
    ("0.001", "0.0001", "refused: runs scale 0.0001, 1.json has 0.001: results of different "
                        "run counts are not merged"),  # both 2 runs per track
    ("0.01", "v2", "refused: suite v2"),
])
def test_files_of_other_scales_or_suites_are_refused_by_name(first, second, says, suites,
                                                             tmp_path, capsys):
    folder = tmp_path / "submissions"
    folder.mkdir()
    (folder / "1.json").write_bytes((suites[first] / "results.json").read_bytes())
    (folder / "2.json").write_bytes((suites[second] / "results.json").read_bytes())
    assert main(["leaderboard", str(folder)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "broadcast" not in captured.err
    assert captured.err.strip().startswith(f"2.json: {says}")
    assert "merged 1 of 2 results file(s)" in captured.out
    board = (folder / "merged" / "leaderboard.md").read_text()
    assert "`1.json`" in board and "`2.json`" not in board


# ------------------------------------------------------------------ escaped names
EVIL = "ev`il <img src=x onerror=alert(1)> | col\n## heading #1 \\"


def test_escape_changes_only_what_needs_it():
    for name in ("learner", "passive", "mylab.agent:Mine", "sb3:models/ppo.zip",
                 "learner@sub.json", "hanger-paper", "jaxppo"):
        assert escape(name) == name and code(name) == f"`{name}`"
    text = escape(EVIL)
    assert "<" not in text and ">" not in text and "\n" not in text and "`" not in text
    assert "\\|" in text and "\\#" in text and "\\\\" in text


def _renamed(doc, old, new):
    doc = copy.deepcopy(doc)
    doc["agents"] = {(new if a == old else a): v for a, v in doc["agents"].items()}
    for by_track in doc["runs"].values():
        for block in by_track.values():
            block["agents"] = {(new if a == old else a): v for a, v in block["agents"].items()}
    for by_track in doc["tracks"].values():
        by_track["agent_configs"] = {(new if a == old else a): v
                                     for a, v in by_track["agent_configs"].items()}
    doc["statistics"], doc["aggregate"] = submission.compute(doc)
    return doc


def _rows_are_whole(text):
    for line in text.splitlines():
        assert not line.startswith("## heading"), line
        if line.startswith("|"):
            cells = line.replace("\\|", "").count("|")
            assert cells >= 2
    assert "<img" not in text


def test_names_from_files_are_escaped_in_the_merged_leaderboard(suites, tmp_path, capsys):
    """An agent's name that would break the leaderboard's tables is refused by validate
    (tests/test_results.py); what stays free text, the submitter's name, is escaped."""
    evil_agent = _renamed(submission.load(suites["v2"] / "results.json"), "passive", EVIL)
    assert any("agent name" in p for p in submission.validate(evil_agent))
    doc = submission.load(suites["v2"] / "results.json")
    doc["submission"]["name"] = "<img src=x>|lab\n# big"
    assert submission.validate(doc) == []
    folder = tmp_path / "submissions"
    folder.mkdir()
    (folder / "evil|<b>.json").write_text(json.dumps(doc))
    assert main(["leaderboard", str(folder)]) == 0
    text = (folder / "merged" / "leaderboard.md").read_text()
    _rows_are_whole(text)
    assert escape("<img src=x>|lab\n# big") in text and "<img src=x>" not in text


@pytest.mark.parametrize("version", ["1", "2"])
def test_names_are_escaped_in_the_suites_leaderboards(version, suites, tmp_path):
    folder = suites["0.01" if version == "1" else "v2"]
    doc = json.loads((folder / "suite.json").read_text())
    results = submission.load(folder / "results.json")
    for tr in doc["tracks"].values():
        tr["agents"][EVIL] = tr["agents"].pop("passive")
        tr["failed_agents"] = [EVIL]
    doc["agents"] = [EVIL]
    results = _renamed(results, "passive", EVIL)
    text = running._leaderboard_text(doc, results)
    _rows_are_whole(text)
    assert code(EVIL) in text and f"`{EVIL}`" not in text
