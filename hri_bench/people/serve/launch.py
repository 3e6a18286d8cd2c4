"""``hri-bench serve`` as a process of its own, for the load benchmark, the docs' screenshots
and the tests that drive it from outside (a browser, websocket clients, ``kill -9``).

    proc, url, lines = start_serve(["hanger", "--port", "0", "--data", data])
    try:
        ...  # url is "http://127.0.0.1:PORT/", or None when it did not start (see lines)
    finally:
        stop_serve(proc)
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Sequence

_SERVING = re.compile(r"serving on (http://127\.0\.0\.1:\d+/)")


def start_serve(args: Sequence[str], timeout: float = 120.0
                ) -> tuple[subprocess.Popen[str], str | None, list[str]]:
    """Start ``hri-bench serve *args`` and read its output until it says where it serves.

    Args:
        args: the arguments after ``serve`` (the scenario first); give ``--port 0`` (a free
            port) and ``--host 127.0.0.1`` (the default) for a URL to be found.
        timeout: seconds to wait for the URL; checked between lines of output.

    Returns:
        The process (its output is a pipe, unbuffered; the rest is left unread), the URL it
        serves on (``http://127.0.0.1:PORT/``), and the lines it printed up to there. The URL
        is None when the process ended first (it has then ended: its return code is set) or
        the time ran out (it is then killed).
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "hri_bench.cli", "serve", *args],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert proc.stdout is not None
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            proc.wait(timeout)
            return proc, None, lines
        lines.append(line)
        found = _SERVING.search(line)
        if found:
            return proc, found.group(1), lines
    proc.kill()
    proc.wait()
    return proc, None, lines


def stop_serve(proc: subprocess.Popen[str], timeout: float = 60.0) -> bool:
    """Stop a server as Ctrl-C does (SIGINT); kill it if it has not ended in ``timeout`` s.

    Returns:
        Whether it ended on Ctrl-C (False: it had to be killed).
    """
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return False
    return True
