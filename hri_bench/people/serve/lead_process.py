"""The server's side of a physical session's process (:mod:`~hri_bench.people.serve.lead_worker`).

Each physical session simulates in a process of its own: a step of the continuous env costs
a few milliseconds of Python, and ten sessions at 25 Hz would not fit in the server's one
interpreter; in processes of their own they share the machine's cores, and a robot that
hangs or dies takes its own session only (its process is killed: the session fails, named).
:class:`LeadProcess` starts one, sends it a request at a time and waits at most a given time
for the answer; :class:`SparePool` keeps one process started ahead (its imports done), so
that a participant who joins waits for the env to be built, not for Python to start.
"""

from __future__ import annotations

import select
import subprocess
import sys
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from hri_bench.people.serve import lead_worker
from hri_bench.people.serve.robot import AgentFailed, Stopped
from hri_bench.run.isolation import host_ended, kill_host
from hri_bench.run.wire import WireError, read_message, write_message

__all__ = ["LeadProcess", "SparePool"]


class LeadProcess:
    """A physical session's process; requests answered in turn, each within a time limit."""

    def __init__(self) -> None:
        self.process = subprocess.Popen(  # noqa: S603  # our own module, no shell
            [sys.executable, "-m", lead_worker.__name__], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, close_fds=True)
        self._stop: str | None = None
        self.hung = False

    def request(self, what: str, header: Mapping[str, Any],
                arrays: Mapping[str, np.ndarray] | None = None, *, timeout_s: float
                ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Send a request and wait for its answer.

        Raises:
            Stopped: The session was stopped meanwhile.
            AgentFailed: The answer says the robot or the simulation failed (its error), or
                no answer came within ``timeout_s`` (the process is killed), or the process
                ended.
        """
        if self._stop is not None:
            raise Stopped(self._stop)
        if self.hung:
            raise AgentFailed(f"the robot did not answer ({what})",
                              f"an earlier call hung; {what} not made")
        proc = self.process
        assert proc.stdin is not None and proc.stdout is not None
        try:
            write_message(proc.stdin, header, arrays)
        except (BrokenPipeError, OSError) as exc:
            raise AgentFailed("the session's simulation stopped", self._ended(exc)) from None
        deadline = time.monotonic() + timeout_s
        while True:
            ready, _, _ = select.select([proc.stdout], [], [], min(
                0.1, max(0.0, deadline - time.monotonic())))
            if ready:
                break
            if self._stop is not None:
                self.hung = True
                raise Stopped(self._stop)
            if time.monotonic() >= deadline:
                self.hung = True
                self.kill()
                raise AgentFailed(
                    f"the robot did not answer in time ({what} took over {timeout_s:g} s)",
                    f"the session's process did not answer {what} within {timeout_s:g} s "
                    "(--agent-timeout); killed")
        try:
            answer, out = read_message(proc.stdout)
        except (EOFError, WireError, OSError) as exc:
            raise AgentFailed("the session's simulation stopped", self._ended(exc)) from None
        if not answer.get("ok"):
            raise AgentFailed(str(answer.get("error", "the robot failed")),
                              str(answer.get("detail", answer.get("error"))))
        return answer, out

    def _ended(self, exc: BaseException) -> str:
        return host_ended(self.process, exc)

    def stop(self, status: str) -> None:
        """A request under way (or the next) gives up waiting: :class:`Stopped`."""
        self._stop = status

    def kill(self) -> None:
        """End the process now."""
        kill_host(self.process)

    def close(self) -> None:
        """Say ``close`` and wait a little for the process to end; kill it otherwise."""
        if self.process.poll() is None and not self.hung:
            try:
                assert self.process.stdin is not None
                write_message(self.process.stdin, {"op": "close"})
                self.process.wait(timeout=5)
            except (OSError, ValueError, subprocess.TimeoutExpired):
                pass
        self.kill()


class SparePool:
    """One :class:`LeadProcess` started ahead of the next session (started again after each
    :meth:`take`, in a thread, so that taking never waits for it).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._spare: LeadProcess | None = None
        self._closed = False
        self._refill()

    def _refill(self) -> None:
        def start() -> None:
            process = LeadProcess()
            with self._lock:
                if self._closed or self._spare is not None:
                    keep = False
                else:
                    self._spare, keep = process, True
            if not keep:
                process.close()

        threading.Thread(target=start, name="lead-spare", daemon=True).start()

    def take(self) -> LeadProcess:
        """A started process (the spare, or a new one)."""
        with self._lock:
            spare, self._spare = self._spare, None
        self._refill()
        if spare is not None and spare.process.poll() is None:
            return spare
        return LeadProcess()

    def close(self) -> None:
        """End the spare."""
        with self._lock:
            self._closed = True
            spare, self._spare = self._spare, None
        if spare is not None:
            spare.close()
