"""One description of the human (HumanSpec) that every env constructor, the study and serve
take; the envs' flat keywords are its shorthand."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs import hanger_v0
from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHumans
from hri_envs.humans.spec import HumanSpec
from hri_envs.humans.splits import MixtureHumans
from hri_envs.humans.tables import TableHumans


def _human_actions(env, episodes=3, seed=0):
    seen = []
    for e in range(episodes):
        obs, _ = env.reset(seed=seed + e)
        done = False
        while not done:
            obs, _, terminated, truncated, _ = env.step(0)
            seen.append(int(obs["last_human_action"]))
            done = terminated or truncated
    return seen


def test_the_flat_keywords_are_the_specs_shorthand():
    spec = HumanSpec(preference="detour", passive=0.2, turn_back=0.1)
    by_spec = gym.make("hri_envs/Wheel-v0", human=spec).unwrapped
    by_keywords = gym.make("hri_envs/Wheel-v0", preference="detour", human_passive=0.2,
                           turn_back=0.1).unwrapped
    assert isinstance(by_spec.human, TableHumans)
    assert _human_actions(by_spec) == _human_actions(by_keywords)
    assert HumanSpec.from_kwargs(human_params={"k": 3}) == HumanSpec(params=(("k", 3),))


def test_the_robot_and_vector_envs_seat_a_population_spec():
    spec = HumanSpec(population="test-v2-adaptive")
    env = gym.make("hri_envs/Wheel-v0", human=spec).unwrapped
    assert isinstance(env.human, MixtureHumans | FiniteStateHumans)
    vec = gym.make_vec("hri_envs/Wheel-v0", num_envs=3, vectorization_mode="vector_entry_point",
                       human=spec)
    assert vec.unwrapped.human.n_runs == 3
    obs, _ = vec.reset(seed=0)
    obs, *_ = vec.step(np.zeros(3, dtype=np.int64))
    family = HumanSpec(population="impatient", params=(("k", 3),))
    env = gym.make("hri_envs/Hanger-v0", human=family).unwrapped
    assert env.human.n_runs == 1


def test_the_parallel_env_takes_the_specs_turning_back_only():
    env = hanger_v0.parallel_env(human=HumanSpec(turn_back=1.0))
    assert env.turn_back == 1.0
    assert hanger_v0.parallel_env(turn_back=0.5).turn_back == 0.5
    with pytest.raises(ConfigError, match="human is an agent") as err:
        hanger_v0.parallel_env(human=HumanSpec(population="test"))
    assert err.value.field == "human"


@pytest.mark.parametrize("kwargs, field, text", [
    ({"human": HumanSpec(), "preference": "detour"}, "human", "not both"),
    ({"population": False}, "population", "must be a name"),
    ({"human_params": [("k",)]}, "human_params", "a mapping or"),
    ({"human_params": {"k": 3}}, "human_params", "no population is given"),
    ({"population": "nobody"}, "population", "unknown population 'nobody'"),
    ({"population": "impatient", "human_params": {"speed": 1}}, "human_params",
     "has no parameter 'speed'"),
])
def test_a_bad_spec_fails_at_construction_naming_the_field(kwargs, field, text):
    with pytest.raises(ConfigError, match=text) as err:
        gym.make("hri_envs/Wheel-v0", **kwargs)
    assert err.value.field == field


def test_an_unknown_keyword_is_a_type_error_as_for_any_function():
    with pytest.raises(TypeError, match="unexpected keyword argument.*'human_speed'"):
        gym.make("hri_envs/Wheel-v0", human_speed=2)


def test_a_study_reads_its_human_once_into_the_maker_of_its_kind():
    """Issue 42: a study's units ask one maker, chosen once from its HumanSpec."""
    from hri_envs.humans.runs import DrawnRuns, OwnHumans, ScriptedRuns, study_humans
    from hri_envs.humans.scripted import preference_human
    from hri_envs.humans.spec import PopulationKind, register_population_kind
    from hri_envs.task.scenarios import scenario_graph

    graph = scenario_graph("hanger")
    prefs = graph.spec.preferences
    cycle = tuple(prefs[r % 3] for r in range(6))
    kw = {"seed": 3, "episodes": 2}
    assert isinstance(study_humans(HumanSpec(), **kw), ScriptedRuns)
    assert isinstance(study_humans(HumanSpec(), drift=1, **kw), DrawnRuns)
    assert isinstance(study_humans(HumanSpec(population="preferences"), **kw), DrawnRuns)
    own = study_humans(HumanSpec(population="tests.helpers_humans:Copycat"), **kw)
    assert isinstance(own, OwnHumans)
    assert own.make(graph, [0, 1], "")[1] == ["tests.helpers_humans:Copycat"] * 2
    register_population_kind(PopulationKind(  # a kind's model is shared by the runs
        "issue42-kind:", "test", lambda name, g: preference_human(g)), replace=True)
    shared, labels = study_humans(HumanSpec(population="issue42-kind:x"), **kw).make(
        graph, [0, 1], "")
    assert isinstance(shared, TableHumans) and labels == ["issue42-kind:x"] * 2

    mixed, labels = study_humans(HumanSpec(), run_preferences=cycle, **kw).make(
        graph, [4, 1, 2], "all")
    assert labels == [cycle[4], cycle[1], cycle[2]]  # each run meets its own preference
    assert isinstance(mixed, TableHumans)
    one, labels = study_humans(HumanSpec(), **kw).make(graph, [0, 1], prefs[5])
    assert one.name == prefs[5] and labels == [prefs[5]] * 2

    drawn = study_humans(HumanSpec(population="preferences"), **kw)
    _, first = drawn.make(graph, [0, 1, 2], "")
    _, again = drawn.make(graph, [2], "")
    assert again == first[2:]  # a run's human comes from (seed, run) alone, whatever the batch
