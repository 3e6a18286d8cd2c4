"""The sparse partner-MDP math: by hand, against the dense functions, numpy path vs compiled."""

import os
import subprocess
import sys

import numpy as np
import pytest

from agents.learner import Learner
from agents.learning import algorithm1, mdp, partner_mdp
from agents.protocol import Trace
from hri_bench.report.speed import _wheel_trace
from hri_bench.run.study import graph_for
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp
from tests.helpers_partner import HAS_JIT


def random_policies(graph, n, seed):
    """(n, S, A) soft-max policies with random values, zero on invalid actions."""
    rng = np.random.default_rng(seed)
    return task_mdp.softmax(rng.normal(size=(n, graph.n_states, graph.n_actions)), graph.valid, 2.0)


def test_two_state_mdp_by_hand(path):
    """State 0: own action 0 stays, 1 moves to the goal 1 if the partner plays 1 (p = 0.25).

    Reward 1 for action 1 in state 0, goal absorbing with reward 0. With γ = 0.5:
    V(1) = 0; Q(0, 1) = 1 + γ (0.75 V(0) + 0.25 V(1)); Q(0, 0) = 0 + γ V(0).
    Greedy is action 1: V(0) = 1 / (1 - 0.375) = 1.6, Q(0, 0) = 0.8.
    """
    nxt = np.array([[[0, 0], [0, 1]], [[1, 1], [1, 1]]])
    partner = np.array([[[0.75, 0.25], [0.5, 0.5]]])
    reward = np.array([[[0.0, 1.0], [0.0, 0.0]]])
    valid = np.ones((2, 2), bool)
    q, greedy = partner_mdp.solve_partner_q(nxt, partner, reward, valid, 0.5, terminal=1)
    np.testing.assert_allclose(q[0], [[0.8, 1.6], [0.0, 0.0]], atol=1e-15)
    assert greedy.tolist() == [[1, 0]]
    backup = partner_mdp.partner_backup(nxt, partner, np.array([[3.0, 7.0]]), terminal=1)
    np.testing.assert_allclose(backup[0], [[3.0, 4.0], [7.0, 7.0]], atol=1e-15)
    counts = partner_mdp.expected_feature_counts(
        nxt, partner, np.array([[[0.0, 1.0], [0.5, 0.5]]]), np.eye(2)[None],
        np.array([0]), np.array([1]), np.array([3]))
    # From 0: P(0 -> 1) = 0.25 per step; over 3 states 0 is visited 1 + 0.75 + 0.5625 times,
    # the goal 0.25 + 0.1875 times: mass counts once on arriving there, then stops.
    np.testing.assert_allclose(counts, [[2.3125, 0.4375]], atol=1e-15)


@pytest.mark.parametrize("scenario", ["wheel", "hanger"])
def test_sparse_functions_equal_the_dense_ones(path, scenario):
    g = graph_for(scenario)
    n_i = g.n_intentions
    partner = random_policies(g, 2 * n_i, 0).reshape(2, n_i, g.n_states, g.n_actions)
    own = random_policies(g, 2 * n_i, 1).reshape(2, n_i, g.n_states, g.n_actions)
    rng = np.random.default_rng(2)
    values = rng.normal(size=(2, n_i, g.n_states))
    term = g.terminal[None, :]
    dense = task_mdp.absorbing(task_mdp.robot_transition(g.next_state, partner), g.terminal)
    backup = partner_mdp.partner_backup(g.next_state, partner, values, term)
    np.testing.assert_allclose(backup, np.einsum("bisaz,biz->bisa", dense, values), atol=1e-13)

    reward = g.reward(-0.25)
    r_sa = partner_mdp.partner_reward(reward, partner, term)
    expected_r = mdp.robot_reward(reward, partner)
    expected_r[:, np.arange(n_i), g.terminal] = 0.0
    np.testing.assert_allclose(r_sa, expected_r, atol=1e-13)

    q, greedy = partner_mdp.solve_partner_q(g.next_state, partner, r_sa, g.valid, 0.9,
                                            terminal=term)
    q_dense = task_mdp.solve_q(dense, expected_r, g.valid, 0.9)
    np.testing.assert_allclose(q, q_dense, atol=1e-10)
    np.testing.assert_array_equal(greedy, np.where(g.valid, q, -np.inf).argmax(-1))
    # A warm start from the optimum gives the same Q.
    again, _ = partner_mdp.solve_partner_q(g.next_state, partner, r_sa, g.valid, 0.9,
                                           terminal=term, policy=greedy)
    np.testing.assert_allclose(again, q, atol=1e-12)

    flat_p, flat_own = partner.reshape(-1, *partner.shape[2:]), own.reshape(-1, *own.shape[2:])
    terminal = np.tile(g.terminal, 2)
    start = rng.integers(0, g.n_states, len(terminal))
    horizon = rng.integers(1, 12, len(terminal))
    phi = g.features[np.tile(np.arange(n_i), 2)]
    counts = partner_mdp.expected_feature_counts(g.next_state, flat_p, flat_own, phi, start,
                                                 terminal, horizon)
    dense_flat = task_mdp.robot_transition(g.next_state, flat_p)
    expected = mdp.expected_feature_counts(dense_flat, flat_own, phi, start, terminal, horizon)
    np.testing.assert_allclose(counts, expected, atol=1e-12)


@pytest.mark.skipif(not HAS_JIT, reason="numba is not importable (or HRI_ENVS_NO_JIT is set)")
def test_compiled_and_numpy_learners_agree(monkeypatch):
    """Five updates of a 4-run wheel Learner: the two paths give the same model to 1e-12."""
    graph, trace = _wheel_trace()
    rng = np.random.default_rng(0)
    traces = [trace, Trace(trace.states[:5], trace.robot_actions[:4], trace.human_actions[:4])] * 2
    intentions = [rng.integers(-1, 3, 4) for _ in range(5)]

    def learn():
        learner = Learner(graph, 4)
        for ints in intentions:
            learner.end_episode(traces, ints)
        return learner

    jit = learn()
    monkeypatch.setattr(partner_mdp, "kernels", lambda: None)
    plain = learn()
    for name in ("theta", "pi_h", "q_h", "q_r", "pi_r"):
        np.testing.assert_allclose(getattr(jit, name), getattr(plain, name), rtol=0, atol=1e-12,
                                   err_msg=name)


@pytest.mark.skipif(not HAS_JIT, reason="numba is not importable (or HRI_ENVS_NO_JIT is set)")
def test_more_states_than_a_bit_set_word_on_both_paths(monkeypatch):
    """130 states and random transitions: the compiled elimination's column sets span three
    64-bit words and fill in; it gives the numpy path's solution (a dense solve)."""
    rng = np.random.default_rng(5)
    n_s, n_a, n_p, n = 130, 4, 3, 6
    nxt = rng.integers(0, n_s, (n_s, n_a, n_p))
    valid, partner_valid = rng.random((n_s, n_a)) < 0.7, rng.random((n_s, n_p)) < 0.7
    valid[:, 0] = partner_valid[:, 0] = True
    partner = task_mdp.softmax(rng.normal(size=(n, n_s, n_p)), partner_valid, 1.0)
    kwargs = {"state_reward": rng.normal(size=(n, n_s)),
              "terminal": np.array([-1, 0, 63, 64, 129, -1])}
    compiled = partner_mdp.solve_soft(nxt, partner, valid, 0.95, 2.0, **kwargs)
    monkeypatch.setattr(partner_mdp, "kernels", lambda: None)
    plain = partner_mdp.solve_soft(nxt, partner, valid, 0.95, 2.0, **kwargs)
    np.testing.assert_allclose(compiled[0], plain[0], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(compiled[1], plain[1])
    np.testing.assert_allclose(compiled[2], plain[2], rtol=0, atol=1e-12)


def test_no_absorbing_state_is_the_same_on_both_paths(path):
    """terminal = -1 means no absorbing state: the numpy path once took it for the last state."""
    g = graph_for("hanger")
    pi, own = random_policies(g, 3, 0), random_policies(g, 3, 1)
    none = np.full(3, -1)
    start, horizon = np.array([0, 1, 2]), np.array([8, 8, 8])
    dense = task_mdp.robot_transition(g.next_state, pi)  # (3, S, A, S), no state made absorbing
    # Without an absorbing state every state passes its mass on: Σ_t d_t φ by hand.
    step = np.einsum("bsa,bsaz->bsz", own, dense)
    d = np.eye(g.n_states)[start]
    svf = d.copy()
    for _ in range(7):
        d = np.einsum("bs,bsz->bz", d, step)
        svf += d
    expected = np.einsum("bs,bsf->bf", svf, g.features[:3])
    counts = partner_mdp.expected_feature_counts(g.next_state, pi, own, g.features[:3], start,
                                                 none, horizon)
    np.testing.assert_allclose(counts, expected, atol=1e-12)


@pytest.mark.parametrize("bad", ["policy", "terminal", "next_state", "states"])
def test_indices_out_of_range_are_refused_before_any_kernel_runs(path, bad):
    """The compiled kernels do not check bounds: a bad index must not reach them."""
    g = graph_for("hanger")
    pi = random_policies(g, 1, 0)
    r = np.zeros((1, g.n_states, g.n_actions))
    nxt = g.next_state.copy()
    kwargs = {"terminal": np.array([g.n_states]) if bad == "terminal" else None,
              "policy": np.full((1, g.n_states), g.n_actions) if bad == "policy" else None}
    if bad == "next_state":
        nxt[0, 0, 0] = -2
    with pytest.raises(ConfigError, match=f"{bad} must hold indices in") as err:
        if bad == "states":
            partner_mdp.belief_policy(np.zeros((1, 1, g.n_states, g.n_actions)), np.ones((1, 1)),
                                      np.array([g.n_states]), g.valid, 1.0, 0.5, None)
        else:
            partner_mdp.solve_partner_q(nxt, pi, r, g.valid, 0.5, **kwargs)
    assert err.value.field == bad


def test_bad_discount_and_iteration_cap_are_refused():
    g = graph_for("hanger")
    pi = random_policies(g, 1, 0)
    r = np.zeros((1, g.n_states, g.n_actions))
    with pytest.raises(ConfigError, match=r"gamma must be in \[0, 1\), got 1.0") as err:
        partner_mdp.solve_partner_q(g.next_state, pi, r, g.valid, 1.0)
    assert err.value.field == "gamma"
    with pytest.raises(ConfigError, match="max_iter must be >= 1, got 0") as err:
        partner_mdp.solve_partner_q(g.next_state, pi, r, g.valid, 0.5, max_iter=0)
    assert err.value.field == "max_iter"


def test_no_jit_environment_variable_selects_the_numpy_path():
    code = "from agents.learning import partner_mdp; print(partner_mdp.jit_enabled())"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "HRI_ENVS_NO_JIT": "1"}, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("with_baseline", [True, False])
def test_belief_policy_is_the_bounded_softmax_of_the_mixed_q(path, with_baseline):
    g = graph_for("wheel")
    rng = np.random.default_rng(4)
    n_b = 50
    q = rng.normal(size=(n_b, g.n_intentions, g.n_states, g.n_actions))
    q[:5] = 0.0  # ties everywhere: every valid action is kept
    belief = rng.dirichlet(np.ones(g.n_intentions), n_b)
    states = rng.integers(0, g.n_states, n_b)
    baseline = np.where(g.valid[states, 1], 1, 0) if with_baseline else None
    got = partner_mdp.belief_policy(q, belief, states, g.valid, 5.0, 0.9, baseline)
    mixed = np.einsum("bi,bia->ba", belief, q[np.arange(n_b), :, states])
    expected = mdp.bounded_softmax(mixed, g.valid[states], 5.0, 0.9, baseline)
    np.testing.assert_allclose(got, expected, atol=1e-14)
    tied = g.valid[states[:5]]
    np.testing.assert_allclose(got[:5], tied / tied.sum(-1, keepdims=True), atol=1e-15)


def test_maxent_q_equals_the_dense_solve_of_its_reward(path):
    """Plain ME-IRL on the sparse table: Q of θᵀφ as the dense Q-iteration gives it."""
    from baselines.maxent import MaxEntIRL

    graph, trace = _wheel_trace()
    agent = MaxEntIRL(graph, 2)
    for _ in range(3):
        agent.end_episode([trace, trace], np.array([1, -1]))
    n_s, n_a = graph.n_states, graph.n_actions
    dense = np.zeros((n_s, n_a, n_s))
    np.put_along_axis(dense, agent._next, 1.0, axis=-1)
    reward = np.einsum("isf,bf->bis", graph.features, agent.theta)
    q = task_mdp.q_iteration(np.broadcast_to(dense, (2, graph.n_intentions, n_s, n_a, n_s)), reward,
                        graph.valid, graph.terminal, agent.config.gamma)
    np.testing.assert_allclose(agent.q, q, atol=1e-10)
    assert not np.allclose(agent.theta[0], agent.theta[1])  # run 1 never learned


def test_preload_loads_the_compiled_kernels_only_when_they_are_used(monkeypatch):
    assert partner_mdp.preload() is HAS_JIT
    assert algorithm1.preload() is HAS_JIT
    monkeypatch.setattr(partner_mdp, "kernels", lambda: None)
    assert partner_mdp.preload() is False
    assert algorithm1.preload() is False


def test_a_broadcast_state_reward_is_every_mdps_on_both_paths(path):
    """One (1, S) state reward for 4 MDPs is each MDP's (the compiled kernel once read past
    its end for MDPs 1-3): the same as giving it 4 times."""
    g = graph_for("wheel")
    pi = random_policies(g, 4, 0)
    one = np.arange(g.n_states, dtype=float)[None]
    got = partner_mdp.solve_soft(g.next_state, pi, g.valid, 0.9, 1.0, state_reward=one)
    full = partner_mdp.solve_soft(g.next_state, pi, g.valid, 0.9, 1.0,
                                  state_reward=np.repeat(one, 4, axis=0))
    for a, b in zip(got, full, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bad", ["state_reward", "joint_reward", "valid", "start", "belief",
                                 "baseline"])
def test_arrays_of_the_wrong_size_are_refused_before_any_kernel_runs(path, bad):
    """The compiled kernels index each array by the batch's and the graph's sizes."""
    g = graph_for("hanger")
    pi = random_policies(g, 3, 0)
    n_s, n_a = g.n_states, g.n_actions
    with pytest.raises(ConfigError, match="shape") as err:
        if bad in ("state_reward", "joint_reward", "valid"):
            kwargs = ({"state_reward": np.zeros((2, n_s))} if bad == "state_reward" else
                      {"joint_reward": np.zeros((n_s, n_a, n_a - 1))} if bad == "joint_reward"
                      else {"state_reward": np.zeros((3, n_s))})
            valid = g.valid[:-1] if bad == "valid" else g.valid
            partner_mdp.solve_soft(g.next_state, pi, valid, 0.9, 1.0, **kwargs)
        elif bad == "start":
            partner_mdp.expected_feature_counts(g.next_state, pi, pi, g.features[:3],
                                                np.zeros(2, np.int64), np.full(3, -1),
                                                np.full(3, 4))
        else:
            q = np.zeros((3, g.n_intentions, n_s, n_a))
            belief = np.ones((2 if bad == "belief" else 3, g.n_intentions))
            base = np.zeros(2, np.int64) if bad == "baseline" else None
            partner_mdp.belief_policy(q, belief, np.zeros(3, np.int64), g.valid, 1.0, 0.5, base)
    assert err.value.field == bad
