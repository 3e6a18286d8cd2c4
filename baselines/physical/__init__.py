"""The robots of the continuous physical envs (``*PandaContinuous-v1``), by name.

:data:`PHYSICAL_AGENTS` is what the physical evaluation reads
(``benchmarks/physical_baselines.py``, and the physical suite): each entry makes the
agent for one run, ``PHYSICAL_AGENTS[name](scenario, seed)`` (``scenario`` the task graph,
or a registered scenario's name, resolved there once; a run: a few episodes with
one human; an agent that learns, learns across them), and says whether it is privileged
(it reads the simulation: a reference, never ranked among robots), whether it is one of
the two references that bound a normalised score (the upper reference, 1, and the
passive floor, 0) and what it does.
docs/physical-baselines.md has each robot's figures and where it wins and loses.

=========================  =====================================================
``upper``                  reference (privileged): follows the human's own reference
``passive``                reference (a robot): zero stiffness, the human drags it
``admittance``             fixed admittance ``v = F / D``, ``ω = τ / D_r``
``variable-admittance``    damping falls as the human pushes on, rises as they hold back
``goal-blend``             goal inference over routes, predict-then-blend
``goal-qmdp``              acts on the goal posterior (QMDP / hindsight optimisation)
``learner``                the paper's Learner through compliant motion primitives
``rl``                     learned (PPO) residual over the variable admittance
=========================  =====================================================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from agents.physical import PhysicalAgent
from baselines.physical.admittance import FixedAdmittance, VariableAdmittance
from baselines.physical.blend import GoalBlend
from baselines.physical.hindsight import GoalQMDP
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["PHYSICAL_AGENTS", "PhysicalAgentEntry", "make_physical_agent"]


@dataclass(frozen=True)
class PhysicalAgentEntry:
    """One robot of the registry: call it with ``(scenario, seed)`` for a new agent.

    Attributes:
        factory: ``factory(graph, seed)`` makes the agent for a run on the scenario's task
            graph.
        privileged: It reads the simulation (the intention, the human's reference): a
            reference, shown apart and never ranked among robots.
        description: One line on what it does.
        reference: One of the two references a normalised score is anchored to (the
            upper reference and the passive floor).
    """

    factory: Callable[[TaskGraph, int], PhysicalAgent]
    privileged: bool
    description: str
    reference: bool = False

    def __call__(self, scenario: TaskGraph | str, seed: int = 0) -> PhysicalAgent:
        """A new agent for one run on ``scenario`` (its task graph, or a registered
        scenario's name, resolved here; ``seed``: its own randomness).
        """
        return self.factory(as_graph(scenario), seed)


def _upper(graph: TaskGraph, seed: int) -> PhysicalAgent:
    # baselines.continuous imports this package's admittance: import it when called.
    from baselines.continuous import UpperReference  # noqa: PLC0415

    return UpperReference()


def _passive(graph: TaskGraph, seed: int) -> PhysicalAgent:
    from baselines.continuous import PassiveFloor  # noqa: PLC0415

    return PassiveFloor()


def _admittance(graph: TaskGraph, seed: int) -> PhysicalAgent:
    return FixedAdmittance(graph)


def _variable(graph: TaskGraph, seed: int) -> PhysicalAgent:
    return VariableAdmittance(graph)


def _blend(graph: TaskGraph, seed: int) -> PhysicalAgent:
    return GoalBlend(graph)


def _qmdp(graph: TaskGraph, seed: int) -> PhysicalAgent:
    return GoalQMDP(graph)


def _rl(graph: TaskGraph, seed: int) -> PhysicalAgent:
    from baselines.physical.residual import ResidualAdmittance  # noqa: PLC0415

    return ResidualAdmittance(graph)


def _learner(graph: TaskGraph, seed: int) -> PhysicalAgent:
    from baselines.continuous import LiftedLearner  # noqa: PLC0415

    return LiftedLearner(graph, seed=seed)


#: The physical robots by name (see the module docstring).
PHYSICAL_AGENTS: dict[str, PhysicalAgentEntry] = {
    "upper": PhysicalAgentEntry(
        _upper, True, "reference: knows the goal and follows the human's own reference",
        reference=True),
    "passive": PhysicalAgentEntry(
        _passive, False, "reference floor: gravity compensated, zero stiffness",
        reference=True),
    "admittance": PhysicalAgentEntry(
        _admittance, False, "fixed admittance: moves at F / D and turns at tau / D_r"),
    "variable-admittance": PhysicalAgentEntry(
        _variable, False, "variable admittance: damping falls as the human pushes on, "
        "rises as they hold back (Duchaine & Gosselin 2007; Lecours et al. 2012)"),
    "goal-blend": PhysicalAgentEntry(
        _blend, False, "infers the goal over the routes, blends its motion towards it "
        "with the admittance by confidence (Dragan & Srinivasa 2013)"),
    "goal-qmdp": PhysicalAgentEntry(
        _qmdp, False, "adds the motion of greatest value expected over the goal "
        "posterior to the admittance (QMDP / hindsight, Javdani et al. 2015)"),
    "learner": PhysicalAgentEntry(
        _learner, False, "the paper's Learner through compliant primitives, following "
        "the human with the admittance between them; learns across a run"),
    "rl": PhysicalAgentEntry(
        _rl, False, "learned: the variable admittance plus a residual trained with PPO on "
        "the train humans (numpy inference from an .npz)"),
}


def make_physical_agent(name: str, scenario: TaskGraph | str, seed: int = 0) -> PhysicalAgent:
    """The registry's agent ``name`` for a run on ``scenario`` (its task graph, or a
    registered scenario's name, resolved here).

    Raises:
        ConfigError: An unknown name (the message lists the names), or an unknown scenario.
    """
    if name not in PHYSICAL_AGENTS:
        raise ConfigError(f"unknown physical agent {name!r}; allowed: "
                          f"{', '.join(PHYSICAL_AGENTS)}", field="agent")
    return PHYSICAL_AGENTS[name].factory(as_graph(scenario), seed)
