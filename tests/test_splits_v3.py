"""Split version 3 (suite v4's humans): distinct by behaviour (issue 41, item 4).

Two humans are the same when their laws of the next action differ by less than
:data:`~hri_envs.humans.distance.TOLERANCE` in total variation on every context both reach
(:func:`~hri_envs.humans.distance.behaviour_distance`; docs/humans.md, "Split version 3").
"""

from __future__ import annotations

import json

import pytest

from hri_envs.humans.distance import TOLERANCE, behaviour_distance, same_behaviour
from hri_envs.humans.families import GROUPS
from hri_envs.humans.finite_state import as_model
from hri_envs.humans.populations import HumanDraw, build_human
from hri_envs.humans.splits import FROZEN_PATH, MIXTURES, frozen_document
from hri_envs.task.scenarios import scenario_graph

EARLIER = ("train", "validation", "validation-v2", "validation-v3")


def _models(name, scenario):
    graph = scenario_graph(scenario)
    return [as_model(build_human(graph, d)) for d in MIXTURES[(name, scenario)].member_draws]


def _draw(scenario, **params):
    graph = scenario_graph(scenario)
    return as_model(build_human(graph, HumanDraw(None, family="preference",
                                                 params=tuple(params.items()))))


def test_the_distance_sees_through_rounding_and_tells_real_differences():
    # The reviewer's pair: a test-v2 human and a train human, 5.6e-17 apart.
    near = behaviour_distance(_draw("wheel", preference="detour", rationality=37.43),
                              _draw("wheel", preference="detour"))
    assert near < 1e-15
    assert behaviour_distance(_draw("wheel", preference="detour", passive=0.3),
                              _draw("wheel", preference="detour")) == pytest.approx(0.3)
    assert behaviour_distance(_draw("wheel", preference="detour"),
                              _draw("wheel", preference="straight")) == 1.0
    assert not same_behaviour(_draw("wheel", preference="detour", passive=0.05),
                              _draw("wheel", preference="detour"))


def test_a_memory_that_shows_late_still_counts():
    graph = scenario_graph("hanger")
    follower = [as_model(build_human(graph, HumanDraw(None, family="follower", params=(
        ("k", k), ("preference", "over-down-rotate/over-rotate-up"))))) for k in (3, 4)]
    assert follower[0].fingerprint != follower[1].fingerprint
    assert behaviour_distance(*follower) == 1.0  # alike until the k-th wait, then not


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_no_test_human_is_the_same_as_another_or_as_a_train_or_validation_human(scenario):
    test = [m for g in GROUPS for m in _models(f"test-v3-{g}", scenario)]
    earlier = [m for n in EARLIER for m in _models(n, scenario)]
    assert len(test) == 160
    for i, m in enumerate(test):
        for other in test[:i] + earlier:
            assert not same_behaviour(m, other, TOLERANCE), (m.name, other.name)


def test_split_v2_holds_humans_the_same_as_train_ones():
    """What v3 fixes (and v2, suite v3's, keeps: its members never change)."""
    train = _models("train", "wheel")
    test = _models("test-v2-scripted", "wheel")
    assert sum(any(same_behaviour(m, t) for t in train) for m in test) > 20


def test_the_frozen_members_are_the_split_s_own():
    frozen = json.loads(FROZEN_PATH.read_text())
    for sc in ("hanger", "wheel"):
        for name in ("validation-v3", "test-v3"):
            spec = MIXTURES[(name, sc)]
            assert frozen[spec.frozen_key()]["generator"] == spec.generator_hash()
            assert len(spec.member_draws) == spec.size


@pytest.mark.slow
def test_the_frozen_members_are_what_the_generator_draws():
    specs = [MIXTURES[(n, sc)] for sc in ("hanger", "wheel")
             for n in ("validation-v3", "test-v3")]
    assert frozen_document(specs) == json.loads(FROZEN_PATH.read_text())


def test_for_humans_without_memory_it_is_the_largest_total_variation_on_the_table():
    a = _draw("hanger", preference="over-down-rotate/over-rotate-up", rationality=0.5)
    b = _draw("hanger", preference="over-down-rotate/over-rotate-up", passive=0.4)
    graph = a.graph
    worst = 0.0
    for start in range(graph.n_intentions):
        for goal in range(graph.n_intentions):
            if goal == start:
                continue
            for s in range(graph.n_states):
                for r in range(graph.n_actions):
                    if graph.valid[s, r]:
                        p, q = a.law[0, start, goal, s, 0], b.law[0, start, goal, s, 0]
                        worst = max(worst, 0.5 * sum(abs(x - y) for x, y in zip(p, q, strict=True)))
    assert worst > 0.05 and behaviour_distance(a, b) == pytest.approx(worst, abs=1e-12)
