"""The process an agent of your own runs in: it sees the robot's view and nothing else.

``python -m hri_bench.run.agent_host`` is started by :mod:`hri_bench.run.isolation` for each
``module:Class`` agent the benchmark runs. It reads messages (:mod:`hri_bench.run.wire`) on
its standard input and answers on its standard output (the agent's own prints go to standard
error). What it is told is all the agent can know (docs/agents.md, "Your agent runs in a
process of its own"):

* ``describe``: import the class and say what it is (its flavour, its name, whether it
  declares ``privileged = True``, the constructor keywords it is given), or why it cannot
  run;
* ``init``: make the agent for a batch of runs from the public task graph (by scenario
  name, after importing the modules the study imported for their registrations), the
  study's r0, reward rule, step limit and episodes, and one random stream per run
  (:data:`ISOLATED_CONTRACT`); never the human, the study's seed or the run indices;
* ``begin``, ``step``, ``end``: the episodes, one message per batched step (the previous
  transition travels with the next observation) and one answered per episode's end; the
  intention only to a privileged agent;
* ``close``: answer and end.

An error of the agent (any exception, ``sys.exit``) is answered to the next message that
expects an answer, with its type, message and traceback as text.
"""

from __future__ import annotations

import inspect
import os
import sys
import threading
import time
import traceback
from collections.abc import Mapping
from typing import Any, BinaryIO

import numpy as np

from agents.protocol import METHODS, Agent, BatchAgent, Batched, Trace, missing_methods
from hri_bench.run.wire import read_message, write_message
from hri_envs.errors import ActionError, ConfigError
from hri_envs.imports import import_class, import_modules

__all__ = ["ISOLATED_CONTRACT", "WITHHELD", "host_pipes", "isolated_keywords", "main"]

#: What an agent of your own may ask for by constructor keyword (docs/agents.md, "Your own
#: agent"). ``Agent`` classes (one per run) get ``rng``, ``BatchAgent`` classes (one per batch)
#: ``rngs``; both get the rest.
ISOLATED_CONTRACT: dict[str, str] = {
    "graph": "the public task graph (hri_envs.task.graph.TaskGraph)",
    "rng": "Agent: this run's generator, from a keyed hash of the study's seed and the run "
           "(hri_bench.run.isolation.agent_streams): it does not tell the run",
    "rngs": "BatchAgent: one generator per run of the batch, as rng",
    "r0": "the study's waiting reward r0",
    "reward": "the reward rule's name (hri_envs.task.episode.REWARD_RULES)",
    "max_steps": "the step limit per episode",
    "episodes": "episodes per run",
}
#: Keywords an agent of your own is never given: they would tell it which run, and so which
#: human, it faces.
WITHHELD: tuple[str, ...] = ("seed", "run", "runs", "human", "intention")


def isolated_keywords(cls: type) -> tuple[str, ...]:
    """The :data:`ISOLATED_CONTRACT` keywords ``cls``'s constructor is given: those it names,
    or all that fit its flavour when it takes ``**kwargs``.

    Raises:
        ConfigError: The constructor requires a keyword of :data:`WITHHELD` (one without a
            default): it could not be made (``field="agents"``).
    """
    params = inspect.signature(cls).parameters
    batch = issubclass(cls, BatchAgent)
    fits = [k for k in ISOLATED_CONTRACT if k != ("rng" if batch else "rngs")]
    if batch:
        fits.remove("graph")  # given by position
    required = [k for k in WITHHELD if k in params
                and params[k].default is inspect.Parameter.empty
                and params[k].kind in (inspect.Parameter.KEYWORD_ONLY,
                                       inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    if required:
        raise ConfigError(f"agent {cls.__module__}:{cls.__qualname__} requires "
                          f"{', '.join(required)} in its constructor; an agent of your own "
                          "is never told the study's seed, its runs or their humans (it "
                          f"may ask for {', '.join(fits)}; take rng/rngs for randomness; "
                          "docs/agents.md, \"Your own agent\")", field="agents")
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return tuple(fits)
    return tuple(k for k in fits if k in params and params[k].kind in (
        inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD))


def _load(spec: str) -> type[Agent] | type[BatchAgent]:
    cls: type[Agent] | type[BatchAgent] = import_class(spec, "agent", "agents",
                                                       (Agent, BatchAgent))
    missing = missing_methods(cls)
    if missing:
        raise ConfigError(f"agent {spec!r} does not implement {', '.join(missing)} of the agent "
                          f"protocol ({', '.join(METHODS)}; docs/agents.md, \"Your own "
                          "agent\")", field="agents")
    return cls


def _describe(spec: str) -> dict[str, Any]:
    cls = _load(spec)
    name = vars(cls).get("name") if isinstance(vars(cls).get("name"), str) else None
    return {"flavour": "batch" if issubclass(cls, BatchAgent) else "agent",
            "module": cls.__module__, "class": cls.__qualname__,
            "name": name or cls.__name__, "privileged": bool(getattr(cls, "privileged", False)),
            "keywords": list(isolated_keywords(cls))}


def _streams(entropy: np.ndarray) -> list[np.random.Generator]:
    return [np.random.default_rng(int.from_bytes(bytes(row), "big")) for row in entropy]


def _make(header: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> BatchAgent:
    from hri_envs.task.scenarios import scenario_graph

    import_modules(header.get("imports", ()))  # a scenario of the user's own, say
    cls = _load(header["spec"])
    graph = scenario_graph(header["scenario"])
    keys = isolated_keywords(cls)
    rngs = _streams(arrays["entropy"])
    given = {"graph": graph, **header["settings"]}
    if issubclass(cls, BatchAgent):
        if "rngs" in keys:
            given["rngs"] = rngs
        return cls(graph, len(rngs), **{k: given[k] for k in keys})  # type: ignore[call-arg,arg-type]

    def one(i: int) -> Agent:
        return cls(**{k: rngs[i] if k == "rng" else given[k] for k in keys})

    return Batched.from_factory(one, list(range(len(rngs))))


def _traces(arrays: Mapping[str, np.ndarray]) -> list[Trace]:
    lengths = arrays["lengths"]
    ends = np.cumsum(lengths)
    out = []
    for i, n in enumerate(lengths):
        a, b = int(ends[i] - n), int(ends[i])
        out.append(Trace(arrays["states"][a + i: b + i + 1], arrays["robot"][a:b],
                         arrays["human"][a:b]))
    return out


def _actions(value: Any, n: int) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "biuf" or arr.shape != (n,):
        raise ActionError(f"act() returned {arr.dtype} of shape {arr.shape}; expected one "
                          f"action per run, shape ({n},)")
    return arr


class _Session:
    """The agent of the current batch and what the next answer must report."""

    def __init__(self) -> None:
        self.agent: BatchAgent | None = None
        self.error: dict[str, str] | None = None

    def run(self, kind: str, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray]
            ) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
        """Handle one message; its answer (None: it expects none)."""
        if kind == "describe":
            return {"describe": _describe(header["spec"])}, {}
        if kind == "init":
            self.agent, self.error = None, None
            self.agent = _make(header, arrays)
            return {"name": str(getattr(self.agent, "name", ""))}, {}
        if self.error is not None or self.agent is None:
            return None if kind == "begin" else ({"error": self.error or {
                "type": "RuntimeError", "message": "no agent: init failed or never came",
                "traceback": ""}}, {})
        agent = self.agent
        if "t_state" in arrays:  # the previous step's transition
            agent.observe(arrays["t_state"], arrays["t_robot"], arrays["t_human"],
                          arrays["t_next"], arrays["t_active"])
        if kind == "begin":
            agent.begin_episode(arrays["starts"])
            return None
        if kind == "end":
            agent.end_episode(_traces(arrays), arrays["intentions"])
            return {}, {}
        out: dict[str, np.ndarray] = {}
        if header.get("belief"):
            held = getattr(agent, "belief", None)
            value = held() if callable(held) else None
            if value is not None:
                out["belief"] = np.asarray(value, dtype=float)
        if kind == "step":
            obs = {k[4:]: v for k, v in arrays.items() if k.startswith("obs.")}
            out["actions"] = _actions(agent.act(obs, arrays["active"]), agent.n_runs)
        return {}, out


def _failure(exc: BaseException) -> dict[str, str]:
    if isinstance(exc, SystemExit):
        return {"type": "SystemExit", "message": f"called sys.exit({exc.code!r})",
                "traceback": traceback.format_exc()}
    return {"type": type(exc).__name__, "message": str(exc),
            "traceback": traceback.format_exc()}


def _watch_parent(parent: int) -> None:
    """End this process when its parent is gone (killed, or its worker was)."""
    while True:
        time.sleep(0.5)
        if os.getppid() != parent:
            os._exit(1)


def host_pipes() -> tuple[BinaryIO, BinaryIO]:
    """A host process's pipes to its parent, taken off its standard input and output.

    Also used by :mod:`hri_bench.people.serve.lead_worker`.

    Returns:
        (inbox, outbox): the messages read and written. Standard input is then empty and
        standard output is standard error (what the code hosted prints never goes into the
        messages), and a thread ends this process when its parent is gone.
    """
    inbox = os.fdopen(os.dup(0), "rb")
    outbox = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # the hosted code's prints go to standard error, never into the messages
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    sys.stdout = sys.stderr
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True).start()
    return inbox, outbox


def main() -> None:
    """Serve one benchmark process until it closes the pipe or says ``close``."""
    inbox, outbox = host_pipes()
    session = _Session()
    physical: Any = None  # the physical suite's robot (hri_bench.run.physical_host)
    while True:
        try:
            header, arrays = read_message(inbox)
        except EOFError:
            return
        kind = header.get("kind")
        if kind == "close":
            write_message(outbox, {"closed": True})
            return
        if kind == "path":
            sys.path[:] = [p for p in header["sys_path"] if isinstance(p, str)]
            continue
        try:
            if str(kind).startswith("physical."):
                if physical is None:
                    from hri_bench.run.physical_session import PhysicalSession  # noqa: PLC0415

                    physical = PhysicalSession()
                answer = physical.run(str(kind), header, arrays)
            else:
                answer = session.run(str(kind), header, arrays)
        except BaseException as exc:  # the agent's: reported, never the end of the host
            failure = _failure(exc)
            if kind == "begin":
                session.error = failure
                continue
            if kind == "init":
                session.error = failure
            answer = ({"error": failure}, {})
        if answer is not None:
            write_message(outbox, *answer)


if __name__ == "__main__":
    main()
