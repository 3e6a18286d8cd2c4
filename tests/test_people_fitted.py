"""Humans fitted to recorded steps (hri_envs/humans/fitted.py): invariants and seats."""

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401
from hri_envs.errors import ConfigError
from hri_envs.humans.fitted import (
    Steps,
    action_log_likelihood,
    count_policy,
    fitted_human,
    uniform_policy,
)
from hri_envs.humans.scripted import preference_human
from hri_envs.humans.tables import TableHumans
from hri_envs.task.scenarios import scenario_graph


def _route_steps(graph, human, pairs):
    """The scripted human's own route for each (start, goal), robot copying it."""
    out = [[], [], [], []]
    for start, goal in pairs:
        s = int(graph.support_state(start, 0))
        for _ in range(40):
            a = int(human.preferred_action(np.array(s), np.array(start), np.array(goal)))
            for col, v in zip(out, (start, goal, s, a), strict=True):
                col.append(v)
            s = int(graph.next_state[s, a, a])
            if graph.support[s] == goal and graph.grasp[s] == 0:
                break
    return Steps(*(np.array(c, dtype=np.int64) for c in out))


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_count_policy_is_a_policy_over_valid_actions(scenario):
    g = scenario_graph(scenario)
    steps = _route_steps(g, preference_human(g, None), [(0, 1), (1, 0), (2, 1)])
    policy = count_policy(g, steps, smoothing=0.5)
    assert policy.shape == (g.n_intentions, g.n_intentions, g.n_states, g.n_actions)
    np.testing.assert_allclose(policy.sum(-1), 1.0)
    assert not policy[..., ~g.valid.astype(bool)].any()
    # where the data are, the recorded action is the likeliest
    p = policy[steps.start, steps.intention, steps.state]
    assert (np.argmax(p, -1) == steps.action).all()
    # an unvisited (start, ι, state) gets the prior: uniform over valid actions
    seen = np.zeros(policy.shape[:3], bool)
    seen[steps.start, steps.intention, steps.state] = True
    k, i, s = np.argwhere(~seen)[0]
    np.testing.assert_allclose(policy[k, i, s], uniform_policy(g)[i, s])


def test_smoothing_backs_off_to_the_counts_without_the_start():
    g = scenario_graph("hanger")
    steps = _route_steps(g, preference_human(g, None), [(1, 0)])
    policy = count_policy(g, steps, smoothing=1.0)
    # start C, same goal A: never seen with this start, but the states are: the counts of
    # the other start dominate the prior
    s, a = int(steps.state[3]), int(steps.action[3])
    assert policy[2, 0, s, a] > 0.5 > uniform_policy(g)[0, s, a]


def test_fitted_human_sits_in_every_seat_and_follows_its_table():
    g = scenario_graph("hanger")
    scripted = preference_human(g, None)
    steps = _route_steps(g, scripted, [(a, b) for a in range(3) for b in range(3) if a != b])
    human = fitted_human(g, count_policy(g, steps, smoothing=1e-6), "recorded:test-v0")
    assert human.name == "recorded:test-v0" and (human.turn_state == -1).all()
    # a robot env seats it (human=) and, with a robot that helps, it reaches the goal
    env = gym.make("hri_envs/Hanger-v0", human=human)
    obs, _ = env.reset(seed=0, options={"start": "B", "intention": "A"})
    for _ in range(40):
        helps = int(scripted.preferred_action(np.array(obs["state"]), np.array(1), np.array(0)))
        obs, _, terminated, truncated, info = env.step(helps)
        if terminated or truncated:
            break
    assert terminated and info["reached_intention"]
    # the benchmark's seat: one row per run, each drawing from its own generator
    seat = TableHumans(human, 4)
    seat.seed([np.random.default_rng(r) for r in range(4)])
    obs = {"state": np.full(4, int(g.support_state(1, 0))), "start": np.ones(4, np.int64),
           "intention": np.zeros(4, np.int64)}
    acts = seat.act(obs, np.ones(4, bool))
    assert g.valid[obs["state"], acts].all()


def test_log_likelihood_and_accuracy():
    g = scenario_graph("hanger")
    steps = _route_steps(g, preference_human(g, None), [(1, 0)])
    good = count_policy(g, steps, smoothing=1e-3)
    flat = np.broadcast_to(uniform_policy(g), good.shape)
    ll_good, acc_good = action_log_likelihood(good, steps, g)
    ll_flat, _ = action_log_likelihood(flat, steps, g)
    assert acc_good == 1.0 and ll_good > ll_flat
    empty = Steps(*(np.zeros(0, np.int64) for _ in range(4)))
    assert np.isnan(action_log_likelihood(good, empty, g)[0])


@pytest.mark.parametrize("bad, field", [
    (Steps(np.array([0]), np.array([1]), np.array([99]), np.array([0])), "state"),
    (Steps(np.array([0]), np.array([1]), np.array([0]), np.array([4])), "action"),
    (Steps(np.array([0, 1]), np.array([1]), np.array([0]), np.array([0])), "intention"),
    (Steps(np.array([0.5]), np.array([1]), np.array([0]), np.array([0])), "start"),
])
def test_bad_steps_are_refused_naming_the_array(bad, field):
    with pytest.raises(ConfigError) as err:
        count_policy(scenario_graph("hanger"), bad)
    assert err.value.field == field


def test_bad_tables_and_smoothing_are_refused():
    g = scenario_graph("hanger")
    steps = Steps(*(np.zeros(0, np.int64) for _ in range(4)))
    for smoothing in (0, -1.0, float("nan"), True):
        with pytest.raises(ConfigError, match="smoothing"):
            count_policy(g, steps, smoothing=smoothing)
    with pytest.raises(ConfigError, match="shape"):
        fitted_human(g, np.ones((2, 2)), "x")
    bad = uniform_policy(g)
    bad[0, 0] *= 2
    with pytest.raises(ConfigError, match="sum to 1"):
        fitted_human(g, bad, "x")
