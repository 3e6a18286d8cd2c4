"""Invariants of the task graph and of episodes under random joint action sequences."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hri_envs import hanger_v0, wheel_v0
from hri_envs.envs.config import scenario_graph

MODULES = {"hanger": hanger_v0, "wheel": wheel_v0}


@st.composite
def episodes(draw):
    """A scenario, r0, start/intention/turn-back and a sequence of joint actions."""
    name = draw(st.sampled_from(sorted(MODULES)))
    graph = scenario_graph(name)
    k, a = graph.n_intentions, graph.n_actions
    start = draw(st.integers(0, k - 1))
    intention = draw(st.integers(0, k - 2))
    intention += intention >= start
    r0 = draw(st.floats(-0.99, -0.01))
    actions = draw(st.lists(st.tuples(st.integers(0, a - 1), st.integers(0, a - 1)),
                            min_size=1, max_size=60))
    turn_back = draw(st.booleans())
    return name, r0, {"start": start, "intention": intention, "turn_back": turn_back}, actions


@settings(max_examples=150, deadline=None)
@given(episodes())
def test_random_joint_actions_keep_the_invariants(case):
    name, r0, options, actions = case
    env = MODULES[name].parallel_env(r0=r0)
    g = env.graph
    obs, _ = env.reset(seed=0, options=options)
    for a_r, a_h in actions:
        before = obs["robot"]["state"]
        obs, rew, term, trunc, info = env.step({"robot": a_r, "human": a_h})
        s = obs["robot"]["state"]
        # free space only while both hold the object
        assert g.support[s] >= 0 or g.grasp[s] == 3
        for agent in ("human", "robot"):
            assert np.array_equal(obs[agent]["action_mask"], g.valid[s].astype(np.int8))
        assert rew["robot"] == rew["human"] and rew["robot"] in (-1.0, r0, 0.0)
        assert info["robot"]["invalid_action"] == (not g.valid[before, a_r])
        assert info["human"]["invalid_action"] == (not g.valid[before, a_h])
        if info["robot"]["aborted"]:  # no motion: only grasp bits may change
            assert rew["robot"] == -1.0
            assert g.support[s] == g.support[before] and g.column[s] == g.column[before]
            assert g.height[s] == g.height[before]
            assert g.orientation[s] == g.orientation[before]
        if term["robot"]:
            assert g.support[s] >= 0 and g.grasp[s] == 0
            assert g.support[s] != options["start"] or env.state()[4] == 1
        if not env.agents:
            break


@pytest.mark.parametrize("name", sorted(MODULES))
def test_every_state_can_reach_every_terminal_state(name):
    g = scenario_graph(name)
    n_s = g.n_states
    adjacency = np.zeros((n_s, n_s), dtype=bool)
    adjacency[np.arange(n_s)[:, None], g.next_state.reshape(n_s, -1)] = True
    reach = adjacency | np.eye(n_s, dtype=bool)
    for _ in range(int(np.ceil(np.log2(n_s))) + 1):  # transitive closure by squaring
        reach = reach | ((reach.astype(np.int64) @ reach.astype(np.int64)) > 0)
    assert reach[:, g.terminal].all()


@pytest.mark.parametrize("name", sorted(MODULES))
def test_free_space_states_are_held_by_both(name):
    g = scenario_graph(name)
    assert (g.grasp[g.support < 0] == 3).all()
    assert g.valid[:, 0].all()  # waiting is always allowed
