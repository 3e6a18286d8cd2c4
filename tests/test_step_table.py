"""The fused step table: the episode rules' tables, looked up once per joint step."""

import numpy as np
import pytest

from hri_envs.envs.config import scenario_graph
from hri_envs.task.episode import EpisodeBatch, EpisodeRules, StepTable, step_reward
from hri_envs.task.graph import TAKE_OFF, TOGGLE, WAIT


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
@pytest.mark.parametrize("reward", ["paper", "no-free-toggle"])
def test_every_entry_is_what_the_batch_bookkeeping_computes(scenario, reward):
    """All (start, lifted, s, a_R, a_H): the table against EpisodeBatch.commit and the rules."""
    graph = scenario_graph(scenario)
    rules = EpisodeRules(graph, -0.3, reward)
    table = StepTable(rules)
    n_s, n_a, n_k = graph.n_states, graph.n_actions, graph.n_intentions
    start, lifted, s, a_r, a_h = (x.reshape(-1) for x in np.meshgrid(
        np.arange(n_k), [False, True], np.arange(n_s), np.arange(n_a), np.arange(n_a),
        indexing="ij"))
    batch = EpisodeBatch(rules, np.full((n_k, n_k), -1), start.size)
    batch.begin(slice(None), start, (start + 1) % n_k, False)
    batch.state[:], batch.lifted[:] = s, lifted
    s_next = graph.next_state[s, a_r, a_h]
    over = batch.commit(s_next, a_h)
    j = table.key(s, start, lifted) + a_r * n_a + a_h
    np.testing.assert_array_equal(j, np.arange(2 * n_k * n_s * n_a * n_a))  # dense, in order
    np.testing.assert_array_equal(table.next_state[j], s_next)
    np.testing.assert_array_equal(table.terminated[j], over)
    np.testing.assert_array_equal(table.lifted[j], batch.lifted)
    np.testing.assert_array_equal(table.next_key[j], table.key(s_next, start, batch.lifted))
    np.testing.assert_array_equal(
        table.reward[j], step_reward(graph, s, a_r, a_h, s_next, -0.3, reward=reward,
                                     start=start, lifted=lifted))
    np.testing.assert_array_equal(table.aborted[j], graph.aborted[s, a_r, a_h])
    np.testing.assert_array_equal(table.robot_invalid[j], ~graph.valid[s, a_r])
    np.testing.assert_array_equal(table.human_invalid[j], ~graph.valid[s, a_h])
    np.testing.assert_array_equal(table.state0, [graph.support_state(k, 0) for k in range(n_k)])
    np.testing.assert_array_equal(table.key0, table.key(table.state0, np.arange(n_k), False))


def test_a_hanger_episode_by_hand():
    """B -> C on the hanger (states 4 .. 8): the human grasps, both take off, move, put on."""
    graph = scenario_graph("hanger")
    table = StepTable(EpisodeRules(graph, -0.33))
    key = table.key0[1]  # resting on B, not lifted
    seen = []
    for a_r, a_h in ((TOGGLE, TOGGLE), (TAKE_OFF, TAKE_OFF), (7, 7), (3, 3), (TOGGLE, TOGGLE)):
        j = key + a_r * graph.n_actions + a_h
        seen.append((int(table.next_state[j]), float(table.reward[j]),
                     bool(table.terminated[j]), bool(table.lifted[j])))
        key = table.next_key[j]
    assert [x[0] for x in seen] == [7, 19, 23, 11, 8]  # on B held, B', C', on C held, on C
    assert [x[2] for x in seen] == [False] * 4 + [True]
    assert [x[3] for x in seen] == [False, True, True, True, True]
    assert all(x[1] == 0.0 for x in seen)  # the robot helped in every step
    j = table.key0[1] + WAIT * graph.n_actions + TOGGLE  # the robot waits, the human grasps
    assert table.reward[j] == -0.33 and not table.terminated[j]
    j = table.key0[1] + TAKE_OFF * graph.n_actions + TOGGLE  # take-off before grasping
    assert table.aborted[j] and table.reward[j] == -1.0 and table.robot_invalid[j]


def test_the_over_context_is_neutral():
    table = StepTable(EpisodeRules(scenario_graph("wheel"), -0.25))
    j = table.over + np.arange(table.stride)
    assert not (table.terminated[j] | table.aborted[j] | table.robot_invalid[j]
                | table.human_invalid[j]).any()
    assert (table.reward[j] == 0.0).all() and (table.next_key[j] == table.over).all()
    assert table.next_key.size == table.over + table.stride
    assert not table.reward.flags.writeable


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
@pytest.mark.parametrize("reward", ["paper", "no-free-toggle"])
def test_the_greedy_table_is_the_step_table_at_the_humans_action(scenario, reward):
    """All (start, lifted, s, ι, a_R) against the step table at a_H = human[start, ι, s]."""
    from hri_envs.humans.scripted import preference_human
    from hri_envs.task.greedy_table import GreedyStepTable

    graph = scenario_graph(scenario)
    steps = StepTable(EpisodeRules(graph, -0.3, reward))
    n_s, n_a, n_k = graph.n_states, graph.n_actions, graph.n_intentions
    start, lifted, s, goal, a_r = (x.reshape(-1) for x in np.meshgrid(
        np.arange(n_k), [False, True], np.arange(n_s), np.arange(n_k), np.arange(n_a),
        indexing="ij"))
    human = preference_human(graph)
    grid = np.indices((n_k, n_k, n_s))  # (start, goal, state)
    table = GreedyStepTable(steps, human.preferred_action(grid[2], grid[0], grid[1]))
    a_h = human.preferred_action(s, start, goal)
    j = table.key(s, start, lifted) + goal * table.goal_stride + a_r
    np.testing.assert_array_equal(j, np.arange(2 * n_k * n_s * n_k * n_a))  # dense, in order
    j0 = steps.key(s, start, lifted) + a_r * n_a + a_h
    np.testing.assert_array_equal(table.human_action[j], a_h)
    for name in ("next_state", "reward", "aborted", "robot_invalid", "terminated"):
        np.testing.assert_array_equal(getattr(table, name)[j], getattr(steps, name)[j0], name)
    ends = steps.terminated[j0]
    assert ends.any() and not ends.all()
    np.testing.assert_array_equal(table.next_key[j][ends], table.over)
    np.testing.assert_array_equal(  # the next context, ι kept aside
        table.next_key[j][~ends], table.key(steps.next_state[j0], start, steps.lifted[j0])[~ends])
    np.testing.assert_array_equal(table.key0, table.key(steps.state0, np.arange(n_k), False))
    over = table.over + np.arange(table.stride)  # neutral, and the human waits
    assert (table.human_action[over] == WAIT).all() and (table.next_key[over] == table.over).all()
    assert not (table.terminated[over] | table.aborted[over] | table.robot_invalid[over]).any()
    assert (table.reward[over] == 0.0).all() and not table.next_key.flags.writeable


def test_the_greedy_table_refuses_a_bad_human_table():
    from hri_envs.errors import ConfigError
    from hri_envs.task.greedy_table import GreedyStepTable

    steps = StepTable(EpisodeRules(scenario_graph("hanger"), -0.33))
    with pytest.raises(ConfigError, match=r"integers of shape \(3, 3, 24\)"):
        GreedyStepTable(steps, np.zeros((3, 24), dtype=np.int64))
    with pytest.raises(ConfigError, match=r"must lie in 0\.\.9"):
        GreedyStepTable(steps, np.full((3, 3, 24), 10))
