"""The benchmark's built-in agents, registered by name when this module is imported.

Each built-in is an :class:`~agents.registry.AgentSpec` in :data:`~agents.registry.AGENTS`:
a maker from the study's :class:`~agents.registry.AgentContext` (the Learner, the baselines,
the references ``informed``, ``blind`` and ``qmdp``) and, for the learners, the settings a
study records. The registry is also told how to make any of them for
:func:`agents.conformance.check_agent`. :mod:`hri_bench.run.agents` imports this module, and
resolves the names that are not registered (``sb3:PATH``, ``jaxppo[:PATH]``,
``module:Class``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from agents import conformance
from agents.config import default_config
from agents.learner import Learner
from agents.learning import algorithm1
from agents.learning.algorithm1 import Workspace
from agents.protocol import BatchAgent
from agents.registry import AGENTS, AgentContext, AgentSpec, register_agent
from baselines import CountQMDP, GoalFilter, Imitator, MaxEntIRL, Oracle, Passive
from baselines.bounds import Blind, Informed
from baselines.product import QMDP, PerRunInformed
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import PreferredActions, ScriptedHuman, preference_human
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import ScenarioSpec, spec_of

__all__: list[str] = []


def _learner_settings(spec: ScenarioSpec, r0: float, learner: dict[str, Any]
                      ) -> dict[str, Any]:
    return default_config(spec, **{"r0": r0, **learner}).to_dict()


def _maxent_settings(spec: ScenarioSpec, r0: float, learner: dict[str, Any]
                     ) -> dict[str, Any]:
    return default_config(spec, r0=r0, learning_rate=0.03).to_dict()


def _countqmdp_settings(spec: ScenarioSpec, r0: float, learner: dict[str, Any]
                        ) -> dict[str, Any]:
    # its reward rule is the study's own ("reward_rule" of summary.json)
    return {k: v for k, v in CountQMDP.defaults(r0=r0).items() if k != "reward"}


def _make_learner(c: AgentContext) -> BatchAgent:
    cfg = default_config(spec_of(c.graph), **{"r0": c.r0, **c.learner})
    return Learner(c.graph, len(c.runs), cfg, seed=c.seed, runs=c.runs, workspace=Workspace())


def _make_maxent(c: AgentContext) -> BatchAgent:
    cfg = default_config(spec_of(c.graph), r0=c.r0, learning_rate=0.03)
    return MaxEntIRL(c.graph, len(c.runs), cfg, seed=c.seed, runs=c.runs)


def _make_oracle(c: AgentContext) -> BatchAgent:
    if not isinstance(c.human, PreferredActions):
        raise ConfigError("the oracle copies a scripted human's preferred actions; this "
                          "study's humans name none", field="agents")
    return Oracle(c.graph, c.human, len(c.runs))


def _make_exact(c: AgentContext, cls: type[Informed] | type[Blind]) -> BatchAgent:
    if not isinstance(c.human, ScriptedHuman):
        raise ConfigError("agent 'blind' plans for one scripted human shared by every "
                          "run; studies whose runs have humans of their own (population=, "
                          "human_drift=) are not supported: use qmdp and informed for a "
                          "bracket", field="agents")
    return cls(c.graph, c.human, len(c.runs), r0=c.r0, max_steps=c.max_steps,
               reward=c.reward)


def _make_informed(c: AgentContext) -> BatchAgent:
    if not isinstance(c.human, ScriptedHuman):  # humans of their own: the product's plans
        return PerRunInformed(c.graph, c.human, len(c.runs), r0=c.r0, max_steps=c.max_steps,
                              reward=c.reward, episodes=c.episodes)
    return _make_exact(c, Informed)


def _make_blind(c: AgentContext) -> BatchAgent:
    return _make_exact(c, Blind)


def _make_qmdp(c: AgentContext) -> BatchAgent:
    return QMDP(c.graph, c.human, len(c.runs), r0=c.r0, max_steps=c.max_steps,
                reward=c.reward, episodes=c.episodes)


def _make_imitator(c: AgentContext) -> BatchAgent:
    return Imitator(c.graph, len(c.runs))


def _make_passive(c: AgentContext) -> BatchAgent:
    return Passive(c.graph, len(c.runs))


def _make_goalfilter(c: AgentContext) -> BatchAgent:
    return GoalFilter(c.graph, len(c.runs), r0=c.r0)


def _make_countqmdp(c: AgentContext) -> BatchAgent:
    return CountQMDP(c.graph, len(c.runs), r0=c.r0, reward=c.reward)


for _spec in (
    AgentSpec("learner", _make_learner, "learner",
              description="the paper's Learner (Algorithm 1): IRL human model, Bayes filter "
                          "over the intention", settings=_learner_settings,
              warm=algorithm1.preload),
    AgentSpec("imitator", _make_imitator, description="Algorithm 3: repeats the human's last "
              "action per (start, state)"),
    AgentSpec("maxent", _make_maxent, "learner", description="Algorithm 4: plain ME-IRL of its "
              "own reward, count-based intention", settings=_maxent_settings,
              warm=algorithm1.preload),
    AgentSpec("passive", _make_passive, description="Algorithm 2: grasp, follow, let go"),
    AgentSpec("oracle", _make_oracle, intention_blind=False,
              description="the paper's heuristic baseline: sees the intention and the "
                          "preference (not a bound)"),
    AgentSpec("goalfilter", _make_goalfilter, description="a Bayesian goal filter that "
              "learns no preference"),
    AgentSpec("countqmdp", _make_countqmdp, "learner", description="counts the human's "
              "actions per context, filters the intention, plans by QMDP",
              settings=_countqmdp_settings),
    AgentSpec("informed", _make_informed, "reference", intention_blind=False, plans=True,
              shared_human=True, description="the information bound: the exact optimum "
              "that sees the intention"),
    AgentSpec("blind", _make_blind, "reference", plans=True, shared_human=True,
              description="the exact intention-blind optimum for one shared human"),
    AgentSpec("qmdp", _make_qmdp, "reference", plans=True, description="QMDP on the exact "
              "posterior with the human's model: the reachable reference where blind does "
              "not fit"),
):
    register_agent(_spec)


def _maker_of(name: str) -> Callable[[TaskGraph], BatchAgent]:
    """A factory of the registered agent ``name`` for :func:`agents.conformance.check_agent`:
    made as a study makes it, for one run against the scenario's scripted human.
    """
    spec = AGENTS[name]

    def make(graph: TaskGraph) -> BatchAgent:
        human = preference_human(graph)  # the robot env's own scripted human
        r0 = spec_of(graph).r0
        return spec.make(AgentContext(graph, human, (0,), 0, r0, {}, 100, "paper", 3))

    return make


conformance.NAMED.append((lambda: list(AGENTS), _maker_of))
