"""Agents of your own in a process of their own: the benchmark's side of the host.

Every ``module:Class`` agent runs in a :mod:`hri_bench.run.agent_host` process, started with
``subprocess`` (never forked from the benchmark: it inherits none of its objects) and spoken
to in the fixed message format of :mod:`hri_bench.run.wire` (JSON and raw arrays; nothing
is unpickled on either side). :class:`IsolatedAgent` is the :class:`~agents.protocol.
BatchAgent` the benchmark's loop drives: it forwards what the robot may see and nothing
else, one message per batched step (:meth:`IsolatedAgent.decide`: the previous transition,
the observation, the belief and the actions in one round trip). The module's classes are
never imported here: :func:`describe` asks the host what the class is.

Each run's random stream comes from :func:`agent_streams`: HMAC-SHA256 keyed by the study's
seed of the run's index, so an agent that does not know the seed cannot tell which run (and
so which human) it faces. The suite's default seed is public: ``hri-bench validate --fresh``
re-runs a results file's agents on a seed the verifier draws (docs/results.md).

A host serves one agent object at a time: when the object is gone, its host waits for the
next agent of the same class (each batch gets a new agent object in the same host; two
sessions of a server, in threads, get a host each); every host ends with the process.
``HRI_BENCH_IN_PROCESS_AGENTS=1`` makes the same agents in the benchmark's own process
instead (with the same constructor keywords and streams), for a debugger; the command line
never sets it.
"""

from __future__ import annotations

import atexit
import hashlib
import hmac
import os
import subprocess
import sys
import threading
import weakref
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from agents.protocol import BatchAgent, Trace
from hri_bench.run import agent_host
from hri_bench.run.wire import WireError, read_message, write_message
from hri_envs.errors import ActionError, ConfigError
from hri_envs.imports import imported_modules, with_cwd_on_path
from hri_envs.task.graph import TaskGraph

__all__ = ["IN_PROCESS", "AgentProcessError", "IsolatedAgent", "acquire_host", "agent_streams",
           "ask_host", "describe", "host_ended", "kill_host", "make_isolated", "release_host",
           "shutdown"]

#: The environment variable that runs agents of your own in the benchmark's process.
IN_PROCESS = "HRI_BENCH_IN_PROCESS_AGENTS"


class AgentProcessError(RuntimeError):
    """An agent's process failed: the agent raised (the message has its traceback) or the
    process ended.

    Attributes:
        kind: The name of the exception the agent raised there ("SystemExit" for
            ``sys.exit``), or this class's name when its process ended.
    """

    def __init__(self, message: str, kind: str = "AgentProcessError") -> None:
        super().__init__(message)
        self.kind = kind


def agent_entropy(seed: int, runs: Sequence[int]) -> np.ndarray:
    """(len(runs), 32) bytes: HMAC-SHA256 keyed by ``seed`` of each run's index."""
    key = str(int(seed)).encode()
    rows = [hmac.new(key, str(int(r)).encode(), hashlib.sha256).digest() for r in runs]
    return np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(len(rows), 32).copy()


def agent_streams(seed: int, runs: Sequence[int]) -> list[np.random.Generator]:
    """The generator an agent of your own gets for each run (:func:`agent_entropy`)."""
    return [np.random.default_rng(int.from_bytes(bytes(row), "big"))
            for row in agent_entropy(seed, runs)]


def host_ended(process: subprocess.Popen[bytes], exc: BaseException) -> str:
    """Why a host process no longer answers (``exc``: what reading or writing raised): how
    it ended, given 2 s to end, or that it stopped answering.

    Also used by :mod:`hri_bench.people.serve.lead_process`.
    """
    try:
        code = process.wait(timeout=2)
    except subprocess.TimeoutExpired:
        return f"its process stopped answering ({exc})"
    return (f"its process was killed (signal {-code})" if code < 0
            else f"its process ended with exit status {code}")


def kill_host(process: subprocess.Popen[bytes]) -> None:
    """Kill a host process now (if it runs), reap it and close its pipes."""
    if process.poll() is None:
        process.kill()
    process.wait()
    for f in (process.stdin, process.stdout):
        if f is not None:
            f.close()


class _Host:
    """One agent host process and its pipes."""

    def __init__(self) -> None:
        self.process = subprocess.Popen(  # noqa: S603  # our own module, no shell
            [sys.executable, "-m", agent_host.__name__], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, close_fds=True)
        self.pid = os.getpid()
        with_cwd_on_path()  # the user's modules, importable from the folder run in
        self.send({"kind": "path", "sys_path": list(sys.path)})

    def send(self, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None
             ) -> None:
        assert self.process.stdin is not None
        try:
            write_message(self.process.stdin, header, arrays)
        except (BrokenPipeError, OSError) as exc:
            raise AgentProcessError(self._ended(exc)) from None

    def request(self, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None
                ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        self.send(header, arrays)
        assert self.process.stdout is not None
        try:
            return read_message(self.process.stdout)
        except (EOFError, WireError, OSError) as exc:
            raise AgentProcessError(self._ended(exc)) from None

    def _ended(self, exc: BaseException) -> str:
        return host_ended(self.process, exc)

    def kill(self) -> None:
        kill_host(self.process)

    def close(self) -> None:
        try:
            self.request({"kind": "close"})
            self.process.wait(timeout=5)
        except (AgentProcessError, subprocess.TimeoutExpired, ValueError):
            pass
        self.kill()


#: Idle hosts per agent (started by this process), and every host started.
_IDLE: dict[str, list[_Host]] = {}
_ALL: list[_Host] = []
_LOCK = threading.Lock()
_DESCRIBED: dict[str, dict[str, Any]] = {}


def acquire_host(spec: str) -> _Host:
    """An idle host of ``spec`` started by this process, or a new one: an agent object has
    a host to itself (two sessions of a server, in threads, never share one).
    """
    with _LOCK:
        idle = _IDLE.setdefault(spec, [])
        while idle:
            host = idle.pop()
            if host.pid == os.getpid() and host.process.poll() is None:
                return host
    host = _Host()
    with _LOCK:
        _ALL.append(host)
    return host


def release_host(spec: str, host: _Host) -> None:
    """``host`` is free for the next agent of ``spec`` (a dead one is forgotten)."""
    if host.pid == os.getpid() and host.process.poll() is None:
        with _LOCK:
            _IDLE.setdefault(spec, []).append(host)


@atexit.register
def shutdown() -> None:
    """End every host this process started."""
    with _LOCK:
        hosts, _ALL[:] = list(_ALL), []
        _IDLE.clear()
    for host in hosts:
        if host.pid == os.getpid():
            host.close()


def _raise(spec: str, error: Mapping[str, str]) -> None:
    kind, message = error.get("type", "Error"), error.get("message", "")
    if kind == "ConfigError":
        raise ConfigError(message, field="agents")
    if kind == "ActionError":
        raise ActionError(message)
    if kind == "SystemExit":
        raise AgentProcessError(f"agent {spec!r} {message}\n{error.get('traceback', '')}"
                                .rstrip(), kind)
    raise AgentProcessError(f"agent {spec!r} raised {kind}: {message}\n"
                            f"{error.get('traceback', '')}".rstrip(), kind)


def ask_host(spec: str, host: _Host, header: Mapping[str, Any],
         arrays: Mapping[str, np.ndarray] | None = None
         ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """One request to ``host``; a host that failed mid-request is ended (an answer it may
    still send would be read as the next one's).
    """
    try:
        answer, arrays_back = host.request(header, arrays)
    except BaseException:
        host.kill()
        raise
    if "error" in answer:
        _raise(spec, answer["error"])
    return answer, arrays_back


def describe(spec: str) -> dict[str, Any]:
    """What ``module:Class`` is, as its host imports it: ``flavour`` ("agent" or "batch"),
    ``module``, ``class``, ``name``, ``privileged`` and ``keywords`` (cached per process).

    Raises:
        ConfigError: The class does not import, is not an agent, misses a method of the
            protocol or requires a keyword it is never given (``field="agents"``).
    """
    if spec not in _DESCRIBED:
        if os.environ.get(IN_PROCESS) == "1":
            _DESCRIBED[spec] = agent_host._describe(spec)
        else:
            host = acquire_host(spec)
            try:
                answer = ask_host(spec, host, {"kind": "describe", "spec": spec})[0]
            finally:
                release_host(spec, host)  # an answer (an error too) leaves it ready
            _DESCRIBED[spec] = answer["describe"]
    return _DESCRIBED[spec]


class IsolatedAgent(BatchAgent):
    """A ``module:Class`` agent for one batch of runs, in its host process.

    Args:
        spec: ``module:Class``.
        graph: The task graph (its scenario is sent; the host builds the same public graph).
        seed: The study's seed (keys the runs' streams; never sent).
        runs: The batch's runs (never sent).
        settings: ``r0``, ``reward``, ``max_steps``, ``episodes``.
    """

    name: ClassVar[str] = "agent"

    def __init__(self, spec: str, graph: TaskGraph, seed: int, runs: Sequence[int],
                 settings: Mapping[str, Any]) -> None:
        super().__init__(len(runs))
        info = describe(spec)
        self.spec = spec
        self.name = info["name"]  # type: ignore[misc]
        self.privileged = bool(info["privileged"])
        self._pending: dict[str, np.ndarray] = {}
        self._belief: np.ndarray | None = None
        self._known = False  # whether _belief is the agent's belief now
        self._host = acquire_host(spec)
        weakref.finalize(self, release_host, spec, self._host)  # free when this agent is gone
        self._ask({"kind": "init", "spec": spec, "scenario": graph.name,
                   "settings": dict(settings), "imports": list(imported_modules())},
                  {"entropy": agent_entropy(seed, runs)})

    def _ask(self, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None
             ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        return ask_host(self.spec, self._host, header, arrays)

    def _send(self, kind: str, arrays: dict[str, np.ndarray]) -> None:
        arrays.update(self._pending)
        self._pending = {}
        try:
            self._host.send({"kind": kind}, arrays)
        except BaseException:
            self._host.kill()
            raise

    def begin_episode(self, starts: np.ndarray) -> None:
        """Start the batch's episodes (no answer awaited)."""
        self._belief, self._known = None, False
        self._send("begin", {"starts": np.asarray(starts)})

    def decide(self, observations: Mapping[str, np.ndarray], active: np.ndarray,
               belief: bool) -> np.ndarray:
        """One step in one message: the previous transition, then (if ``belief``) the
        agent's belief, then its actions for ``observations``. The belief is kept for
        :meth:`belief`.
        """
        arrays = {f"obs.{k}": np.asarray(v) for k, v in observations.items()}
        arrays["active"] = np.asarray(active, dtype=bool)
        arrays.update(self._pending)
        self._pending = {}
        _, back = self._ask({"kind": "step", "belief": bool(belief)}, arrays)
        self._belief, self._known = back.get("belief"), bool(belief)
        return back["actions"]

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The batch's actions (:meth:`decide` without the belief)."""
        return self.decide(observations, active, False)

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Kept, and sent with the next message."""
        self._belief, self._known = None, False
        self._pending = {"t_state": np.asarray(states), "t_robot": np.asarray(robot_actions),
                         "t_human": np.asarray(human_actions),
                         "t_next": np.asarray(next_states),
                         "t_active": np.asarray(active, dtype=bool)}

    def belief(self) -> np.ndarray | None:
        """The belief :meth:`decide` brought; else asked for (one round trip)."""
        if not self._known:
            arrays = dict(self._pending)
            self._pending = {}
            _, back = self._ask({"kind": "belief", "belief": True}, arrays)
            self._belief, self._known = back.get("belief"), True
        return self._belief

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """The episode's traces and the intentions revealed (answered: an error of the
        agent's learning is reported here).
        """
        arrays = dict(self._pending)
        self._pending = {}
        arrays.update(
            states=np.concatenate([t.states for t in traces]),
            robot=np.concatenate([t.robot_actions for t in traces]),
            human=np.concatenate([t.human_actions for t in traces]),
            lengths=np.array([len(t.robot_actions) for t in traces], dtype=np.int64),
            intentions=np.asarray(intentions))
        self._ask({"kind": "end"}, arrays)
        self._belief, self._known = None, False


def make_isolated(spec: str, graph: TaskGraph, seed: int, runs: Sequence[int],
                  settings: Mapping[str, Any]) -> BatchAgent:
    """The agent ``spec`` for a batch of runs: in its host (:class:`IsolatedAgent`), or made
    here when :data:`IN_PROCESS` is "1" (same keywords and streams).
    """
    if os.environ.get(IN_PROCESS) != "1":
        return IsolatedAgent(spec, graph, seed, runs, settings)
    header = {"spec": spec, "scenario": graph.name, "settings": dict(settings)}
    agent = agent_host._make(header, {"entropy": agent_entropy(seed, runs)})
    agent.privileged = bool(describe(spec)["privileged"])  # type: ignore[attr-defined]
    return agent
