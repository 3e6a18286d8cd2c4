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
