"""The task model: graph sizes, features, scripted humans (routes, passivity, turning back)."""

import numpy as np
import pytest

from hri_envs.humans.scripted import boltzmann_human, preference_human
from hri_envs.task import (
    build_graph,
    initial_theta,
    sample_wheel_layout,
    state_features,
    wheel_scenario,
)
from hri_envs.task.episode import (
    arrived,
    classify,
    episode_over,
    left_start,
    start_state,
    step_reward,
    turn_back,
)
from hri_envs.task.features import feature_groups
from hri_envs.task.graph import PUT_ON, ROTATE, TAKE_OFF, TOGGLE, WAIT
from hri_envs.task.scenarios.hanger import PREFERENCES as HANGER_PREFERENCES


def test_sizes_match_the_paper(hanger, wheel):
    assert (hanger.n_states, hanger.n_features) == (24, 26)
    assert hanger.valid.sum(1).min() == 2 and hanger.valid.sum(1).max() == 6
    assert (wheel.n_states, wheel.n_features) == (36, 26)
    assert wheel.valid.sum(1).max() == 8


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
    assert human.turn_back == 1.0
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
    assert episode_over(hanger, on(b, 0), a, False)  # resting on another support, let go
    assert not episode_over(hanger, on(b, 1), a, False)  # the human still holds it
    assert not episode_over(hanger, on(a, 0), a, False)  # not lifted yet: the start
    assert episode_over(hanger, on(a, 0), a, True)  # turned back after lifting it
    assert not episode_over(hanger, hanger.mounting_state[b], a, True)  # in free space
    assert left_start(hanger, hanger.mounting_state[a], a) and not left_start(hanger, on(a, 3), a)
    assert arrived(hanger, on(b, 3), a, False) and not arrived(hanger, on(a, 3), a, False)
    # Vectorised: one call over every state, start and lifted flag (as EpisodeRules does).
    ends = episode_over(hanger, np.arange(24)[:, None, None], np.arange(3)[None, :, None],
                        np.array([False, True])[None, None, :])
    # unlifted: each resting state ends the episodes of the 2 other starts; lifted: all 3
    assert ends.shape == (24, 3, 2) and ends[:, :, 0].sum() == 3 * 2 and ends[:, :, 1].sum() == 9


def test_step_rules_by_hand_on_observed_states(hanger):
    """Reward and decisions judged on the state reached, as a physics backend reports it."""
    on, r0 = hanger.support_state, -0.33
    a = 0
    held = on(a, 3)  # on A, held by both
    up = int(hanger.next_state[held, TAKE_OFF, WAIT])
    # The robot takes off while the human follows: the graph's prediction is reached.
    assert step_reward(hanger, held, TAKE_OFF, WAIT, up, r0) == 0.0
    assert classify(hanger, held, TAKE_OFF, WAIT, up) == (True, False, False)
    # Same actions, but the object did not move (the physics stalled): the human waited and
    # nothing changed, so r⁻, and the robot's motion was not correct.
    assert step_reward(hanger, held, TAKE_OFF, WAIT, held, r0) == -1.0
    assert classify(hanger, held, TAKE_OFF, WAIT, held) == (False, False, True)
    # The robot waits while the human acts: r0 and passive.
    assert step_reward(hanger, held, WAIT, TAKE_OFF, up, r0) == r0
    assert classify(hanger, held, WAIT, TAKE_OFF, up) == (False, True, False)
    # Grasping is never counteracted: both toggle at once on A (nobody held it) -> both hold.
    assert step_reward(hanger, on(a, 0), TOGGLE, TOGGLE, on(a, 3), r0) == 0.0
    assert classify(hanger, on(a, 0), TOGGLE, TOGGLE, on(a, 3)).correct


def test_grasp_and_let_go_cost_nothing_on_the_wheel():
    """The free toggle of docs/task-model.md: grasp + human let go, then let go + wait."""
    wheel = build_graph(wheel_scenario())
    reward = wheel.reward(-0.25)
    assert reward[5, TOGGLE, TOGGLE] == 0.0  # on B held by the human -> on B held by the robot
    assert int(wheel.next_state[5, TOGGLE, TOGGLE]) == 6
    assert reward[6, TOGGLE, WAIT] == 0.0  # the robot lets go: on B, nobody holds it
    assert episode_over(wheel, int(wheel.next_state[6, TOGGLE, WAIT]), 0, True)


def test_graph_tables_are_the_rules_on_the_graphs_transitions(hanger):
    s, a_r, a_h = np.meshgrid(np.arange(hanger.n_states), np.arange(hanger.n_actions),
                              np.arange(hanger.n_actions), indexing="ij")
    # The paper's rules as first written, independently of hri_envs.task.episode: r- for an
    # aborted step, a robot motion the human counteracts with another, or a human wait with
    # nothing changed; r0 for the robot waiting while the human acts; correct = acted, not
    # aborted, not overridden by another motion.
    counteracted = (a_r >= TAKE_OFF) & (a_h >= TAKE_OFF) & (a_r != a_h)
    penalty = hanger.aborted | counteracted | ((a_h == WAIT) & (hanger.next_state == s))
    expected = np.where(penalty, -1.0, np.where((a_r == WAIT) & (a_h != WAIT), -0.4, 0.0))
    np.testing.assert_array_equal(hanger.reward(-0.4), expected)
    np.testing.assert_array_equal(hanger.robot_effective,
                                  (a_r != WAIT) & ~hanger.aborted & ~counteracted)


def test_turn_back_and_start_state_by_hand(hanger):
    turn_state = np.full((3, 3), -1)
    turn_state[0, 1] = 17
    intention, turning = turn_back(turn_state, np.array([16, 17, 17]), np.array([0, 0, 0]),
                                   np.array([1, 1, 1]), np.array([True, True, False]))
    np.testing.assert_array_equal(intention, [1, 0, 1])  # only the turning run at 17 turns
    np.testing.assert_array_equal(turning, [True, False, False])
    np.testing.assert_array_equal(start_state(hanger, np.array([0, 2])), [0, 8])
