"""The robot's calls, fenced: an agent that raises, exits or hangs ends its session only.

The robot's agent is code the server does not control (``module:Class``, ``sb3:PATH``). Each
session makes it and calls it (``begin_episode``, ``act``, ``observe``, ``end_episode``,
``belief``) through :class:`AgentWorker`: a daemon thread of the session's own that makes
each call in turn while the session's thread waits at most ``timeout_s`` seconds for it
(``--agent-timeout``, never longer than ``--idle-timeout``), telling the page after
:data:`SLOW_S` seconds that the robot is thinking. Whatever the call raises,
:class:`SystemExit` and :class:`KeyboardInterrupt` included, or a call that does not
return in time, comes back to the session as one :class:`AgentFailed` naming the call and
the error, and the session ends (``failed``) with that error on the page. A hung call's
thread cannot be stopped from outside: it is left waiting (a daemon thread, it does not
keep the server from exiting) with the agent it holds.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np

from agents.protocol import BatchAgent, Trace

__all__ = ["AgentFailed", "AgentWorker", "GuardedAgent", "Stopped"]

T = TypeVar("T")


class AgentFailed(Exception):
    """The robot's agent raised, exited or did not return in time.

    Attributes:
        public: What the participant's page says (the call and the error's type).
        detail: What the session's record and the server's log say (with the message).
    """

    def __init__(self, public: str, detail: str) -> None:
        super().__init__(detail)
        self.public, self.detail = public, detail


class Stopped(Exception):
    """The session was stopped (``status``: stopped, abandoned) while it waited."""

    def __init__(self, status: str) -> None:
        super().__init__(status)
        self.status = status


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().replace("\n", " ")
    kind = getattr(exc, "kind", type(exc).__name__)  # an agent in its own process: its error's
    return f"{kind}: {text[:300]}" if text else kind


#: Seconds a call of the agent may take before the session is told it is slow.
SLOW_S = 3.0
#: The clock of the calls' time limits (a test may put a fake clock in its place).
_clock = time.monotonic


class AgentWorker:
    """The thread that makes one session's calls of its agent, one at a time.

    Args:
        name: The thread's name.
        timeout_s: The longest a call may take.
        limit: The setting that sets ``timeout_s``, for messages.
        on_slow: Called (with the call's name, from the waiting thread) once a call has
            taken :data:`SLOW_S` seconds, so that the page can say the robot is busy.
    """

    def __init__(self, name: str, timeout_s: float, limit: str = "--agent-timeout",
                 on_slow: Callable[[str], None] | None = None) -> None:
        self.timeout_s = float(timeout_s)
        self.limit, self.on_slow = limit, on_slow
        self.hung = False
        self._stop: str | None = None
        self._calls: queue.SimpleQueue[tuple[Callable[[], Any], list[Any], threading.Event]
                                       | None] = queue.SimpleQueue()
        self.thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        while True:
            item = self._calls.get()
            if item is None:
                return
            fn, box, done = item
            try:
                box.append((True, fn()))
            except BaseException as exc:  # noqa: BLE001 (SystemExit too: the agent's, not ours)
                box.append((False, exc))
            del fn, item
            done.set()

    def call(self, what: str, fn: Callable[[], T]) -> T:
        """``fn()`` made in the worker thread; its value.

        Raises:
            AgentFailed: It raised (anything) or took longer than ``timeout_s``; or an
                earlier call hung.
        """
        if self._stop is not None:
            raise Stopped(self._stop)
        if self.hung:
            raise AgentFailed(f"the robot did not answer ({what})",
                              f"an earlier call of the agent hung; {what} not made")
        box: list[Any] = []
        done = threading.Event()
        started = _clock()
        self._calls.put((fn, box, done))
        deadline = started + self.timeout_s
        slow = self.on_slow
        while not done.wait(min(0.1, max(0.0, deadline - _clock()))):
            if self._stop is not None:  # the server stops: it does not wait for the call
                self.hung = True
                raise Stopped(self._stop)
            if slow is not None and _clock() - started >= SLOW_S:
                slow(what)
                slow = None
            if _clock() < deadline:
                continue
            self.hung = True
            raise AgentFailed(
                f"the robot did not answer in time ({what} took over {self.timeout_s:g} s)",
                f"the agent's {what} did not return within {self.timeout_s:g} s "
                f"({self.limit})")
        ok, value = box[0]
        if ok:
            return value
        kind = getattr(value, "kind", type(value).__name__)  # in its own process: its error's
        raise AgentFailed(f"the robot's program failed ({kind} in {what})",
                          f"the agent's {what} raised {_describe(value)}") from value

    def stop(self, status: str) -> None:
        """A call under way (or the next) gives up waiting: :class:`Stopped` (``status``)."""
        self._stop = status

    def close(self) -> None:
        """End the thread once it has made the calls handed in (a hung one never ends)."""
        self._calls.put(None)


class GuardedAgent(BatchAgent):
    """``inner``'s every call made through ``worker`` (see the module docstring)."""

    def __init__(self, inner: BatchAgent, worker: AgentWorker) -> None:
        super().__init__(inner.n_runs)
        self.inner, self.worker = inner, worker
        self.name = getattr(inner, "name", type(inner).__name__)  # type: ignore[misc]
        self.privileged = bool(getattr(inner, "privileged", False))

    def begin_episode(self, starts: np.ndarray) -> None:
        """The inner agent's, in the worker."""
        self.worker.call("begin_episode()", lambda: self.inner.begin_episode(starts))

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The inner agent's, in the worker."""
        return self.worker.call("act()", lambda: self.inner.act(observations, active))

    def observe(self, states: np.ndarray, robot_actions: np.ndarray,
                human_actions: np.ndarray, next_states: np.ndarray,
                active: np.ndarray) -> None:
        """The inner agent's, in the worker."""
        self.worker.call("observe()", lambda: self.inner.observe(
            states, robot_actions, human_actions, next_states, active))

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """The inner agent's (its learning), in the worker."""
        self.worker.call("end_episode()", lambda: self.inner.end_episode(traces, intentions))

    def belief(self) -> np.ndarray | None:
        """The inner agent's, in the worker (None when it has none)."""
        held = getattr(self.inner, "belief", None)
        if not callable(held):
            return None
        value: np.ndarray | None = self.worker.call("belief()", held)
        return value
