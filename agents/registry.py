"""The agents the benchmark knows by name: :class:`AgentSpec`, its registry :data:`AGENTS`
and :func:`register_agent` (docs/extending.md, "An agent").

The registry sits here, beside the agent protocol and its conformance check
(:func:`agents.conformance.check_agent`), as every kind's registry sits in its own package
(:class:`hri_envs.registry.Registry`). The built-in agents, made of this package's Learner
and of :mod:`baselines`, are registered by :mod:`hri_bench.run.builtin_agents`, which
:mod:`hri_bench.run.agents` imports; that module also resolves the names that are not
registered (``sb3:PATH``, ``jaxppo[:PATH]``, ``module:Class``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from agents.protocol import BatchAgent
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.registry import Registry
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import ScenarioSpec

__all__ = ["AGENTS", "JAXPPO", "ROLES", "AgentContext", "AgentSpec", "agent_spec",
           "register_agent"]

#: The agent name that plays the JAX PPO checkpoints shipped with the package
#: (:data:`hri_bench.run.agents.JAXPPO_CHECKPOINTS`): a form of its own, never registered.
JAXPPO = "jaxppo"
#: What an agent is: a learner, a baseline, or a reference (a bound the suites add where it
#: fits and never rank).
ROLES: tuple[str, ...] = ("learner", "baseline", "reference")


@dataclass(frozen=True)
class AgentContext:
    """What the benchmark hands an agent's maker: one batch of a study's runs.

    Attributes:
        graph: The task graph (it knows its scenario: ``graph.spec``).
        human: The scripted human, or the runs' humans (the Oracle and the references read
            their models).
        runs: The batch's run indices (randomness derives from ``(seed, run)``).
        seed: The study's base seed.
        r0: The study's waiting reward.
        learner: Changes to the Learner's configuration (``--learner-*``).
        max_steps: The step limit per episode.
        reward: The reward rule's name.
        episodes: Episodes per run.
    """

    graph: TaskGraph
    human: ScriptedHuman | BatchHuman
    runs: tuple[int, ...]
    seed: int
    r0: float
    learner: dict[str, Any]
    max_steps: int
    reward: str
    episodes: int


@dataclass(frozen=True)
class AgentSpec:
    """A robot agent the benchmark knows by name (docs/extending.md, "An agent").

    Attributes:
        name: Registry key (``--agents NAME``).
        make: ``make(context) -> BatchAgent`` for one batch of runs (:class:`AgentContext`).
        role: "learner", "baseline" or "reference" (a bound the suites add where it fits
            and never rank).
        intention_blind: It must infer the intention (``blind`` is its ceiling); False for
            an agent that sees ι (the Oracle, ``informed``).
        plans: It plans with the human's model (a reference: refused for humans without one).
        shared_human: It plans for one human shared by every run (a study groups its runs by
            the human's preference for it).
        description: One line for help texts.
        settings: ``settings(spec, r0, learner) -> dict | None``: what ``summary.json``
            records of its configuration on the scenario ``spec`` (a
            :class:`~hri_envs.task.scenarios.ScenarioSpec`; None: nothing).
        warm: Called once before a study forks its workers (e.g. to load compiled kernels
            the workers then inherit); None: nothing to do.
    """

    name: str
    make: Callable[[AgentContext], BatchAgent]
    role: str = "baseline"
    intention_blind: bool = True
    plans: bool = False
    shared_human: bool = False
    description: str = ""
    settings: Callable[[ScenarioSpec, float, dict[str, Any]], dict[str, Any] | None] | None = None
    warm: Callable[[], Any] | None = None


def _check(spec: AgentSpec) -> None:
    """What :func:`register_agent` checks (its docstring)."""
    if ":" in spec.name or spec.name == JAXPPO:
        raise ConfigError(f"agent name {spec.name!r} is taken by a form of its own "
                          "(module:Class, sb3:PATH, jaxppo[:PATH]); choose another",
                          field="agents")
    if spec.role not in ROLES:
        raise ConfigError(f"agent {spec.name!r}: role {spec.role!r} is not one of "
                          f"{', '.join(ROLES)}", field="agents")
    if not callable(spec.make):
        raise ConfigError(f"agent {spec.name!r}: make must be a function make(context) -> "
                          "BatchAgent", field="agents")


#: The agents the benchmark knows by name (:func:`register_agent`; a
#: :class:`~hri_envs.registry.Registry`).
AGENTS: Registry[AgentSpec] = Registry("agent", AgentSpec, field="agents", check=_check)


def register_agent(spec: AgentSpec, *, replace: bool = False) -> AgentSpec:
    """Make an agent known to ``hri-bench study --agents`` and ``suite --agents``; returns
    it. A published suite's agents are listed by value and never change with this.

    Args:
        spec: The agent.
        replace: Replace the agent registered under its name (otherwise refused).

    Raises:
        ConfigError: ``spec`` is not an :class:`AgentSpec`, its name has a ``:`` (the form
            of ``module:Class``, ``sb3:PATH``) or is another agent's (and ``replace`` is
            False), its role is not one of :data:`ROLES`, or ``make`` is not callable
            (``field="agents"``).
    """
    return AGENTS.register(spec, replace=replace)


def agent_spec(name: str) -> AgentSpec:
    """The registered agent ``name``.

    Raises:
        ConfigError: ``name`` is not registered; the message lists the registered agents
            (:func:`hri_bench.run.agents.validate_agent_name` also knows the forms that are
            not registered).
    """
    return AGENTS.get(name)
