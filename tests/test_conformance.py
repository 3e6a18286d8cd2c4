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


# ------------------------------------------------------------------ issue 43: the third fault round
def _nan(step):
    return np.full(np.shape(step.paper), np.nan)


@pytest.mark.parametrize(("charge", "text"), [
    (_nan, r"rewards must be finite and in \[-1, 0\], got \[nan, nan\]"),
    (lambda step: step.paper + 5.0, r"rewards must be finite and in \[-1, 0\], got \[4.0, 5.0\]"),
    (lambda step: 1 / 0, r"charge\(\) raised ZeroDivisionError: division by zero"),
    (lambda step: np.zeros(7), r"charge\(\) returned rewards of shape \(7,\); they must "
                               r"broadcast with the step's arrays"),
    (lambda step: step.s + step.missing, r"charge\(\) raised AttributeError"),
    (lambda step: "cheap", r"charge\(\) raised ValueError"),
])
def test_a_reward_rule_that_breaks_the_contract_is_refused_where_it_enters(charge, text):
    """register_reward_rule promised a ConfigError and gave none: RobotEnv(reward=rule) then
    returned nan rewards and a study's mean was nan. Every door (registration, an env given
    the rule object, the conformance check) now refuses it, naming the field."""
    from hri_envs.envs.robot import RobotEnv
    from hri_envs.task.episode import register_reward_rule

    rule = RewardRule("broken-rule", "breaks the contract", charge)
    for door in (lambda: register_reward_rule(rule), lambda: RobotEnv(reward=rule),
                 lambda: check_reward_rule(rule)):
        with pytest.raises(ConfigError, match=text) as err:
            door()
        assert err.value.field == "reward"
    assert "broken-rule" not in REWARD_RULES


def test_a_good_reward_rule_object_works_unregistered():
    from hri_envs.envs.robot import RobotEnv

    rule = RewardRule("halved", "half the paper's", lambda step: step.paper / 2)
    env = RobotEnv(reward=rule)
    env.reset(seed=0)
    assert np.isfinite(env.step(0)[1])


def _box(**changes):
    import dataclasses

    from tests import scenario_box

    return dataclasses.replace(scenario_box.SPEC, **{"name": "box-faulty", **changes})


def _nan_support():
    import dataclasses

    from tests import scenario_box

    geometry = scenario_box.geometry()
    supports = list(geometry.supports)
    supports[1] = dataclasses.replace(supports[1], position=np.array([np.nan, 0.1, 1.1]))
    return dataclasses.replace(geometry, supports=tuple(supports))


@pytest.mark.parametrize(("changes", "field", "text"), [
    ({"r0": float("nan")}, "r0", r"r0 must be a number in the open interval \(-1, 0\), got nan"),
    ({"r0": 5.0}, "r0", r"r0 must be a number in the open interval \(-1, 0\), got 5.0"),
    ({"gamma": 1.5}, "gamma", r"gamma must be a number in \[0, 1\), got 1.5"),
    ({"gamma": "0.9"}, "gamma", r"gamma must be a number in \[0, 1\)"),
    ({"episodes": 0}, "episodes", r"episodes must be a whole number >= 1, got 0"),
    ({"episodes": 2.5}, "episodes", r"episodes must be a whole number >= 1"),
    ({"name": ""}, "name", r"a scenario's name must be letters, digits, '-' and '_'"),
    ({"name": "a/b"}, "name", r"a scenario's name must be .*, got 'a/b'"),
    ({"name": 3}, "name", r"a scenario's name must be"),
    ({"preferences": ()}, "preferences", r"preferences must be a tuple of one or more names"),
    ({"geometry": _nan_support}, "geometry",
     r"support 'B''s position must be 3 finite numbers \[m\]"),
])
def test_a_scenario_spec_with_a_bad_field_is_refused_naming_it(changes, field, text):
    """register_scenario and check_scenario accepted r0 NaN or +5, gamma 1.5, episodes 0,
    a support at NaN and names '' and 'a/b'."""
    from hri_envs.task.scenarios import register_scenario

    spec = _box(**changes)
    for door in (lambda: register_scenario(spec), lambda: check_scenario(spec, env=False)):
        with pytest.raises(ConfigError, match=text) as err:
            door()
        assert err.value.field == field
    assert spec.name not in SCENARIOS


def test_a_scenarios_route_that_raises_is_named():
    def route(scenario, preference, start, goal):
        raise KeyError(preference)

    with pytest.raises(ConfigError, match=r"scenario 'box-faulty': preference 'over-first' "
                                          r"does not lead.*\(KeyError: 'over-first'\)") as err:
        check_scenario(_box(route=route), env=False)
    assert err.value.field == "route"


def test_a_family_that_raises_is_named():
    from hri_envs.humans.families import Family, register_family

    def broken(graph, *, k: int = 1):
        raise RuntimeError("the family's own bug")

    register_family(Family("broken-family", "misspecified", broken, "raises"))
    try:
        with pytest.raises(ConfigError, match=r"cannot be seated: RuntimeError: the family's "
                                              r"own bug") as err:
            check_human(HumanSpec(population="broken-family"), "hanger")
        assert err.value.field == "human"
    finally:
        FAMILIES.unregister("broken-family")


class _WordBelief(Passive):
    def belief(self):
        return np.array([["A", "B", "C"]])


class _DictBelief(Passive):
    def belief(self):
        return {"A": 1.0}


class _RaisingBelief(Passive):
    def belief(self):
        raise LookupError("no belief yet")


class _FailsToBuild(Passive):
    def __init__(self, graph, n_runs):
        raise OSError("weights missing")


@pytest.mark.parametrize(("agent", "field", "text"), [
    (_WordBelief, "belief", r"belief\(\) of agent '.*' returned ndarray .*; a belief is an "
                            r"array of numbers"),
    (_DictBelief, "belief", r"belief\(\) of agent '.*' returned dict"),
    (_RaisingBelief, "belief", r"belief\(\) failed after episode 1: LookupError: no belief yet"),
    (_FailsToBuild, "agent", r"the agent cannot be made: OSError: weights missing"),
])
def test_an_agent_that_breaks_the_protocol_is_named(agent, field, text):
    with pytest.raises(ConfigError, match=text) as err:
        check_agent(agent, episodes=1)
    assert err.value.field == field


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
