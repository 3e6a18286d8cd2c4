"""Which robot agents the benchmark can run, by name.

Built in: ``learner``, ``imitator``, ``maxent``, ``passive``, ``oracle``. Any other entry of
the form ``module:Class`` imports ``Class`` from ``module``: a :class:`~agents.protocol.Agent`
subclass is instantiated once per run (with ``graph=`` if its constructor accepts it), a
:class:`~agents.protocol.BatchAgent` subclass once per batch as ``Class(graph, n_runs)``.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Sequence
from typing import Any

from agents.config import default_config
from agents.learner import Learner
from agents.protocol import Agent, BatchAgent, Batched
from baselines import Imitator, MaxEntIRL, Oracle, Passive
from hri_envs.task.graph import TaskGraph
from hri_envs.task.humans import ScriptedHuman

__all__ = ["BUILTIN_AGENTS", "make_agent", "validate_agent_name"]

BUILTIN_AGENTS: tuple[str, ...] = ("learner", "imitator", "maxent", "passive", "oracle")


def validate_agent_name(name: str) -> None:
    """Raise ``ValueError`` naming the allowed agents when ``name`` is not one."""
    if name in BUILTIN_AGENTS:
        return
    if ":" in name and all(name.split(":", 1)):
        return
    raise ValueError(
        f"unknown agent {name!r}; allowed: {', '.join(BUILTIN_AGENTS)}, "
        "or 'module:Class' for your own agent"
    )


def _import(spec: str) -> Any:
    module, _, attr = spec.partition(":")
    try:
        return getattr(importlib.import_module(module), attr)
    except (ImportError, AttributeError) as exc:
        raise ValueError(f"cannot import agent {spec!r}: {exc}") from exc


def make_agent(
    name: str,
    graph: TaskGraph,
    human: ScriptedHuman,
    runs: Sequence[int],
    *,
    seed: int,
    r0: float,
) -> BatchAgent:
    """A batched agent for the given runs.

    Args:
        name: See the module docstring.
        graph: The task graph.
        human: The scripted human (the Oracle copies its preference).
        runs: Run indices of the batch (randomness derives from ``(seed, run)``).
        seed: Base seed.
        r0: The study's waiting reward, used by the Learner's robot reward.
    """
    validate_agent_name(name)
    n = len(runs)
    if name == "learner":
        return Learner(graph, n, default_config(graph.name, r0=r0), seed=seed, runs=runs)
    if name == "maxent":
        cfg = default_config(graph.name, r0=r0, learning_rate=0.03)
        return MaxEntIRL(graph, n, cfg, seed=seed, runs=runs)
    if name == "imitator":
        return Imitator(graph, n)
    if name == "passive":
        return Passive(graph, n)
    if name == "oracle":
        return Oracle(graph, human, n)
    cls = _import(name)
    if inspect.isclass(cls) and issubclass(cls, BatchAgent):
        return cls(graph, n)  # type: ignore[call-arg,arg-type]  # user class: documented signature
    if inspect.isclass(cls) and issubclass(cls, Agent):
        takes_graph = "graph" in inspect.signature(cls).parameters
        return Batched.from_factory(
            lambda run: cls(graph=graph) if takes_graph else cls(), runs  # type: ignore[call-arg]
        )
    raise ValueError(f"{name!r} is neither an agents.Agent nor an agents.BatchAgent subclass")
