"""Studies that survive faults (docs/benchmark.md, 'Interrupted studies'): a checked --out,
finished units on disk, kill and resume with byte-identical files, failing agents reported,
and summary.json replayed through --config.
"""

import errno
import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hri_bench.cli import main
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.errors import ActionError, ConfigError
from tests.helpers_processes import children, start_cli

ROOT = Path(__file__).resolve().parents[1]
# 2 agents x 36 preferences (one run each, so one chunk) = 72 units of about 10 ms each.
STUDY = ["study", "hanger", "--preference", "all", "--runs", "36", "--episodes", "3",
         "--agents", "learner,maxent", "--jobs", "2", "--no-progress"]


def _alive(pid):
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "study"
    assert main([*STUDY, "--out", str(out)]) == 0  # in-process: the uninterrupted run
    return out


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
#: SIGTERM takes SIGINT's path in the study (exit 143 instead of 130): in the slow run.
@pytest.mark.parametrize("sig", [signal.SIGKILL,
                                 pytest.param(signal.SIGTERM, marks=pytest.mark.slow),
                                 signal.SIGINT])
def test_killed_study_leaves_no_workers_and_resumes_identically(sig, reference, tmp_path):
    out = tmp_path / "study"
    proc = start_cli([*STUDY, "--out", str(out)])
    deadline = time.monotonic() + 60
    while not list((out / ".units").glob("0*.npz")):
        assert proc.poll() is None, "the study ended before the first unit was seen"
        assert time.monotonic() < deadline
        time.sleep(0.02)
    workers = children(proc.pid)
    assert len(workers) == 2
    proc.send_signal(sig)
    code = proc.wait(timeout=30)
    stderr = proc.stderr.read()
    if sig != signal.SIGKILL:
        assert code == {signal.SIGTERM: 143, signal.SIGINT: 130}[sig]
        assert "--resume" in stderr and "finished unit(s) kept" in stderr
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers), "orphaned pool workers"
    # Nothing that looks complete: no final files, every unit file whole.
    assert not (out / "summary.json").exists() and not (out / "episodes.csv").exists()
    kept = list((out / ".units").glob("0*.npz"))
    assert 0 < len(kept) < 72
    for path in kept:
        with np.load(path, allow_pickle=False) as data:
            assert data["m.reward"].shape[1] == 3

    resumed = start_cli([*STUDY, "--out", str(out), "--resume"])
    assert resumed.wait(timeout=120) == 0, resumed.stderr.read()
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes()
    log = [json.loads(line) for line in (out / "run_log.jsonl").read_text().splitlines()]
    assert log[-1]["status"] == "complete" and log[-1]["resumed"] == len(kept)
    assert not (out / ".units").exists()


def test_the_cli_imports_neither_jax_nor_the_physics():
    # JAX in the process makes a study start its workers by spawn (slower to start, and
    # multiprocessing's resource tracker a third child: the kill test above counted it), and
    # the physics needs the "mujoco" extra: a graph study needs neither. The people commands'
    # modules once imported both at the CLI's import (hri_envs.physics imports mink, whose
    # qpsolvers imports JAX).
    code = ("import sys, hri_bench.cli; "
            "print(sorted(m for m in ('jax', 'mink', 'hri_envs.physics') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_nothing_left_to_simulate_starts_no_pool(monkeypatch):
    # A resumed study whose units are all on disk only writes its files: a pool forked and
    # terminated for nothing once hung in terminate() (issue 24).
    cfg = StudyConfig("wheel", agents=("passive", "learner"), runs=4, episodes=1, jobs=2,
                      executor="process")
    done = {}
    first = run_study(cfg, on_result=done.__setitem__)

    def no_pool(*args, **kwargs):
        raise AssertionError("a pool was started with nothing to simulate")

    monkeypatch.setattr("hri_bench.run.study._start_pool", no_pool)
    again = run_study(cfg, done=done)
    for agent, metrics in first.metrics.items():
        for key, values in metrics.items():
            np.testing.assert_array_equal(values, again.metrics[agent][key], err_msg=key)


_EARLY_SIGINT = """
import os, signal
from hri_bench.run import study
from hri_bench.run.studyio import stop_on_signals

real = study._worker_init

def early(*args):
    os.kill(os.getpid(), signal.SIGINT)  # before the worker has its own handlers
    real(*args)

study._worker_init = early
cfg = study.StudyConfig("wheel", agents=("passive",), runs=4, episodes=1, jobs=2,
                        executor="process")
with stop_on_signals():
    study.run_study(cfg)
print("finished")
"""


def test_a_signal_at_a_workers_start_never_runs_the_parents_handler():
    # A worker that ran the parent's Ctrl-C handler during its set-up died, was replaced,
    # died again...: the pool never finished (issue 24). Workers start with the stop signals
    # blocked, so the early SIGINT meets the worker's own "ignore".
    proc = subprocess.run([sys.executable, "-c", _EARLY_SIGINT], capture_output=True,
                          text=True, timeout=60, cwd=ROOT,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "finished" and "KeyboardInterrupt" not in proc.stderr


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_a_second_study_on_the_same_out_is_refused(tmp_path, monkeypatch):
    # --overwrite on the --out of a running study once removed its files (issue 24). The
    # first study's agent waits for a gate file, so it is still running, whatever the
    # machine's speed, while the second one starts.
    gate = tmp_path / "gate"
    monkeypatch.setenv("HRI_TEST_GATE", str(gate))
    out = tmp_path / "study"
    study = ["study", "wheel", "--runs", "2", "--episodes", "2", "--jobs", "1", "--no-progress",
             "--agents", "tests.helpers_agents:WaitsForGate", "--out", str(out)]
    first = start_cli(study)
    deadline = time.monotonic() + 60
    while not (out / ".lock").exists():
        assert first.poll() is None and time.monotonic() < deadline
        time.sleep(0.02)
    for flag in ("--overwrite", "--resume"):
        second = start_cli([*study, flag])
        assert second.wait(timeout=60) == 2
        err = second.stderr.read()
        assert f"argument --out: another study (process {first.pid}) is writing in" in err
        assert "Traceback" not in err
    assert first.poll() is None  # the first study was neither stopped nor disturbed
    first.kill()
    first.wait(timeout=30)
    # The lock went with the study's process, even if its workers are still exiting.
    with (out / ".lock").open("a") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(f, fcntl.LOCK_UN)
    gate.touch()
    resumed = start_cli([*study, "--resume"])
    assert resumed.wait(timeout=120) == 0, resumed.stderr.read()
    # The resumed study wrote what the same study run without interruption writes.
    uninterrupted = tmp_path / "uninterrupted"
    assert main([*study[:-1], str(uninterrupted)]) == 0
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (uninterrupted / name).read_bytes(), name
    assert not (out / ".lock").exists()


def test_the_lock_is_held_for_the_folders_life(tmp_path, capsys):
    from hri_bench.run.studyio import StudyDir

    out = tmp_path / "study"
    base = ["study", "wheel", "--runs", "2", "--episodes", "1", "--agents", "passive",
            "--no-progress", "--out", str(out)]
    with StudyDir(out, StudyConfig("wheel", agents=("passive",), runs=2, episodes=1)):
        with pytest.raises(SystemExit) as exc:
            main([*base, "--overwrite"])
        assert exc.value.code == 2
        assert f"another study (process {os.getpid()}) is writing in" in capsys.readouterr().err
    assert main([*base, "--resume"]) == 0


SMALL = ["study", "wheel", "--runs", "3", "--episodes", "2", "--agents", "learner,passive",
         "--no-progress"]


@pytest.fixture(scope="module")
def small_reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("small") / "study"
    assert main([*SMALL, "--out", str(out)]) == 0
    return out


def _interrupted(out):
    """A study of SMALL stopped (Ctrl-C) as it was about to write its files."""
    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("hri_bench.run.studyio.write_outputs", stop)
        assert main([*SMALL, "--out", str(out)]) == 130


def _log(out):
    return [json.loads(line) for line in (out / "run_log.jsonl").read_text().splitlines()]


def test_resume_removes_what_a_killed_write_left(small_reference, tmp_path):
    out = tmp_path / "study"
    _interrupted(out)
    assert [e["status"] for e in _log(out)] == ["interrupted"]
    # What a SIGKILL in the middle of the final write leaves behind.
    leftovers = [out / ".summary.json.k2j4_x.tmp", out / ".episodes.csv.a8f_3x.tmp",
                 out / ".plots-q1w2e3" / "reward.png", out / ".units" / ".0000-x.npz.ab.tmp.npz"]
    for path in leftovers:
        path.parent.mkdir(exist_ok=True)
        path.write_text("half")
    assert main([*SMALL, "--out", str(out), "--resume"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["summary.json", "episodes.csv", "reward.png", "decisions.png", "run_log.jsonl"])
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (small_reference / name).read_bytes()
    assert [e["status"] for e in _log(out)] == ["interrupted", "complete"]


def test_resume_of_a_complete_study_does_nothing(small_reference, tmp_path, capsys):
    out = tmp_path / "study"
    assert main([*SMALL, "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.name != "run_log.jsonl"}
    capsys.readouterr()
    assert main([*SMALL, "--out", str(out), "--resume"]) == 0
    assert "nothing to do: the study in" in capsys.readouterr().out
    assert before == {p.name: p.read_bytes() for p in out.iterdir() if p.name != "run_log.jsonl"}
    assert [e["status"] for e in _log(out)] == ["complete", "complete"]
    with pytest.raises(SystemExit):
        main([*SMALL, "--seed", "1", "--out", str(out), "--resume"])
    assert "holds a different, complete study (differs in: seed)" in capsys.readouterr().err


def test_ctrl_c_while_the_folder_is_cleaned_is_a_stop_not_a_traceback(tmp_path, monkeypatch,
                                                                     capsys):
    # Found by the kill tests: the leftovers of a killed study are removed before the
    # simulation, and a Ctrl-C there was a KeyboardInterrupt traceback.
    out = tmp_path / "study"
    _interrupted(out)

    def ctrl_c(self):
        raise KeyboardInterrupt

    monkeypatch.setattr("hri_bench.run.studyio.StudyDir._remove_leftovers", ctrl_c)
    capsys.readouterr()
    assert main([*SMALL, "--out", str(out), "--resume"]) == 130
    err = capsys.readouterr().err
    assert "stopped; 2 finished unit(s) kept" in err and err.rstrip().endswith("--resume")
    assert not (out / ".lock").exists()  # released


@pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="needs /proc")
@pytest.mark.parametrize("victim", [".npz", "episodes.csv", "summary.json"])
def test_a_full_disk_is_one_line_naming_the_file_and_the_resume(victim, small_reference,
                                                                 tmp_path, monkeypatch, capsys):
    out = tmp_path / "study"
    real_fsync = os.fsync

    def full(fd):  # the disk fills up as this file is flushed
        if victim in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", full)
    assert main([*SMALL, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith(f"hri-bench: cannot write {out}") and victim in err.split(":")[1]
    assert "No space left on device" in err
    assert err.endswith(f"--out {out} --resume")
    assert not list(out.rglob("*.tmp*")) and not list(out.glob(".plots-*"))
    assert _log(out)[-1]["status"] == "interrupted"
    monkeypatch.setattr(os, "fsync", real_fsync)  # space freed
    assert main([*SMALL, "--out", str(out), "--resume"]) == 0
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (small_reference / name).read_bytes()
    assert _log(out)[-1]["status"] == "complete"


def test_out_is_checked_before_any_simulation(tmp_path, capsys):
    a_file = tmp_path / "file"
    a_file.write_text("x")
    base = ["study", "wheel", "--runs", "1", "--episodes", "1", "--no-progress"]
    with pytest.raises(SystemExit) as exc:
        main([*base, "--out", str(a_file)])
    assert exc.value.code == 2
    assert "argument --out" in capsys.readouterr().err
    full = tmp_path / "full"
    full.mkdir()
    (full / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit):
        main([*base, "--out", str(full)])
    assert "is not empty" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*base, "--out", str(full), "--resume"])
    assert "nothing to resume" in capsys.readouterr().err
    assert main([*base, "--out", str(full), "--overwrite"]) == 0
    assert (full / "notes.txt").read_text() == "mine"  # only the study's own files go


def test_resume_refuses_a_folder_of_another_study(tmp_path, capsys):
    out = tmp_path / "study"
    (out / ".units").mkdir(parents=True)
    base = ["study", "wheel", "--runs", "2", "--episodes", "1", "--no-progress", "--out",
            str(out)]
    from hri_bench.run.studyio import StudyDir

    StudyDir(out, StudyConfig("wheel", runs=2, episodes=1, seed=5), overwrite=True).close()
    with pytest.raises(SystemExit):
        main([*base, "--resume"])
    assert "differs in: seed" in capsys.readouterr().err


def test_unwritable_out(tmp_path, capsys, monkeypatch):
    # chmod does not stop root, so the permission check itself is made to say no.
    monkeypatch.setattr("hri_bench.run.studyio.os.access", lambda *args, **kwargs: False)
    with pytest.raises(SystemExit):
        main(["study", "wheel", "--runs", "1", "--out", str(tmp_path / "x")])
    assert "cannot write" in capsys.readouterr().err


def test_failing_agent_is_reported_and_the_others_are_written(tmp_path, capsys):
    out = tmp_path / "study"
    code = main(["study", "wheel", "--runs", "3", "--episodes", "2", "--no-progress", "--out",
                 str(out), "--agents", "learner,tests.helpers_agents:RaisesInAct,oracle"])
    assert code == 1
    assert "tests.helpers_agents:RaisesInAct" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["agents"]) == {"learner", "oracle"}
    assert summary["failed_agents"] == ["tests.helpers_agents:RaisesInAct"]
    log = (out / "errors.log").read_text()
    assert "agent 'tests.helpers_agents:RaisesInAct' raised" in log
    assert "Traceback" in log and "deliberate failure in act" in log


@pytest.mark.parametrize("agent, message", [
    ("nosuch.mod:Foo", "cannot import agent 'nosuch.mod:Foo': ModuleNotFoundError"),
    ("tests.helpers_agents:NotAnAgent",
     "not a subclass of agents.protocol.Agent or agents.protocol.BatchAgent"),
    ("tests.helpers_agents:Missing", "cannot import agent 'tests.helpers_agents:Missing'"),
])
def test_an_agent_that_is_not_one_is_refused_before_any_simulation(agent, message, tmp_path,
                                                                    capsys):
    # It once passed parsing; the study simulated the others and exited 1 (issue 24).
    out = tmp_path / "study"
    with pytest.raises(SystemExit) as exc:
        main(["study", "wheel", "--runs", "2", "--episodes", "1", "--no-progress", "--out",
              str(out), "--agents", f"passive,{agent}"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "argument --agents" in err and message in err and "Traceback" not in err
    assert not out.exists()
    with pytest.raises(ConfigError, match="agent") as info:
        StudyConfig("wheel", agents=("passive", agent))
    assert info.value.field == "agents"


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_an_agent_calling_sys_exit_fails_alone(jobs, tmp_path, capsys):
    # sys.exit(3) in act() once ended the whole study with no outputs (issue 24).
    out = tmp_path / "study"
    bad = "tests.helpers_agents:ExitsInAct"
    code = main(["study", "wheel", "--runs", "3", "--episodes", "2", "--no-progress", "--out",
                 str(out), "--jobs", jobs, "--agents", f"passive,{bad}"])
    assert code == 1
    assert bad in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["agents"]) == {"passive"} and summary["failed_agents"] == [bad]
    assert "SystemExit: 3" in (out / "errors.log").read_text()
    with pytest.raises(RuntimeError, match=r"agent 'tests.helpers_agents:ExitsInAct' called "
                                           r"sys.exit\(3\)"):
        run_study(StudyConfig("wheel", agents=(bad,), runs=2, episodes=1))


#: Agents that end their process or raise KeyboardInterrupt themselves (tests/helpers_faults.py)
#: while the gate is closed.
ENDERS = ("tests.helpers_faults:ExitsProcess", "tests.helpers_faults:RaisesKeyboardInterrupt")
ONE_RULE = ["study", "wheel", "--runs", "2", "--episodes", "2", "--no-progress", "--agents",
            ",".join(("passive", *ENDERS))]


@pytest.fixture(scope="module")
def one_rule_reference(tmp_path_factory):
    """The study with the gate open: every agent runs."""
    root = tmp_path_factory.mktemp("one-rule")
    gate = root / "open"
    gate.touch()
    out = root / "reference"
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HRI_TEST_GATE", str(gate))
        assert main([*ONE_RULE, "--out", str(out)]) == 0
    return gate, out


@pytest.mark.parametrize("isolated", [True, False], ids=["own-process", "in-process"])
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_an_agent_that_ends_its_process_or_raises_ctrl_c_is_left_out_like_one_that_raises(
        jobs, isolated, one_rule_reference, tmp_path, monkeypatch):
    """Issue 43: in the benchmark's process at --jobs 1, os._exit(3) ended hri-bench with
    exit 3 and nothing on stderr (on --resume too) and KeyboardInterrupt was taken for Ctrl-C
    (exit 130); at --jobs 2 both stopped the study. One rule now (docs/benchmark.md): the
    agent is left out, the others finish, exit 1; --resume runs only its units."""
    gate, reference = one_rule_reference
    if not isolated:
        monkeypatch.setenv("HRI_BENCH_IN_PROCESS_AGENTS", "1")
    out = tmp_path / "study"
    args = [*ONE_RULE, "--jobs", jobs, "--out", str(out)]
    proc = start_cli(args, tmp_path / "closed")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert f"agent(s) {', '.join(ENDERS)} raised; no results for them" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failed_agents"] == list(ENDERS) and set(summary["agents"]) == {"passive"}
    log = (out / "errors.log").read_text()
    assert "os._exit(3)" in log or "exit status 3" in log
    assert "KeyboardInterrupt: deliberate" in log
    proc = start_cli([*args, "--resume"], gate)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


def test_a_stop_of_the_study_is_not_taken_for_an_agents_ctrl_c(monkeypatch):
    """The study's own SIGINT (StudyStopped, from stop_on_signals) stops it; a plain
    KeyboardInterrupt where Python's default handler runs (a library caller's Ctrl-C)
    too."""
    from hri_bench.run import study
    from hri_bench.run.studyio import stop_on_signals

    unit = study.study_units(StudyConfig("wheel", agents=("passive",), runs=1, episodes=1))[0]
    # Python's default handler, as a library caller has it (an earlier test of the same
    # worker may have left another one installed)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        for raised in (study.StudyStopped("signal 2"), KeyboardInterrupt()):
            def stop(_unit, raised=raised):
                raise raised

            monkeypatch.setattr(study, "_run_unit", stop)
            with pytest.raises(KeyboardInterrupt):
                study._run_unit_caught(unit)
    finally:
        signal.signal(signal.SIGINT, previous)
    with stop_on_signals():  # where the study handles SIGINT: a plain one is the agent's
        failure = study._run_unit_caught(unit)
    assert isinstance(failure, study.UnitFailure)
    assert "agent 'passive' raised KeyboardInterrupt" in str(failure.error)


def test_invalid_action_names_agent_run_and_step():
    cfg = StudyConfig("wheel", agents=("tests.helpers_agents:OutOfRange",), runs=2, episodes=1)
    with pytest.raises(ActionError, match=r"agent 'tests.helpers_agents:OutOfRange': act\(\) "
                                          r"returned action 99 for run 0 in episode 1, step 3"):
        run_study(cfg)


def test_config_replays_a_study_byte_for_byte(tmp_path, capsys):
    first, again = tmp_path / "first", tmp_path / "again"
    assert main(["study", "wheel", "--runs", "3", "--episodes", "3", "--turn-back", "0.5",
                 "--max-steps", "30", "--human-passive", "0.1", "--seed", "3", "--agents",
                 "learner,maxent", "--no-progress", "--out", str(first)]) == 0
    summary = json.loads((first / "summary.json").read_text())
    assert summary["turn_back"] == 0.5 and summary["max_steps"] == 30
    assert summary["settings"]["turn_back"] == 0.5
    assert summary["agent_configs"]["maxent"]["learning_rate"] == 0.03
    assert summary["env_ids"]["gymnasium"] == "hri_envs/Wheel-v0"
    assert main(["study", "--config", str(first / "summary.json"), "--jobs", "2",
                 "--no-progress", "--out", str(again)]) == 0
    for name in ("summary.json", "episodes.csv"):
        assert (again / name).read_bytes() == (first / name).read_bytes()
    with pytest.raises(SystemExit):
        main(["study", "--config", str(first / "summary.json"), "--seed", "4", "--out",
              str(tmp_path / "x")])
    assert "drop --seed" in capsys.readouterr().err


def test_settings_round_trip_and_unknown_settings_are_named():
    from hri_bench.run.study import Probe
    from hri_envs.errors import ConfigError

    cfg = StudyConfig("hanger", agents=("learner",), runs=2, turn_back=0.2,
                      probes=(Probe("p", "human", 3, 1, 2, True),))
    assert StudyConfig.from_settings(json.loads(json.dumps(cfg.settings()))) == cfg
    with pytest.raises(ConfigError, match="unknown setting.*colour.*a study's settings are"):
        StudyConfig.from_settings({**cfg.settings(), "colour": "red"})


def test_truncations_are_counted_in_the_summary(tmp_path):
    out = tmp_path / "study"
    assert main(["study", "wheel", "--runs", "2", "--episodes", "2", "--max-steps", "2",
                 "--agents", "passive", "--no-progress", "--out", str(out)]) == 0
    passive = json.loads((out / "summary.json").read_text())["agents"]["passive"]
    # Two steps never finish a wheel episode: every episode is cut off.
    assert passive["truncated"]["mean"] == [1.0, 1.0]
    assert passive["overall"]["truncation_rate"] == 1.0
    assert passive["overall"]["truncated_episodes"] == 4


def test_a_unit_an_earlier_version_wrote_without_the_task_metrics_is_simulated_again(tmp_path):
    # --resume of a study begun before the task's metrics existed: its units lack them.
    from hri_bench.run.runner import TASK_METRICS
    from hri_bench.run.study import study_units
    from hri_bench.run.studyio import StudyDir

    cfg = StudyConfig("wheel", agents=("passive",), runs=2, episodes=1)
    units = study_units(cfg)
    with StudyDir(tmp_path / "study", cfg) as folder:
        run_study(cfg, on_result=lambda i, res: folder.save_unit(i, units[i], res))
        assert sorted(folder.load_done(units)) == list(range(len(units)))
        path = folder.unit_path(0, units[0])
        with np.load(path) as data:
            old = {k: data[k] for k in data.files if k != f"m.{TASK_METRICS[0]}"}
        np.savez(path, **old)
        assert 0 not in folder.load_done(units)
