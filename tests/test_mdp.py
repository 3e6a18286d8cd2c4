"""The learning math against hand-computed cases and invariants."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agents.learning import mdp
from hri_envs.task import build_graph, hanger_scenario
from hri_envs.task import mdp as task_mdp
from hri_envs.task.graph import TOGGLE, WAIT


def chain(gamma: float = 0.9):
    """3 states in a line, actions 0 = stay, 1 = advance; state 2 is the goal (reward 1)."""
    t = np.zeros((3, 2, 3))
    for s in range(3):
        t[s, 0, s] = 1.0
        t[s, 1, min(s + 1, 2)] = 1.0
    return t[None], np.array([[0.0, 0.0, 1.0]]), np.ones((3, 2), bool)


def test_q_iteration_chain_by_hand():
    t, r, valid = chain()
    q = task_mdp.q_iteration(t, r, valid, terminal=np.array([2]), gamma=0.9)[0]
    # The goal loops on itself collecting 1 per step: V(2) = 1 / (1 - 0.9) = 10.
    assert q[2] == pytest.approx([10.0, 10.0])
    assert q[1] == pytest.approx([0.9 * 10.0, 1.0 + 0.9 * 10.0])
    assert q[0] == pytest.approx([0.9 * 9.0, 0.9 * 10.0])


def bellman_iterate(t, r_sa, valid, gamma, sweeps=2000):
    q = np.zeros_like(r_sa)
    for _ in range(sweeps):
        v = np.where(valid, q, -np.inf).max(-1)
        q = r_sa + gamma * t @ v
    return q


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), gamma=st.floats(0.0, 0.95))
def test_policy_iteration_matches_bellman_sweeps(seed, gamma):
    rng = np.random.default_rng(seed)
    n_s, n_a = 6, 3
    t = rng.dirichlet(np.ones(n_s), size=(n_s, n_a))
    r = rng.normal(size=(n_s, n_a))
    valid = rng.random((n_s, n_a)) < 0.7
    valid[:, 0] = True
    q = task_mdp.solve_q(t, r, valid, gamma)
    expected = bellman_iterate(t, r, valid, gamma)
    np.testing.assert_allclose(np.where(valid, q, 0), np.where(valid, expected, 0), atol=1e-8)


def test_softmax_sums_to_one_and_ignores_invalid_actions():
    q = np.array([[1.0, 2.0, 50.0], [0.0, 0.0, 0.0]])
    valid = np.array([[True, True, False], [True, False, True]])
    p = task_mdp.softmax(q, valid, temperature=2.0)
    np.testing.assert_allclose(p.sum(-1), 1.0)
    assert p[0, 2] == 0.0 and p[1, 1] == 0.0
    assert p[0, 1] / p[0, 0] == pytest.approx(np.exp(2.0))
    assert p[1, 0] == pytest.approx(0.5)


def test_bounded_softmax_by_hand():
    q = np.array([0.0, 0.1, -1.0])
    valid = np.ones(3, bool)
    # p ∝ (1, e^0.5, e^-5): the bound is max(p(baseline 0), 0.9 max p) = 0.9 p(1) > p(0).
    p = mdp.bounded_softmax(q, valid, 5.0, 0.9, np.array(0))
    np.testing.assert_allclose(p, [0.0, 1.0, 0.0])
    # With η = 0.5 the baseline's own probability is the binding bound: actions 0 and 1 stay.
    p = mdp.bounded_softmax(q, valid, 5.0, 0.5, np.array(0))
    np.testing.assert_allclose(p, np.array([1.0, np.exp(0.5), 0.0]) / (1 + np.exp(0.5)))


def test_bayes_update_by_hand():
    b = np.array([0.0, 0.5, 0.5])
    like = np.array([0.2, 0.6, 0.2])
    prior = np.array([0.025, 0.4875, 0.4875])  # Eq. 4 with β = 0.95
    expected = prior * like / (prior * like).sum()
    np.testing.assert_allclose(mdp.bayes_update(b, like, 0.95), expected)


def test_bayes_update_survives_zero_likelihood_and_recovers():
    b = np.array([0.0, 1.0, 0.0])
    out = mdp.bayes_update(b, np.zeros(3), 0.95)
    assert np.all(np.isfinite(out)) and out.sum() == pytest.approx(1.0) and out.max() < 1.0
    # Intention changed to 0: repeated evidence moves the belief there.
    for _ in range(5):
        out = mdp.bayes_update(out, np.array([0.9, 0.05, 0.05]), 0.95)
    assert out.argmax() == 0


@pytest.mark.parametrize(
    ("states", "kept"),
    [
        ([0, 1, 2, 3], [0, 1, 2, 3]),
        ([0, 1, 2, 1, 3, 4, 3, 5], [0, 3, 6, 7]),
        ([0, 1, 0, 1, 2], [2, 3, 4]),
        ([0, 0, 0, 1], [2, 3]),
        ([7], [0]),
    ],
)
def test_remove_loops(states, kept):
    np.testing.assert_array_equal(mdp.remove_loops(np.array(states)), kept)


def test_irl_step_moves_towards_demonstrated_features_and_rescales():
    theta = np.array([[0.5, -1.0, 0.0]])
    new = mdp.irl_step(theta, np.array([[2.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 1.0]]), 0.1)
    # raw step: [0.5 + 0.1, -1, 0 - 0.1]; max |θ| is already 1, so no rescaling
    np.testing.assert_allclose(new, [[0.6, -1.0, -0.1]])
    big = mdp.irl_step(theta, np.array([[30.0, 0.0, 0.0]]), np.zeros((1, 3)), 0.1)
    np.testing.assert_allclose(big, [[1.0, -1.0 / 3.5, 0.0]])  # rescaled by max |θ| = 3.5


def test_expected_counts_of_a_deterministic_path_are_its_features():
    t, _, _ = chain()
    policy = np.array([[[0.0, 1.0]] * 3])  # always advance
    feats = np.eye(3)[None]
    counts = mdp.expected_feature_counts(t, policy, feats, np.array([0]), np.array([2]),
                                         np.array([3]))
    np.testing.assert_allclose(counts, [[1.0, 1.0, 1.0]])
    # A uniform policy without reaching the terminal keeps all mass: visits sum to the horizon.
    uniform = np.full((1, 3, 2), 0.5)
    counts = mdp.expected_feature_counts(t, uniform, feats, np.array([0]), np.array([2]),
                                         np.array([2]))
    assert counts.sum() == pytest.approx(2.0)


def test_single_agent_transitions_are_distributions():
    g = build_graph(hanger_scenario())
    rng = np.random.default_rng(0)
    pi = rng.random((2, g.n_states, g.n_actions)) * g.valid
    pi /= pi.sum(-1, keepdims=True)
    for t in (task_mdp.robot_transition(g.next_state, pi),
              task_mdp.human_transition(g.next_state, pi)):
        assert t.shape == (2, g.n_states, g.n_actions, g.n_states)
        np.testing.assert_allclose(t.sum(-1), 1.0)
    # By hand: robot moves over to B from A′ while the human waits with probability 0.3 and
    # moves up with probability 0.7: the object ends over B w.p. 0.3, up at A w.p. 0.7.
    s, over_b, up = g.waypoint_state(0, 0, 0), g.move_over(1), g.move_to_height(1)
    pi_h = np.zeros((g.n_states, g.n_actions))
    pi_h[:, 0] = 1.0
    pi_h[s] = 0.0
    pi_h[s, [0, up]] = [0.3, 0.7]
    t_r = task_mdp.robot_transition(g.next_state, pi_h)
    assert t_r[s, over_b, g.waypoint_state(1, 0, 0)] == pytest.approx(0.3)
    assert t_r[s, over_b, g.waypoint_state(0, 1, 0)] == pytest.approx(0.7)


def test_passive_policy_grasps_at_start_and_lets_go_elsewhere():
    g = build_graph(hanger_scenario())
    acts = task_mdp.passive_actions(g, np.array(0))
    assert acts[g.support_state(0, 0)] == TOGGLE
    assert acts[g.support_state(0, 3)] == WAIT  # holding at the start: wait for take-off
    assert acts[g.support_state(1, 3)] == TOGGLE  # holding at another support: let go
    assert acts[g.waypoint_state(0, 0, 0)] == WAIT
    lifted = task_mdp.passive_actions(g, np.array([0]), np.array([True]))[0]
    assert lifted[g.support_state(0, 3)] == TOGGLE  # turned back: the start is the goal
