"""The robot's conformance check: whether an agent keeps the agent protocol.

:func:`check_agent` plays a few episodes of an agent in a scenario's robot env
(``gymnasium.make``-able, against its scripted human) and checks what the benchmark, the
envs and every other caller rely on (docs/agents.md): ``act`` returns an integer action the
state allows, the belief it may expose is a probability vector over the supports, it learns
from ``end_episode`` without failing, and two agents made alike act alike on the same
episodes (nothing random but through the generators it was given). The test suite runs it
over every built-in agent; docs/extending.md, "An agent", ends with it. The human's side
and the task's have theirs in :mod:`hri_envs.conformance`.

It takes a registered agent's name too, as the scenarios' and reward rules' checks take
theirs: the benchmark's registry of agents by name
(:func:`hri_bench.run.agents.register_agent`) sits above this package and adds itself to
:data:`NAMED` when it is imported (a module that registers an agent imports it).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from agents.protocol import Agent, BatchAgent, read_belief
from agents.rollout import run_episode
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph

__all__ = ["NAMED", "check_agent"]

#: What :func:`check_agent` takes: an agent class, or a factory ``make(graph) -> agent``.
AgentMaker = type[Agent] | type[BatchAgent] | Callable[[TaskGraph], Agent | BatchAgent]
#: Registries of agents by name: ``(names, maker)`` pairs, ``names()`` the names one knows
#: and ``maker(name)`` the factory of one (hri_bench.run.agents adds its own).
NAMED: list[tuple[Callable[[], list[str]], Callable[[str], AgentMaker]]] = []


def _named(name: str) -> AgentMaker:
    """The factory of the agent registered as ``name``."""
    for names, maker in NAMED:
        if name in names():
            return maker(name)
    known = [n for names, _ in NAMED for n in names()]
    raise ConfigError(f"unknown agent {name!r}; registered: {', '.join(known) or 'none yet'} "
                      "(an agent is registered with hri_bench.run.agents.register_agent: "
                      "import the module that registers it first)", field="agent")


def _single(maker: AgentMaker, graph: TaskGraph) -> Agent:
    """One agent for one stream, from a class or a factory."""
    make = cast(Any, maker)
    if isinstance(maker, type) and issubclass(maker, BatchAgent):
        made: Any = make(graph, 1)
    elif isinstance(maker, type) and issubclass(maker, Agent):
        try:
            made = make(graph=graph)
        except TypeError:
            made = make()
    else:
        made = make(graph)
    if isinstance(made, BatchAgent):
        if made.n_runs != 1:
            raise ConfigError(f"the agent made for one run has n_runs={made.n_runs}",
                              field="agent")
        return made.single()
    if not isinstance(made, Agent):
        raise ConfigError(f"an agent must be an agents.protocol.Agent or BatchAgent, got "
                          f"{type(made).__name__}", field="agent")
    if getattr(getattr(made, "batch", made), "privileged", False):
        raise ConfigError("the agent is privileged (it reads the intention, which the robot's "
                          "observation never holds): check_agent checks agents that act on "
                          "the robot's view", field="agent")
    return made


def check_agent(maker: AgentMaker | str, scenario: str = "hanger", *, episodes: int = 3,
                seed: int = 0, env_kwargs: dict[str, Any] | None = None,
                allow_invalid: bool = False) -> str:
    """Check an agent in ``scenario``'s robot env.

    Args:
        maker: A registered agent's name (``"learner"``, or one of your own registered with
            :func:`hri_bench.run.agents.register_agent`: made as a study makes it, for one
            run against the env's scripted human), an :class:`Agent` subclass (made as
            ``Class(graph=graph)`` or ``Class()``), a :class:`BatchAgent` subclass
            (``Class(graph, 1)``), or a factory ``make(graph)`` returning either.
        scenario: A registered scenario with a Gymnasium robot env.
        episodes: Episodes per agent (it learns across them).
        seed: The env's first seed.
        env_kwargs: More keywords of the env (e.g. ``human=HumanSpec(...)``).
        allow_invalid: Accept actions the state does not allow (they abort the step and
            cost r⁻ = -1; a learner that explores without the mask may take them).

    Raises:
        ConfigError: It cannot be made, ``act`` returns something other than an action
            the state allows (``field="action"``), its belief is not a probability vector
            over the supports (``field="belief"``), it fails, or two agents made alike act
            differently on the same episodes (``field="agent"``).
    """
    from hri_envs.envs.robot import RobotEnv

    if isinstance(maker, str):
        maker = _named(maker)

    def play() -> list[int]:
        env = RobotEnv(scenario, **(env_kwargs or {}))
        try:
            agent = _single(maker, env.graph)
        except ConfigError:
            raise
        except Exception as exc:  # the agent's own constructor
            raise ConfigError(f"the agent cannot be made: {type(exc).__name__}: {exc}",
                              field="agent") from exc
        actions: list[int] = []
        for e in range(episodes):
            try:
                result = run_episode(env, agent, seed=seed + e)
            except ConfigError:
                raise
            except Exception as exc:
                raise ConfigError(f"the agent failed in episode {e + 1}: "
                                  f"{type(exc).__name__}: {exc}", field="agent") from exc
            s = result.trace.states[:-1]
            bad = ~env.graph.valid[s, result.trace.robot_actions]
            if bad.any() and not allow_invalid:
                t = int(np.flatnonzero(bad)[0])
                raise ConfigError(f"the agent chose action {result.trace.robot_actions[t]} "
                                  f"in state {int(s[t])} of episode {e + 1}, where it is not "
                                  "valid (the observation's action_mask says which are)",
                                  field="action")
            try:
                belief = read_belief(getattr(agent, "batch", agent), None)
            except ConfigError:
                raise
            except Exception as exc:  # the agent's own belief()
                raise ConfigError(f"the agent's belief() failed after episode {e + 1}: "
                                  f"{type(exc).__name__}: {exc}", field="belief") from exc
            if belief is not None and np.asarray(belief).shape[-1] != env.graph.n_intentions:
                raise ConfigError(f"the agent's belief has {np.asarray(belief).shape[-1]} "
                                  f"entries; the scenario has {env.graph.n_intentions} "
                                  "supports", field="belief")
            actions += result.trace.robot_actions.tolist()
        return actions

    first = play()
    if play() != first:
        raise ConfigError("two agents made alike chose different actions on the same "
                          "episodes: draw randomness only from the generators you are given",
                          field="agent")
    return f"agent on the {scenario}: {episodes} episodes, {len(first)} valid actions, " \
           "reproducible"
