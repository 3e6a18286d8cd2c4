"""Dead and hung pool workers (issue 34): a study whose worker dies (SIGKILL from the agent
or from outside; an agent's ``os._exit`` or ``KeyboardInterrupt`` is its own failure since
issue 43, tests/test_study_faults.py) or whose unit runs
past ``--unit-time-limit`` ends within seconds with one line naming the unit, keeps its
finished units, and ``--resume`` completes it byte-identical to an uninterrupted run.

Before the fix each of these studies waited forever at 0 CPU; here every subprocess has a
timeout, so a hang fails the test instead of stalling it.
"""

import math
import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from hri_bench.cli import main
from hri_bench.run.isolation import IN_PROCESS
from hri_bench.run.study import CLOCK_FILE, StudyConfig, UnitLostError, run_study
from hri_envs.errors import ConfigError
from tests.helpers_processes import children, finish, start_cli

#: Seconds a study with a dead or hung worker may take to end (it ends in about one).
PROMPT = 30


@pytest.fixture(autouse=True)
def _agents_in_the_worker(monkeypatch):
    """The agents of tests/helpers_faults.py end or stall the process they run in. An agent
    of one's own runs in a process of its own (its death is that agent's failure,
    tests/test_isolation.py); these tests are about the pool's workers, so the agents run in
    the worker, as the benchmark's own agents do.
    """
    monkeypatch.setenv(IN_PROCESS, "1")


def _study(agent, *extra):
    return ["study", "wheel", "--runs", "4", "--episodes", "2", "--no-progress", "--agents",
            f"passive,{agent}", *extra]


def _uninterrupted(args, out, gate, monkeypatch):
    gate.touch()
    monkeypatch.setenv("HRI_TEST_GATE", str(gate))
    assert main([*args, "--out", str(out)]) == 0


def _resumed_identically(args, out, gate, reference):
    gate.touch()
    code, _, err = finish(start_cli([*args, "--out", str(out), "--resume"], gate), timeout=120)
    assert code == 0, err
    for name in ("summary.json", "episodes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert not (out / ".units").exists() and not (out / ".lock").exists()


#: An agent calling os._exit or raising KeyboardInterrupt is left out like one that raises
#: (tests/test_study_faults.py, issue 43); a signal kills the worker, whoever sends it.
@pytest.mark.parametrize("agent, says", [
    ("KillsItself", "its worker process was killed (SIGKILL"),
])
def test_a_dead_worker_ends_the_study_naming_the_unit_and_resume_completes_it(
        agent, says, tmp_path, monkeypatch):
    name = f"tests.helpers_faults:{agent}"
    args = _study(name, "--jobs", "2")
    gate = tmp_path / "gate"
    out = tmp_path / "study"
    t = time.monotonic()
    code, _, err = finish(start_cli([*args, "--out", str(out)], gate), PROMPT)
    took = time.monotonic() - t
    assert code == 1, err
    err = err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert err.startswith(f"hri-bench: study stopped: agent {name!r}, runs ")
    assert says in err
    assert err.endswith(f"--out {out} --resume")
    assert took < PROMPT
    assert not (out / "summary.json").exists()
    reference = tmp_path / "reference"
    _uninterrupted(args, reference, tmp_path / "open", monkeypatch)
    _resumed_identically(args, out, gate, reference)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_a_worker_killed_from_outside_ends_the_study_within_seconds(tmp_path, monkeypatch):
    # kill -9 (or the OOM killer) on a worker busy with a unit: its agent waits for the gate.
    args = _study("tests.helpers_agents:WaitsForGate", "--jobs", "2")
    gate = tmp_path / "gate"
    out = tmp_path / "study"
    proc = start_cli([*args, "--out", str(out)], gate)
    deadline = time.monotonic() + 120  # only a guard against a hang
    while not (waiting := [int(p.name.rsplit(".", 1)[1])
                           for p in tmp_path.glob("gate.waiting.*")]):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.02)
    victim = waiting[0]  # a worker known to wait in WaitsForGate's unit
    assert victim in children(proc.pid)
    os.kill(victim, signal.SIGKILL)
    code, _, err = finish(proc, PROMPT)  # the unit limit is 3600 s: not waited out
    assert code == 1, err
    assert "agent 'tests.helpers_agents:WaitsForGate', runs " in err
    assert "its worker process was killed (SIGKILL" in err and "Traceback" not in err
    reference = tmp_path / "reference"
    _uninterrupted(args, reference, gate, monkeypatch)
    _resumed_identically(args, out, gate, reference)


def _set_clock(clock: Path, seconds: float) -> None:
    """Write the time limit's clock (:data:`CLOCK_FILE`) whole, as the study reads it."""
    part = clock.with_name(clock.name + ".part")
    part.write_text(repr(float(seconds)))
    os.replace(part, clock)


#: With --jobs 2 the parent's clock ends a unit whatever its worker does: a worker spinning
#: in C code (SpinsInC) is ended as a sleeping one (Hangs); in the slow run.
@pytest.mark.parametrize("agent, jobs", [("Hangs", "1"), ("Hangs", "2"),
                                         pytest.param("SpinsInC", "2", marks=pytest.mark.slow)])
def test_a_unit_over_the_time_limit_ends_the_study(agent, jobs, tmp_path, monkeypatch):
    """The limit is measured by a clock the test holds (``CLOCK_FILE``), in the parent's
    watchdog (--jobs 2) and in the serial executor's alarm (--jobs 1): it stands still while
    the study runs, so no unit runs over the limit on a loaded machine's account (the
    passive reference's once did, at load 4-6); the test moves it past the limit only once
    the hanging agent waits and the other units are done."""
    name = f"tests.helpers_faults:{agent}"
    args = _study(name, "--jobs", jobs, "--unit-time-limit", "0.5")
    gate = tmp_path / "gate"
    out = tmp_path / "study"
    clock = tmp_path / "clock"
    _set_clock(clock, 0.0)
    monkeypatch.setenv(CLOCK_FILE, str(clock))  # the study's processes read it
    proc = start_cli([*args, "--out", str(out)], gate)
    waiting = tmp_path / "gate.waiting"
    others = 1 if jobs == "2" else 0  # passive's unit, beside the hanging one
    deadline = time.monotonic() + 120  # only a guard against a hang
    while not (waiting.exists() and len(list((out / ".units").glob("*.npz"))) >= others):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.02)
    time.sleep(1.0)  # twice the limit of real time: the limit's clock stood still
    assert proc.poll() is None, proc.stderr.read()
    _set_clock(clock, 0.6)
    code, _, err = finish(proc, PROMPT)
    assert code == 1, err
    assert f"agent {name!r}, runs " in err and "Traceback" not in err
    assert "ran longer than the time limit of 0.5 s per unit of work" in err
    reference = tmp_path / "reference"
    _uninterrupted(args, reference, tmp_path / "open", monkeypatch)
    _resumed_identically(args, out, gate, reference)


def test_the_library_raises_a_unit_lost_error_naming_the_unit(monkeypatch):
    monkeypatch.delenv("HRI_TEST_GATE", raising=False)
    cfg = StudyConfig("wheel", agents=("tests.helpers_faults:KillsItself",), runs=4,
                      episodes=1, jobs=2, executor="process")
    seen = []
    with pytest.raises(UnitLostError) as info:
        run_study(cfg, on_result=lambda i, res: seen.append(i), keep_going=True)
    assert info.value.agent == "tests.helpers_faults:KillsItself"
    assert info.value.runs in ((0, 1), (2, 3)) and "killed (SIGKILL" in info.value.reason
    assert seen == []
    with pytest.raises(UnitLostError, match="time limit of 0.5 s"):
        run_study(StudyConfig("wheel", agents=("tests.helpers_faults:Hangs",), runs=2,
                              episodes=1, unit_time_limit=0.5))


@pytest.mark.parametrize("bad", [0, -1, float("nan"), "60", True])
def test_the_time_limit_is_checked(bad):
    with pytest.raises(ConfigError) as info:
        StudyConfig("wheel", unit_time_limit=bad)
    assert info.value.field == "unit_time_limit"
    assert StudyConfig("wheel", unit_time_limit=float("inf")).unit_time_limit == float("inf")


@pytest.mark.parametrize("bad", ["0", "-1", "nan", "soon"])
def test_the_time_limit_flag_is_checked(bad, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["study", "wheel", "--unit-time-limit", bad, "--out", str(tmp_path / "x")])
    assert exc.value.code == 2
    assert "argument --unit-time-limit: expected a number of seconds > 0, or inf" in \
        capsys.readouterr().err


def test_the_time_limit_changes_no_number_and_is_not_a_setting():
    a = StudyConfig("wheel", agents=("learner",), runs=2, episodes=2)
    b = StudyConfig("wheel", agents=("learner",), runs=2, episodes=2, unit_time_limit=99.0)
    assert a.settings() == b.settings()
    ra, rb = run_study(a), run_study(b)
    for key, values in ra.metrics["learner"].items():
        np.testing.assert_array_equal(values, rb.metrics["learner"][key], err_msg=key)


def test_the_default_time_limit_is_the_backends():
    """A unit on MuJoCo Warp batches up to 1,000 episodes into its worlds at its device's
    speed (4 runs of 2 episodes took 761 s on a CPU): no default limit there, which would
    stop a sound study as hung; 3600 s on the other backends; a given limit always wins."""
    assert StudyConfig("wheel").time_limit() == 3600.0
    assert StudyConfig("hanger", backend="mujoco").time_limit() == 3600.0
    assert StudyConfig("hanger", backend="mjwarp").time_limit() == math.inf
    assert StudyConfig("hanger", backend="mjwarp", unit_time_limit=5).time_limit() == 5.0
    assert StudyConfig("wheel", unit_time_limit=math.inf).time_limit() == math.inf
