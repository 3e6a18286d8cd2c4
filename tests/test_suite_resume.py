"""The suite's output folder (issue 34): the study's lock, a refused non-empty ``--out``,
``--resume`` (finished tracks and units are not run again; the files byte-identical to an
uninterrupted run's), ``--overwrite`` (only the suite's own files, stale figures included),
Ctrl-C and SIGKILL, a dead worker, and bad or full ``--out`` in one line.
"""

import errno
import json
import os
import signal
import time
from pathlib import Path

import pytest

from hri_bench.cli import main
from hri_bench.run.isolation import IN_PROCESS
from hri_bench.suite import running
from tests.helpers_processes import finish, start_cli

GATED = "tests.helpers_faults:WaitsOnWheel"
#: Three small v1 tracks; the gated agent stays in the wheel track until its gate opens.
SUITE = ["suite", "--suite-version", "1", "--tracks", "hanger-paper,hanger-passive,wheel-paper",
         "--runs-scale", "0.01", "--jobs", "2", "--no-progress", "--agents",
         f"learner,passive,{GATED}"]
FILES = ("suite.json", "results.json", "leaderboard.md")
PROMPT = 60
#: One worker runs the module, so that the uninterrupted suite (:func:`gate`) runs once.
pytestmark = pytest.mark.xdist_group("suite-resume")


def _wait_for(proc, ready, what):
    deadline = time.monotonic() + PROMPT
    while not ready():
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            pytest.fail(f"never saw {what}: {proc.communicate()[1]}")
        time.sleep(0.02)


@pytest.fixture(scope="module")
def gate(tmp_path_factory):
    """An open gate (the gated agent waits as AlwaysWait) and the uninterrupted suite."""
    root = tmp_path_factory.mktemp("suite-resume")
    opened = root / "open"
    opened.touch()
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HRI_TEST_GATE", str(opened))
        reference = root / "reference"
        assert main([*SUITE, "--out", str(reference)]) == 0
    return opened, reference


def _identical(out, reference):
    for name in FILES:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert not (out / ".suite").exists() and not (out / ".lock").exists()
    assert sorted(p.name for p in out.glob("*.png")) == sorted(
        p.name for p in reference.glob("*.png"))


def _in_the_wheel_track(out):
    return lambda: (out / ".suite" / "01-hanger-passive.json").exists() and any(
        (out / ".suite" / "02-wheel-paper").glob("0*.npz"))


#: SIGTERM takes SIGINT's path (exit 143 instead of 130; tests/test_study_faults.py runs
#: the study's in the default run).
@pytest.mark.parametrize("sig", [signal.SIGINT,
                                 pytest.param(signal.SIGTERM, marks=pytest.mark.slow),
                                 signal.SIGKILL])
def test_a_stopped_suite_resumes_without_running_finished_work(sig, gate, tmp_path,
                                                               monkeypatch):
    opened, reference = gate
    out = tmp_path / "suite"
    closed = tmp_path / "closed"
    proc = start_cli([*SUITE, "--out", str(out)], closed)
    _wait_for(proc, _in_the_wheel_track(out), "the suite in its wheel track")
    proc.send_signal(sig)
    code, _, err = finish(proc, PROMPT, "the suite")
    if sig != signal.SIGKILL:
        assert code == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], err
        assert "Traceback" not in err and "KeyboardInterrupt" not in err
        assert "stopped; 2 finished track(s) and " in err
        assert err.rstrip().endswith(f"--out {out} --resume")
    assert not (out / "suite.json").exists()
    # Resumed in this process: only the wheel track is simulated, from its kept units.
    calls = []
    real = running.run_study

    def spy(cfg, **kwargs):
        calls.append((cfg.scenario, len(kwargs["done"])))
        return real(cfg, **kwargs)

    monkeypatch.setattr(running, "run_study", spy)
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    assert main([*SUITE, "--out", str(out), "--resume"]) == 0
    assert len(calls) == 1 and calls[0][0] == "wheel" and calls[0][1] > 0, calls
    _identical(out, reference)


def test_a_second_suite_or_study_on_the_folder_is_refused(gate, tmp_path, capsys):
    out = tmp_path / "suite"
    closed = tmp_path / "closed"
    first = start_cli([*SUITE, "--out", str(out)], closed)
    _wait_for(first, _in_the_wheel_track(out), "the suite in its wheel track")
    for flag in ("--resume", "--overwrite"):
        with pytest.raises(SystemExit) as exc:
            main([*SUITE, "--out", str(out), flag])
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert f"argument --out: another suite (process {first.pid}) is writing in" in err
    with pytest.raises(SystemExit):
        main(["study", "wheel", "--runs", "1", "--out", str(out), "--overwrite"])
    assert f"another suite (process {first.pid}) is writing in" in capsys.readouterr().err
    assert first.poll() is None  # undisturbed
    first.send_signal(signal.SIGINT)
    assert finish(first, PROMPT, "the suite")[0] == 130


def test_a_non_empty_out_needs_resume_or_overwrite_which_removes_only_the_suites_files(
        gate, tmp_path, capsys, monkeypatch):
    opened, reference = gate
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    out = tmp_path / "suite"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit) as exc:
        main([*SUITE, "--out", str(out)])
    assert exc.value.code == 2
    assert "is not empty; give a new or empty directory, --resume" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*SUITE, "--out", str(out), "--resume"])
    assert "nothing to resume in" in capsys.readouterr().err
    # What another suite left: figures of other tracks and versions, its files, a seed.
    for name in ("wheel-drift.png", "hanger-test-adaptive.png", "hanger-recorded-x.png",
                 "suite.json", "errors.log", "ranking.png"):
        (out / name).write_text("stale")
    (out / "seed-3").mkdir()
    (out / "seed-3" / "suite.json").write_text("stale")
    (out / "mine").mkdir()
    (out / "mine" / "suite.json").write_text("mine too")
    assert main([*SUITE, "--out", str(out), "--overwrite"]) == 0
    _identical(out, reference)
    left = sorted(p.name for p in out.iterdir())
    assert left == sorted(["notes.txt", "mine", *FILES, "suite_log.json", "hanger-paper.png",
                           "hanger-passive.png", "wheel-paper.png", "profiles.png"]), left
    assert (out / "mine" / "suite.json").read_text() == "mine too"
    capsys.readouterr()
    assert main([*SUITE, "--out", str(out), "--resume"]) == 0
    assert "nothing to do: the suite in" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main([*SUITE, "--seed", "1", "--out", str(out), "--resume"])
    assert "holds a different, complete suite (differs in: seeds)" in capsys.readouterr().err


def test_ctrl_c_in_process_is_the_resume_command_not_a_traceback(gate, tmp_path, capsys,
                                                                  monkeypatch):
    opened, reference = gate
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    out = tmp_path / "suite"
    real = running.track_figure

    def ctrl_c(name, entry, path, **kwargs):
        if name == "hanger-passive":
            raise KeyboardInterrupt
        return real(name, entry, path, **kwargs)

    monkeypatch.setattr(running, "track_figure", ctrl_c)
    assert main([*SUITE, "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "stopped; 2 finished track(s) and 0 finished unit(s) kept in" in err
    assert err.rstrip().endswith("--resume") and "Traceback" not in err
    monkeypatch.setattr(running, "track_figure", real)
    assert main([*SUITE, "--out", str(out), "--resume"]) == 0
    _identical(out, reference)


def test_the_librarys_resume_of_a_complete_suite_removes_what_a_kill_left(tmp_path):
    """run_suite(resume=True) asks complete_suite first: a .suite/ left without its plan by
    a kill after suite_log.json was written is removed there too (the CLI's path is
    SuiteDir's, below); one that still holds its plan is a suite in progress, kept."""
    from hri_bench.suite.resume import PLAN, STATE, SUITE_LOG, complete_suite

    plan = {"version": "v3", "agents": ["passive"]}
    (tmp_path / SUITE_LOG).write_text(json.dumps({"plan": plan}))
    (tmp_path / "suite.json").write_text(json.dumps({"tracks": {}}))
    (tmp_path / STATE / "units").mkdir(parents=True)
    (tmp_path / STATE / PLAN).write_text(json.dumps(plan))
    assert complete_suite(tmp_path, plan) is None and (tmp_path / STATE).is_dir()
    (tmp_path / STATE / PLAN).unlink()  # killed after the plan's removal
    assert complete_suite(tmp_path, plan) == {"tracks": {}}
    assert not (tmp_path / STATE).exists()


@pytest.mark.parametrize("killed", ["before the plan's removal", "after the plan's removal"])
def test_a_kill_as_the_work_folder_is_removed_leaves_nothing_after_resume(
        killed, gate, tmp_path, capsys, monkeypatch):
    """Issue 43: a SIGKILL between writing suite_log.json and removing .suite/ left .suite/,
    and --resume said "nothing to do" without removing it (the kill is simulated: finish()
    stops where the kill came)."""
    from hri_bench.suite import resume

    opened, reference = gate
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    out = tmp_path / "suite"

    def killed_in_finish(store):
        if killed == "after the plan's removal":
            (store.state / resume.PLAN).unlink()

    monkeypatch.setattr(resume.TrackStore, "finish", killed_in_finish)
    assert main([*SUITE, "--out", str(out)]) == 0
    assert (out / ".suite").is_dir() and (out / "suite_log.json").is_file()
    monkeypatch.undo()
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    capsys.readouterr()
    assert main([*SUITE, "--out", str(out), "--resume"]) == 0
    assert ("nothing to do" in capsys.readouterr().out) == (killed != "before the plan's removal")
    _identical(out, reference)


#: suite.json is written as results.json is; a unit's .npz as the study's (tests/
#: test_study_faults.py, in the default run).
@pytest.mark.parametrize("victim", ["results.json",
                                    pytest.param("suite.json", marks=pytest.mark.slow),
                                    pytest.param(".npz", marks=pytest.mark.slow)])
def test_a_full_disk_is_one_line_and_resume_completes(victim, gate, tmp_path, capsys,
                                                      monkeypatch):
    opened, reference = gate
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    out = tmp_path / "suite"
    real_fsync = os.fsync

    def full(fd):
        if victim in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", full)
    assert main([*SUITE, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith(f"hri-bench: cannot write {out}") and "No space left on device" in err
    assert err.endswith(f"--out {out} --resume")
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert main([*SUITE, "--out", str(out), "--resume"]) == 0
    _identical(out, reference)


@pytest.mark.parametrize("where", ["file", "proc", "read-only"])
def test_a_bad_out_is_one_line(where, tmp_path, capsys, monkeypatch):
    out = {"file": tmp_path / "file", "proc": Path("/proc/self/suite"),
           "read-only": tmp_path / "ro" / "suite"}[where]
    if where == "file":
        out.write_text("x")
    if where == "read-only":  # chmod does not stop root: the check itself says no
        monkeypatch.setattr("hri_bench.run.studyio.os.access", lambda *args, **kwargs: False)
    with pytest.raises(SystemExit) as exc:
        main([*SUITE, "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("hri-bench suite: error: argument --out: ")
    assert "Traceback" not in err


def test_a_dead_worker_ends_the_suite_naming_the_track_and_resume_completes(gate, tmp_path,
                                                                           monkeypatch):
    monkeypatch.setenv(IN_PROCESS, "1")  # the agent ends the worker (tests/test_study_workers.py)
    args = ["suite", "--suite-version", "1", "--tracks", "hanger-paper,wheel-paper",
            "--runs-scale", "0.01", "--jobs", "2", "--no-progress", "--agents",
            "passive,tests.helpers_faults:KillsItself"]
    out = tmp_path / "suite"
    closed = tmp_path / "closed"
    t = time.monotonic()
    code, _, err = finish(start_cli([*args, "--out", str(out)], closed), PROMPT, "the suite")
    assert code == 1, err
    assert time.monotonic() - t < PROMPT
    err = err.strip()
    assert err.startswith("hri-bench: suite stopped: track hanger-paper, agent "
                          "'tests.helpers_faults:KillsItself', run")
    assert "killed (SIGKILL" in err and err.endswith("--resume") and "\n" not in err
    opened = tmp_path / "open"
    opened.touch()
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    reference = tmp_path / "reference"
    assert main([*args, "--out", str(reference)]) == 0
    code, _, err = finish(start_cli([*args, "--out", str(out), "--resume"], opened), PROMPT,
                          "the suite")
    assert code == 0, err
    _identical(out, reference)


def test_several_seeds_resume_too(tmp_path, monkeypatch):
    opened = tmp_path / "open"
    opened.touch()
    monkeypatch.setenv("HRI_TEST_GATE", str(opened))
    args = ["suite", "--suite-version", "2", "--tracks", "hanger-paper", "--runs-scale",
            "0.01", "--agents", "passive", "--seeds", "0,1", "--no-progress"]
    reference = tmp_path / "reference"
    assert main([*args, "--out", str(reference)]) == 0
    out = tmp_path / "suite"
    real = running.run_study
    n = []

    def stop_in_seed_1(cfg, **kwargs):
        if cfg.seed == 1:
            raise KeyboardInterrupt
        n.append(cfg.seed)
        return real(cfg, **kwargs)

    monkeypatch.setattr(running, "run_study", stop_in_seed_1)
    assert main([*args, "--out", str(out)]) == 130
    assert n == [0]
    monkeypatch.setattr(running, "run_study",
                        lambda cfg, **kw: n.append(cfg.seed) or real(cfg, **kw))
    assert main([*args, "--out", str(out), "--resume"]) == 0
    assert n == [0, 1]  # seed 0 was complete
    _identical(out, reference)
    for s in (0, 1):
        _identical(out / f"seed-{s}", reference / f"seed-{s}")
    log = json.loads((out / "suite_log.json").read_text())
    assert log["plan"]["seeds"] == [0, 1]
