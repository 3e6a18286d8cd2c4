"""The task model: graph sizes, features, scripted humans (routes, passivity, turning back)."""

import numpy as np
import pytest

from hri_envs.task import (
    build_graph,
    hanger_scenario,
    initial_theta,
    sample_wheel_layout,
    state_features,
    wheel_scenario,
)
from hri_envs.task.features import feature_groups
from hri_envs.task.graph import PUT_ON, ROTATE, TAKE_OFF, TOGGLE, WAIT
from hri_envs.task.humans import (
    HANGER_PREFERENCES,
    boltzmann_human,
    preference_human,
)


@pytest.fixture(scope="module")
def hanger():
    return build_graph(hanger_scenario())


@pytest.fixture(scope="module")
def wheel():
    return build_graph(wheel_scenario())


def test_sizes_match_the_paper(hanger, wheel):
    assert (hanger.n_states, hanger.n_features) == (24, 26)
    assert hanger.valid_counts.min() == 2 and hanger.valid_counts.max() == 6
    assert (wheel.n_states, wheel.n_features) == (36, 26)
    assert wheel.valid_counts.max() == 8


def test_state_and_action_names_are_readable(hanger):
    assert hanger.state_names[hanger.waypoint_state(1, 1, 1)] == \
        "held at B′ column, 0.87 m, rail-facing"
    assert hanger.action_label(hanger.waypoint_state(1, 1, 1), hanger.move_to_height(0)) == \
        "move down to 0.585 m"
    assert hanger.agent_action_label(hanger.support_state(0, 3), TOGGLE, robot=True) == "let go"
    assert hanger.agent_action_label(hanger.support_state(0, 1), TOGGLE, robot=True) == "grasp"


def test_features_by_hand(hanger):
    phi = hanger.features
    goal_b, on_b = 1, hanger.support_state(1, 0)
    assert phi[goal_b, on_b, 0] == pytest.approx(1.0)  # resting on the goal, nobody holds
    assert phi[0, on_b].argmax() == 10  # for goal A, B is the nearest non-goal support, μ = 0
    # B′ (rail-facing) for goal B: at the goal's mounting point (rail orientation and goal
    # orientation, the same one) and, as C′ has B′'s height, also "goal column at a non-goal
    # height": four unit features, normalised to 1/4 each.
    groups = dict(feature_groups(2))
    b_mount = phi[goal_b, hanger.mounting_state[1]]
    np.testing.assert_allclose(b_mount[groups["goal mounting point"]], [0, 0.25, 0.25], atol=1e-6)
    np.testing.assert_allclose(b_mount[groups["goal column, non-goal height"]], [0, 0.25, 0.25],
                               atol=1e-6)
    assert b_mount.sum() == pytest.approx(1.0)
    assert np.all(phi.sum(-1) <= 1 + 1e-9) and np.all(phi >= 0)
    theta = initial_theta(26)
    assert theta[0] == 0.1 and theta[10] == -1.0 and np.count_nonzero(theta) == 2


def test_wheel_features_do_not_depend_on_layout(wheel):
    rng = np.random.default_rng(0)
    for _ in range(5):
        layout = sample_wheel_layout(rng)
        b, c = np.array(layout)
        assert 1.0 <= np.linalg.norm(b - c) <= 2.2
        assert all(1.6 <= np.linalg.norm(p) <= 3.6 for p in (b, c))
        other = build_graph(wheel_scenario(layout))
        np.testing.assert_allclose(other.features, wheel.features, atol=1e-9)
        np.testing.assert_array_equal(other.next_state, wheel.next_state)


def test_wheel_waypoints_below_a_stand_are_projected():
    sc = wheel_scenario()
    low_at_b = sc.waypoint_position(1, 0)  # 0.95 m, below stand B's top (1.0 m)
    above_b = sc.waypoint_position(1, 3)
    assert low_at_b[0] == pytest.approx(sc.supports[1].mounting[0] - sc.projection)
    assert above_b[0] == pytest.approx(sc.supports[1].mounting[0])
    features = state_features(sc, np.array([above_b]), sc.orientations[:1], np.array([3]))
    assert features.shape == (3, 1, 26)


def walk(graph, human, start, goal, robot_joins=True):
    """Run the human with a helpful robot (grasps with the human, lets go at the goal)."""
    s, labels = graph.support_state(start), []
    for _ in range(30):
        a_h = int(human.preferred_action(s, start, goal))
        holds = graph.grasp[s] & 2
        at_goal = graph.support[s] == goal
        a_r = TOGGLE if robot_joins and graph.support[s] >= 0 and (bool(holds) == at_goal) else 0
        labels.append(graph.agent_action_label(s, a_h, robot=False))
        s = int(graph.next_state[s, a_r, a_h])
        if graph.support[s] == goal and graph.grasp[s] == 0:
            return labels
    raise AssertionError(f"did not arrive: {labels}")


def test_most_frequent_hanger_preference_routes(hanger):
    human = preference_human(hanger)
    assert walk(hanger, human, 1, 0) == ["grasp", "take off", "move down to 0.585 m",
                                         "move over to A", "rotate", "put on", "let go"]
    assert walk(hanger, human, 0, 2) == ["grasp", "take off", "move over to C", "rotate",
                                         "move up to 0.87 m", "put on", "let go"]
    assert walk(hanger, human, 1, 2) == ["grasp", "take off", "move over to C", "put on",
                                         "let go"]


def test_all_36_hanger_preferences_differ_and_arrive(hanger):
    assert len(set(HANGER_PREFERENCES)) == 36
    routes = {tuple(walk(hanger, preference_human(hanger, p), 1, 0) +
                    walk(hanger, preference_human(hanger, p), 0, 1)) for p in HANGER_PREFERENCES}
    assert len(routes) == 36


def test_wheel_preferences_follow_fig9(wheel):
    straight = walk(wheel, preference_human(wheel, "straight"), 0, 1)
    assert straight[2:5] == ["move over to B", "move down to 1.1 m", "rotate"]
    detour = walk(wheel, preference_human(wheel, "detour"), 0, 1)
    assert detour[2:6] == ["rotate", "move down to 0.95 m", "move over to B", "move up to 1.1 m"]
    assert "rotate" not in walk(wheel, preference_human(wheel, "straight"), 1, 2)


def test_off_route_the_human_replans_with_its_preference(wheel):
    human = preference_human(wheel, "detour")
    # The robot carried the wheel (vertical) over to C at 1.7 m while the human was passive;
    # going to B, the detour human rotates first, then goes down to carrying height.
    s = wheel.waypoint_state(2, 3, 1)
    assert human.preferred_action(s, 0, 1) == ROTATE
    s = wheel.waypoint_state(2, 3, 0)
    assert human.preferred_action(s, 0, 1) == wheel.move_to_height(0)


def test_passive_human_waits_at_the_given_rate(hanger):
    human = preference_human(hanger, passive=0.2)
    rng = np.random.default_rng(0)
    states = np.full(20_000, hanger.waypoint_state(1, 1, 1))
    actions = human.act(rng, states, np.ones_like(states), np.zeros_like(states))
    assert np.mean(actions == WAIT) == pytest.approx(0.2, abs=0.015)
    assert set(np.unique(actions)) == {WAIT, hanger.move_to_height(0)}


def test_turning_back_halfway(hanger):
    human = preference_human(hanger, turn_back=1.0)
    assert human.draw_turn_back(np.random.default_rng(0), 3).all()
    turn = human.turn_state[0, 1]  # A -> B: turn at "B column, low, rail-facing"
    assert hanger.state_names[turn] == "held at B column, 0.585 m, rail-facing"
    # After turning, the goal is the start: the human heads back to A.
    assert human.preferred_action(turn, 0, 0) == hanger.move_over(0)


def test_boltzmann_human(hanger):
    theta = initial_theta(26)
    human = boltzmann_human(hanger, theta, temperature=25.0)
    p = human.policy
    np.testing.assert_allclose(p.sum(-1), 1.0)
    assert np.all(p[..., ~hanger.valid] == 0.0)
    # Resting on the start with nobody holding it is punished: the human grasps.
    assert p[1, 0, hanger.support_state(1), TOGGLE] > 0.5
    # At the goal's mounting point, the human puts the hanger on.
    assert p[1, 0, hanger.mounting_state[0], PUT_ON] > 0.5
    rng = np.random.default_rng(1)
    acts = human.act(rng, np.full(100, hanger.support_state(1, 3)), 1, 0)
    assert np.mean(acts == TAKE_OFF) > 0.5
    with pytest.raises(ValueError, match="theta must have shape"):
        boltzmann_human(hanger, np.zeros(3))


def test_bad_human_configuration(hanger):
    with pytest.raises(ValueError, match="allowed: down-over-rotate"):
        preference_human(hanger, "straight")
    with pytest.raises(ValueError, match="passive must be a probability"):
        preference_human(hanger, passive=1.5)


def test_episode_end_rule_by_hand(hanger):
    on = hanger.support_state
    a, b = 0, 1
    assert hanger.episode_over(on(b, 0), a, False)  # resting on another support, let go
    assert not hanger.episode_over(on(b, 1), a, False)  # the human still holds it
    assert not hanger.episode_over(on(a, 0), a, False)  # not lifted yet: the start
    assert hanger.episode_over(on(a, 0), a, True)  # turned back after lifting it
    assert not hanger.episode_over(hanger.mounting_state[b], a, True)  # in free space
    assert hanger.left_start(hanger.mounting_state[a], a) and not hanger.left_start(on(a, 3), a)
    assert hanger.arrived(on(b, 3), a, False) and not hanger.arrived(on(a, 3), a, False)
    # Vectorised: one call over every state, start and lifted flag (as EpisodeRules does).
    ends = hanger.episode_over(np.arange(24)[:, None, None], np.arange(3)[None, :, None],
                               np.array([False, True])[None, None, :])
    # unlifted: each resting state ends the episodes of the 2 other starts; lifted: all 3
    assert ends.shape == (24, 3, 2) and ends[:, :, 0].sum() == 3 * 2 and ends[:, :, 1].sum() == 9
