"""The conformance checks users run on what they add, run over every registered entry, and
shown to fail on what breaks the contract they check (docs/extending.md)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.conformance import check_agent
from baselines import Passive
from hri_bench.run.agents import AGENTS, AgentContext
from hri_envs.conformance import check_human, check_reward_rule, check_scenario
from hri_envs.errors import ConfigError
from hri_envs.humans.families import FAMILIES
from hri_envs.humans.scripted import preference_human
from hri_envs.humans.spec import HumanSpec
from hri_envs.task.episode import REWARD_RULES, RewardRule
from hri_envs.task.scenarios import SCENARIOS


@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_every_registered_scenario_conforms(scenario):
    assert check_scenario(scenario).startswith(f"scenario {scenario!r}")


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_registered_family_conforms(family):
    for scenario in ("hanger", "wheel"):
        check_human(HumanSpec(population=family), scenario, episodes=2)


@pytest.mark.parametrize("rule", sorted(REWARD_RULES))
def test_every_registered_reward_rule_conforms(rule):
    check_reward_rule(rule)


@pytest.mark.parametrize("name", sorted(a for a, s in AGENTS.items() if s.intention_blind))
def test_every_registered_intention_blind_agent_conforms(name):
    spec = AGENTS[name]

    def make(graph):
        human = preference_human(graph)  # the env's own scripted human
        return spec.make(AgentContext(graph, human, (0,), 0, -0.3, {}, 100, "paper", 3))

    check_agent(make, "hanger", episodes=2)


# ------------------------------------------------------------------ the checks can fail
def test_a_reward_rule_outside_minus_one_to_zero_fails():
    with pytest.raises(ConfigError, match="in \\[-1, 0\\]") as err:
        check_reward_rule(RewardRule("bonus", "pays +1", lambda step: step.paper + 1.0))
    assert err.value.field == "reward"


def test_a_reward_rule_that_depends_on_more_than_the_step_fails():
    rng = np.random.default_rng(0)

    def luck(step):
        return np.where(rng.random(np.shape(step.paper)) < 0.5, step.paper, -1.0)

    with pytest.raises(ConfigError, match="fused table and step_reward differ"):
        check_reward_rule(RewardRule("luck", "random", luck))


class _Invalid(Passive):
    def act(self, observations, active):
        return np.full(self.n_runs, self.graph.n_actions - 1)  # valid nowhere at a support


class _Unseeded(Passive):
    def act(self, observations, active):
        mask = observations["action_mask"][0].astype(bool)
        return np.array([np.random.choice(np.flatnonzero(mask))])  # noqa: NPY002


def test_an_agent_that_reads_the_intention_is_refused_by_name():
    spec = AGENTS["oracle"]

    def make(graph):
        return spec.make(AgentContext(graph, preference_human(graph), (0,), 0, -0.3, {}, 100,
                                      "paper", 3))

    with pytest.raises(ConfigError, match="privileged") as err:
        check_agent(make)
    assert err.value.field == "agent"


def test_an_agent_that_takes_masked_actions_or_draws_unseeded_fails():
    with pytest.raises(ConfigError, match="where it is not valid") as err:
        check_agent(_Invalid)
    assert err.value.field == "action"
    check_agent(_Invalid, allow_invalid=True)
    with pytest.raises(ConfigError, match="made alike chose different actions") as err:
        check_agent(_Unseeded, episodes=3)
    assert err.value.field == "agent"


def test_a_human_that_fails_while_playing_fails_the_check():
    from hri_envs.humans.protocol import Human

    class Broken(Human):
        def act(self, observation):
            raise RuntimeError("boom")

    with pytest.raises(ConfigError, match="the human failed in episode 1.*boom"):
        check_human(Broken(), "wheel")


def test_a_scenario_whose_routes_do_not_lead_to_the_goal_fails():
    import dataclasses

    from tests import scenario_box

    stuck = dataclasses.replace(scenario_box.SPEC, name="stuck",
                                route=lambda scenario, preference, start, goal: [])
    with pytest.raises(ConfigError, match="does not lead the object") as err:
        check_scenario(stuck, env=False)
    assert err.value.field == "route"
