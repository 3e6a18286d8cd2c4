"""The conformance checks users run on what they add, run over every registered entry, and
shown to fail on what breaks the contract they check (docs/extending.md)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from agents.conformance import check_agent
from baselines import Passive
from hri_bench.run.agents import AGENTS, AgentContext
from hri_envs.conformance import check_backend, check_human, check_reward_rule, check_scenario
from hri_envs.envs import backends
from hri_envs.envs.backends import BACKENDS, BackendSpec, BatchStep, GraphBatch, register_backend
from hri_envs.envs.episode import Episode
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


@pytest.mark.parametrize("backend", [
    pytest.param(name, marks=pytest.mark.skip(reason="on MuJoCo Warp: tests/test_mjwarp.py"))
    if name == "mjwarp" else name for name in BACKENDS])
def test_every_registered_backend_conforms(backend):
    if any(importlib.util.find_spec(m) is None for m in BACKENDS[backend].requires):
        pytest.skip(f"backend {backend!r} needs its extra")
    assert check_backend(backend).startswith(f"backend {backend!r} on the hanger")


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


# ------------------------------------------------------------------ a backend of one's own
class _OffGraph(GraphBatch):
    """Reports a state the graph does not have."""

    def transition(self, state, a_r, a_h, active):
        step = super().transition(state, a_r, a_h, active)
        return step._replace(next_state=step.next_state + self.graph.n_states)


class _SharedStream(GraphBatch):
    """Its sensor misreads the human from one generator for the whole batch: a run's
    numbers depend on the runs batched with it."""

    def __init__(self, graph, runs, seed, physics=None):
        super().__init__(graph, runs, seed, physics)
        self.rng = np.random.default_rng(seed)

    def transition(self, state, a_r, a_h, active):
        seen = np.where(self.rng.random(len(state)) < 0.5, 0, a_h)
        return BatchStep(self.graph.next_state[state, a_r, a_h], seen, None, {})


class _UnseededBatch(GraphBatch):
    """Misreads the human from the global generator: not reproducible."""

    def transition(self, state, a_r, a_h, active):
        seen = np.where(np.random.random(len(state)) < 0.5, 0, a_h)  # noqa: NPY002
        return BatchStep(self.graph.next_state[state, a_r, a_h], seen, None, {})


class _Figures(GraphBatch):
    """Names a figure it never reports."""

    extras = ("impulse",)


class _Slips(Episode):
    """The single env's object slips back at random, from the global generator."""

    def transition(self, a_r, a_h):
        nxt = super().transition(a_r, a_h)
        return self.state if np.random.random() < 0.3 else nxt  # noqa: NPY002


@pytest.fixture
def own_backend():
    """Registers backend "own" (the graph's classes under another name) for the test."""
    spec = register_backend(BackendSpec("own", "hri_envs.envs.episode:Episode",
                                        "hri_envs.envs.backends:GraphBatch"))
    yield spec
    BACKENDS.unregister("own")


def test_a_backend_of_ones_own_is_registered_and_conforms(own_backend):
    assert own_backend in BACKENDS.values() and backends.backend_spec("own") is own_backend
    assert check_backend("own", "wheel").startswith("backend 'own' on the wheel")


@pytest.mark.parametrize(("episode", "batch", "match", "field"), [
    ("Episode", "_OffGraph", "next_state is .*integers in \\[0, ", "backend"),
    ("Episode", "_SharedStream", "moved differently alone than in a batch", "backend"),
    ("Episode", "_UnseededBatch", "moved differently the second time", "backend"),
    ("Episode", "_Figures", "finite values of each of its extras", "backend"),
    ("_Slips", "GraphBatch", "robot env played the same seeds differently|check_env", "env"),
    ("GraphBatch", "GraphBatch", "is not a subclass of hri_envs.envs.episode.Episode",
     "backend"),
])
def test_a_broken_backend_fails_its_conformance_check(own_backend, episode, batch, match,
                                                      field):
    where = {"Episode": "hri_envs.envs.episode", "GraphBatch": "hri_envs.envs.backends"}
    broken = BackendSpec("own", f"{where.get(episode, 'tests.test_conformance')}:{episode}",
                         f"{where.get(batch, 'tests.test_conformance')}:{batch}")
    register_backend(broken, replace=True)
    with pytest.raises(ConfigError, match=match) as err:
        check_backend("own")
    assert err.value.field == field


def test_check_backend_checks_registered_backends_only():
    with pytest.raises(ConfigError, match="register_backend") as err:
        check_backend(BackendSpec("elsewhere", "hri_envs.envs.episode:Episode",
                                  "hri_envs.envs.backends:GraphBatch"))
    assert err.value.field == "backend"
