"""A study killed again and again while it writes its files, then resumed (issue 24).

Every kill happens at one step of the writing phase: an audit hook (:func:`sys.addaudithook`)
counts the file-system operations that write (open for writing, rename, remove, mkdir,
rmtree, ...) from the first one of the final write, and at step k the study's process sends
itself SIGKILL or SIGINT. Each trial kills a study at step k, kills its next two resumes at
random steps, and resumes it once more; all the while:

- no run hangs (each has a timeout);
- a final file is either absent or byte-identical to an uninterrupted run's, and
  ``summary.json`` (written last) only comes with all the others;
- ``run_log.jsonl`` is whole lines of JSON, and says "complete" only once every file is in
  place and the unit files are gone;
- after the last resume: exit 0, the files byte-identical, no ``*.tmp``, ``.plots-*``,
  ``.units`` or ``.lock`` left.

The studies run in forked children of the test process (no interpreter start-up per kill),
with two agents × 4 runs × 2 episodes, ``--jobs 2`` (a resume with nothing to simulate must
start no pool) and cheap stand-in plots. The default run kills each write step once (over
50 kills in all); the slow tests kill each step with both signals and at random moments.
"""

import itertools
import json
import os
import random
import shutil
import signal
import sys
import time
import traceback
from pathlib import Path

import pytest

from hri_bench.cli import main
from hri_bench.core import plots

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")

STUDY = ["study", "hanger", "--runs", "4", "--episodes", "2", "--agents", "learner,passive",
         "--jobs", "2", "--no-progress"]
FINAL = ("summary.json", "episodes.csv", "reward.png", "decisions.png")
#: Audit events of operations that can write; "open" only when opened for writing.
_WRITES = {"open", "os.rename", "os.remove", "os.rmdir", "os.mkdir", "os.truncate",
           "shutil.rmtree", "tempfile.mkstemp", "tempfile.mkdtemp"}
_WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC
#: Seconds any one run of the tiny study may take before it counts as a hang.
TIMEOUT = 60


def _writes(event, args):
    if event not in _WRITES:
        return False
    if event != "open":
        return True
    mode, flags = args[1], args[2]
    return any(c in mode for c in "wax+") if isinstance(mode, str) else bool(flags & _WRITE_FLAGS)


def _stand_in_plots(result, out):
    """Two small files per study, as plots.study_plots writes them (matplotlib is slow)."""
    paths = []
    for name in ("reward.png", "decisions.png"):
        (out / name).write_bytes(f"{name} {sorted(result.metrics)}".encode())
        paths.append(out / name)
    return paths


def _run(argv, log, *, kill_at=None, sig=signal.SIGKILL, steps_file=None, after=None):
    """Run ``hri-bench argv`` in a forked child; with ``kill_at``, the child sends itself
    ``sig`` at that write step of its final write; with ``after``, the parent sends it
    ``sig`` after that many seconds. Return (killed, exit code).
    """
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 97
        try:
            with open(log, "a") as f:
                os.dup2(f.fileno(), 1)
                os.dup2(f.fileno(), 2)
            sys.stdout = sys.stderr = open(1, "w", closefd=False)  # noqa: SIM115
            steps = itertools.count(1)
            seen = []

            def hook(event, args):
                if not _writes(event, args):
                    return
                if seen or (event == "os.mkdir" and ".plots-" in str(args[0])):
                    seen.append(event)
                    if next(steps) == kill_at:
                        os.kill(os.getpid(), sig)

            sys.addaudithook(hook)
            code = main(argv)
            if steps_file is not None:
                Path(steps_file).write_text(str(len(seen)))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 96
        except BaseException:
            traceback.print_exc()
            code = 95
        finally:
            sys.stdout.flush()
            os._exit(code)
    if after is not None:
        time.sleep(after)
        os.kill(pid, sig)  # a child that has just ended is a zombie: no error
    deadline = time.monotonic() + TIMEOUT
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            pytest.fail(f"hri-bench {' '.join(argv)} hung (killed after {TIMEOUT} s); "
                        f"see {log}")
        time.sleep(0.002)
    if os.WIFSIGNALED(status):
        return os.WTERMSIG(status) == sig, -os.WTERMSIG(status)
    code = os.WEXITSTATUS(status)
    return sig == signal.SIGINT and code == 130, code


def _log(out):
    path = out / "run_log.jsonl"
    lines = path.read_text().splitlines() if path.exists() else []
    return [json.loads(line) for line in lines]  # a torn line fails here


def _check(out, reference):
    """What must hold after any kill."""
    present = [name for name in FINAL if (out / name).exists()]
    for name in present:
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    if "summary.json" in present:
        assert present == list(FINAL), "summary.json before the other files"
    statuses = [entry["status"] for entry in _log(out)]
    assert set(statuses) <= {"complete", "interrupted"}, statuses
    if "complete" in statuses:
        assert present == list(FINAL) and not (out / ".units").exists(), \
            "run_log says complete before every file is in place"


def _check_resumed(out, reference):
    """What must hold after a resume that was not killed."""
    _check(out, reference)
    assert _log(out)[-1]["status"] == "complete"
    assert sorted(p.name for p in out.iterdir()) == sorted([*FINAL, "run_log.jsonl"])
    assert not list(out.rglob("*.tmp*"))


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """An uninterrupted run, a study killed at the first step of its final write (every
    unit simulated), and the number of write steps of a resume's final write.
    """
    root = tmp_path_factory.mktemp("kills")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plots, "study_plots", _stand_in_plots)
        reference = root / "reference"
        assert main([*STUDY, "--out", str(reference)]) == 0  # in-process: imports everything
        template = root / "template"
        log = root / "template.log"
        assert _run([*STUDY, "--out", str(template)], log, kill_at=1) == (True, -9)
        assert not any((template / name).exists() for name in FINAL)
        counted = root / "counted"
        shutil.copytree(template, counted)
        steps_file = root / "steps"
        assert _run([*STUDY, "--out", str(counted), "--resume"], log,
                    steps_file=steps_file)[1] == 0
        _check_resumed(counted, reference)
        yield reference, template, int(steps_file.read_text()), root


def _trials(tiny, first, steps, seed):
    """For each of ``steps``: kill a study at that step with signal ``first``, kill two
    resumes in a row at random steps (the other signal, then ``first``), resume it; return
    the kills.
    """
    reference, template, n_steps, root = tiny
    second = signal.SIGINT if first == signal.SIGKILL else signal.SIGKILL
    rng = random.Random(seed)
    kills = 0
    for k in steps:
        out = root / f"{first.name}-{k}"
        log = root / f"{first.name}-{k}.log"
        shutil.copytree(template, out)
        resume = [*STUDY, "--out", str(out), "--resume"]
        killed, code = _run(resume, log, kill_at=k, sig=first)
        assert killed, f"the kill at write step {k} of {n_steps} did not happen ({code})"
        kills += 1
        _check(out, reference)
        # Resumes killed in turn (unless the first kill left nothing to write).
        for sig in (second, first):
            killed, code = _run(resume, log, kill_at=rng.randint(1, n_steps), sig=sig)
            assert killed or code == 0, (code, log.read_text())
            kills += killed
            _check(out, reference)
        assert _run(resume, log)[1] == 0, log.read_text()
        _check_resumed(out, reference)
        shutil.rmtree(out)
    return kills


@pytest.mark.parametrize("first", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_kills_while_writing_are_resumed_truthfully(first, tiny, monkeypatch):
    """Every write step is killed once, by SIGKILL (odd steps) or SIGINT (even ones), and
    so are most resumes: over 50 writing-phase kills in the two halves.
    """
    monkeypatch.setattr(plots, "study_plots", _stand_in_plots)
    n_steps = tiny[2]
    assert n_steps >= 20  # the plots, the CSV, the summary, the units, the log, the lock
    odd = first == signal.SIGKILL
    kills = _trials(tiny, first, range(1 if odd else 2, n_steps + 1, 2), seed=first)
    assert kills >= 25


@pytest.mark.slow
@pytest.mark.parametrize("first", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_every_write_step_killed_by_either_signal(first, tiny, monkeypatch):
    monkeypatch.setattr(plots, "study_plots", _stand_in_plots)
    n_steps = tiny[2]
    assert _trials(tiny, first, range(1, n_steps + 1), seed=first + 100) >= 50


@pytest.mark.slow
def test_kills_at_random_moments_of_a_resume(tiny, monkeypatch):
    """SIGKILL from outside at random moments of resumes (within a computation, a write,
    an fsync), chained until one resume ends; every state checked as above.
    """
    monkeypatch.setattr(plots, "study_plots", _stand_in_plots)
    reference, template, _, root = tiny
    rng = random.Random(24)
    out, log = root / "random", root / "random.log"
    t = time.monotonic()
    shutil.copytree(template, out)
    assert _run([*STUDY, "--out", str(out), "--resume"], log)[1] == 0
    duration = time.monotonic() - t
    kills = 0
    while kills < 50:
        shutil.rmtree(out)
        shutil.copytree(template, out)
        resume = [*STUDY, "--out", str(out), "--resume"]
        for _ in range(3):
            killed, code = _run(resume, log, after=rng.uniform(0.0, duration))
            assert killed or code == 0, (code, log.read_text())
            kills += killed
            _check(out, reference)
        assert _run(resume, log)[1] == 0, log.read_text()
        _check_resumed(out, reference)
