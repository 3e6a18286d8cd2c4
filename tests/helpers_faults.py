"""Agents that end or stall their process, for the tests of dead and hung pool workers
(``module:Class`` agents of the study and suite tests).

Each waits (as :class:`tests.helpers_agents.AlwaysWait`) once the file named by
``$HRI_TEST_GATE`` exists; until then its first decision ends or stalls its process in its
own way. So a study dies with the gate closed and, resumed with the gate open, gives the
numbers an uninterrupted run with the gate open gives.
"""

import os
import signal
import time
from pathlib import Path

from tests.helpers_agents import AlwaysWait


def _closed() -> bool:
    gate = os.environ.get("HRI_TEST_GATE")
    return gate is None or not Path(gate).exists()


def _say_waiting() -> None:
    """Create ``$HRI_TEST_GATE.waiting``: the agent is about to wait without end."""
    gate = os.environ.get("HRI_TEST_GATE")
    if gate is not None:
        Path(f"{gate}.waiting").touch()


class ExitsProcess(AlwaysWait):
    """``os._exit(3)`` on its first decision: the process ends without a word."""

    def act(self, observation):
        if _closed():
            os._exit(3)
        return 0


class KillsItself(AlwaysWait):
    """SIGKILL to its own process (as the out-of-memory killer would)."""

    def act(self, observation):
        if _closed():
            os.kill(os.getpid(), signal.SIGKILL)
        return 0


class RaisesKeyboardInterrupt(AlwaysWait):
    """Raises ``KeyboardInterrupt`` from ``act``."""

    def act(self, observation):
        if _closed():
            raise KeyboardInterrupt("deliberate")
        return 0


class Hangs(AlwaysWait):
    """Sleeps (for an hour) on its first decision (saying so first: a test that holds the time
    limit's clock moves it on then)."""

    def act(self, observation):
        if _closed():
            _say_waiting()
            time.sleep(3600)
        return 0


class SpinsInC(AlwaysWait):
    """Waits without end in one call that holds no Python frame (``signal.sigwait`` on a
    signal that never comes): only a process that can be killed ends it.
    """

    def act(self, observation):
        if _closed():
            _say_waiting()
            signal.pthread_sigmask(signal.SIG_BLOCK, [signal.SIGUSR2])
            signal.sigwait([signal.SIGUSR2])
        return 0


class WaitsOnWheel(AlwaysWait):
    """On the wheel, waits in ``act`` until the gate opens (at most 120 s); on the hanger it
    waits as AlwaysWait: a suite runs its hanger tracks, then stays in its first wheel track
    while a test interrupts it.
    """

    def __init__(self, graph):
        self.wheel = graph.name == "wheel"

    def act(self, observation):
        deadline = time.monotonic() + 120
        while self.wheel and _closed() and time.monotonic() < deadline:
            time.sleep(0.01)
        return 0
