"""``hri-bench`` in a process of its own, for the tests that stop, kill or resume it
(tests/test_study_faults.py, test_study_workers.py, test_suite_resume.py)."""

import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def start_cli(args: list[str], gate: Path | None = None, **popen: Any) -> subprocess.Popen:
    """``python -m hri_bench.cli ARGS`` from the checkout, its output captured as text;
    ``gate``: the file the agents of tests/helpers_faults.py wait for (``$HRI_TEST_GATE``)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if gate is not None:
        env["HRI_TEST_GATE"] = str(gate)
    return subprocess.Popen([sys.executable, "-m", "hri_bench.cli", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            **popen)


def finish(proc: subprocess.Popen, timeout: float, what: str = "the study"
           ) -> tuple[int, str, str]:
    """Its exit status, output and errors; a process still running after ``timeout``
    seconds is killed and fails the test ("``what`` hung")."""
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"{what} hung (killed after {timeout} s)")
    return proc.returncode, out, err


def children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    kids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(entry.name))
    return kids
