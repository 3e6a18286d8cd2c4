"""The learning math's batch helpers: loop removal in one call, and batches shared by threads.

Both must give the numbers of the plain code bit for bit (not merely to rounding): the
studies' outputs are compared byte for byte across versions.
"""

import multiprocessing

import numpy as np
import pytest

from agents.learner import Learner
from agents.learning import algorithm1, compiled, mdp, partner_mdp
from agents.protocol import Trace
from hri_bench.report.speed import _wheel_trace
from hri_bench.run.study import graph_for
from hri_envs.errors import ConfigError
from hri_envs.task import mdp as task_mdp
from tests.helpers_partner import HAS_JIT

needs_jit = pytest.mark.skipif(not HAS_JIT, reason="numba is not importable")


@pytest.fixture
def threads():
    """Restore the process's thread setting after a test changes it."""
    before = partner_mdp.threads()
    yield partner_mdp.set_threads
    partner_mdp.set_threads(before)


def looped_traces(n_s, n, seed):
    """Random walks with many revisits (lengths 1 to 60), as int64 and as int32 arrays."""
    rng = np.random.default_rng(seed)
    out = []
    for b in range(n):
        length = 1 + int(rng.integers(60))
        walk = rng.integers(0, min(n_s, 3 + b % 7), length)  # few states: loops everywhere
        out.append(walk.astype(np.int32) if b % 2 else walk)
    return out


def test_loop_removal_by_hand(path):
    """0 1 2 1 3 2 4: back at 1 drops 2; 2 then comes as a new state: path 0 1 3 2 4."""
    features = np.arange(2 * 5 * 3, dtype=float).reshape(2, 5, 3)
    counts, start, horizon = partner_mdp.loop_free_counts(
        features, [np.array([0, 1, 2, 1, 3, 2, 4]), np.array([3])], np.array([1, 0]))
    np.testing.assert_array_equal(start, [0, 3])
    np.testing.assert_array_equal(horizon, [5, 1])
    np.testing.assert_array_equal(counts[0], features[1, [0, 1, 3, 2, 4]].sum(axis=0))
    np.testing.assert_array_equal(counts[1], features[0, 3])


@needs_jit
@pytest.mark.parametrize("n_f", [2, 26])  # 1 feature, or no numba: it calls demonstrations
def test_loop_free_counts_are_the_demonstrations_bit_for_bit(n_f):
    rng = np.random.default_rng(n_f)
    features = rng.normal(size=(3, 36, n_f)) * 10.0 ** rng.uniform(-6, 6, size=(3, 36, n_f))
    traces = looped_traces(36, 80, n_f)
    intentions = rng.integers(0, 3, 80)
    counts, start, horizon = partner_mdp.loop_free_counts(features, traces, intentions)
    demo = mdp.demonstrations(features, traces, intentions)
    assert counts.tobytes() == demo.counts.tobytes()
    np.testing.assert_array_equal(start, demo.start)
    np.testing.assert_array_equal(horizon, demo.horizon)


@pytest.mark.parametrize(("traces", "intentions", "field", "says"), [
    ([np.array([0, 1]), np.array([], dtype=np.int64)], [0, 1], "state_traces", "at least one"),
    ([np.array([0, 36])], [0], "state_traces", "[0, 36)"),
    ([np.array([0, -1])], [0], "state_traces", "[0, 36)"),
    ([np.array([0, 1])], [3], "intentions", "[0, 3)"),
    ([np.array([0, 1])], [0, 1], "intentions", "one entry per trace"),
])
def test_bad_traces_are_refused(traces, intentions, field, says):
    if field == "state_traces" and "at least" not in says and not HAS_JIT:
        pytest.skip("the numpy path indexes φ directly")
    features = np.ones((3, 36, 4))
    with pytest.raises(ConfigError, match=says.replace("[", r"\[").replace(")", r"\)")) as err:
        partner_mdp.loop_free_counts(features, traces, np.array(intentions))
    assert err.value.field == field


def test_thread_setting_is_checked(threads, monkeypatch):
    with pytest.raises(ConfigError, match=">= 1") as err:
        threads(0)
    assert err.value.field == "threads"
    monkeypatch.setenv(partner_mdp.THREADS_ENV, "two")
    with pytest.raises(ConfigError, match="whole number >= 1") as err:
        threads(None)
    assert err.value.field == partner_mdp.THREADS_ENV
    monkeypatch.setenv(partner_mdp.THREADS_ENV, "3")
    threads(None)
    assert partner_mdp.threads() == 3
    monkeypatch.delenv(partner_mdp.THREADS_ENV)
    threads(None)
    assert partner_mdp.threads() == compiled._cores() >= 1  # the default: every core


def _child_threads(_):
    return partner_mdp.threads()


def test_a_forked_child_runs_the_kernels_on_one_thread(threads):
    """A study's workers are forked: they must not each start the parent's threads."""
    threads(2)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.map(_child_threads, [0]) == [1]
    assert partner_mdp.threads() == 2


def test_a_child_forked_before_the_parent_chose_runs_on_one_thread(threads, monkeypatch):
    """The default (every core) is the importing process's; its forked workers get one."""
    monkeypatch.delenv(partner_mdp.THREADS_ENV, raising=False)
    monkeypatch.setattr(compiled, "_threads", None)
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.map(_child_threads, [0]) == [1]
    assert partner_mdp.threads() == compiled._cores()


@needs_jit
def test_threads_give_the_same_numbers_bit_for_bit(threads):
    """Ten updates of a 100-run wheel Learner on 1 and on 2 threads: identical models (every
    batch of the update, the IRL step's 100 MDPs included, is shared by both threads)."""
    graph, trace = _wheel_trace()
    rng = np.random.default_rng(1)
    short = Trace(trace.states[:5], trace.robot_actions[:4], trace.human_actions[:4])
    traces = [trace, short] * 50
    intentions = [rng.integers(-1, 3, 100) for _ in range(10)]

    def learn(n):
        threads(n)
        learner = Learner(graph, 100)
        for ints in intentions:
            learner.end_episode(traces, ints)
        return learner

    one, two = learn(1), learn(2)
    assert compiled._threads_here(100) == 2
    for name, a, b in zip(algorithm1.Models._fields, one._models, two._models, strict=True):
        assert a.tobytes() == b.tobytes(), name


@needs_jit  # without numba solve_soft is those three calls
@pytest.mark.parametrize("kind", ["state", "joint"])
def test_solve_soft_is_the_three_calls(kind):
    """The fused kernel's Q and greedy policy are solve_partner_q's bit for bit; its soft-max
    is the masked soft-max of the task model (hri_envs.task.mdp.softmax) to rounding."""
    g = graph_for("wheel")
    rng = np.random.default_rng(7)
    pi = task_mdp.softmax(rng.normal(size=(5, 3, g.n_states, g.n_actions)), g.valid, 2.0)
    term = g.terminal[None, :]
    warm = rng.integers(0, 2, (5, 3, g.n_states)) * g.valid.argmax(-1)  # valid actions
    if kind == "state":
        values = rng.normal(size=(5, 3, g.n_states))
        reward = partner_mdp.partner_backup(g.next_state, pi, values, term)
        got = partner_mdp.solve_soft(g.next_state, pi, g.valid, 0.9, 3.0, state_reward=values,
                                     terminal=term, policy=warm)
    else:
        joint = rng.normal(size=(g.n_states, g.n_actions, g.n_actions))
        reward = partner_mdp.partner_reward(joint, pi, term)
        got = partner_mdp.solve_soft(g.next_state, pi, g.valid, 0.9, 3.0, joint_reward=joint,
                                     terminal=term, policy=warm)
    q, greedy = partner_mdp.solve_partner_q(g.next_state, pi, reward, g.valid, 0.9,
                                            terminal=term, policy=warm)
    for a, b in zip(got[:2], (q, greedy), strict=True):
        assert a.shape == b.shape and a.tobytes() == b.tobytes()
    np.testing.assert_allclose(got[2], task_mdp.softmax(q, g.valid, 3.0), rtol=0, atol=1e-15)


@pytest.mark.parametrize("rewards", [{}, {"state_reward": np.zeros(24),
                                          "joint_reward": np.zeros((24, 10, 10))}])
def test_solve_soft_needs_exactly_one_reward(path, rewards):
    g = graph_for("hanger")
    pi = task_mdp.softmax(np.zeros((1, g.n_states, g.n_actions)), g.valid, 1.0)
    with pytest.raises(ConfigError, match="exactly one of state_reward") as err:
        partner_mdp.solve_soft(g.next_state, pi, g.valid, 0.9, 1.0, **rewards)
    assert err.value.field == "state_reward"


def _models_inputs(seed, n_b=30, scenario="wheel"):
    """Random but valid inputs of algorithm1.update: the graph's own (read-only) tables, the
    parameters, policies, θ, warm starts, looped traces."""
    g = graph_for(scenario)
    rng = np.random.default_rng(seed)
    pi_r = task_mdp.softmax(rng.normal(size=(n_b, g.n_intentions, g.n_states, g.n_actions)),
                       g.valid, 2.0)
    theta = rng.normal(size=(n_b, g.n_features))
    first_valid = g.valid.argmax(-1)
    warm = tuple(np.broadcast_to(first_valid, (n_b, g.n_intentions, g.n_states)).copy()
                 for _ in range(2))
    traces = [t % g.n_states for t in looped_traces(g.n_states, n_b, seed)]
    intentions = rng.integers(-1, g.n_intentions, n_b)
    tables = algorithm1.Tables(g.next_state, g.valid, g.reward(-0.1), g.features, g.terminal)
    params = algorithm1.Params(gamma=0.9, human_temperature=3.0, robot_temperature=2.0,
                               irl_temperature=1.5, learning_rate=0.2)
    return tables, params, theta, pi_r, warm, traces, intentions


def _last(warm):
    """Models of a last update that hold only its greedy actions (all update reads of them)."""
    return algorithm1.Models(*[None] * 8)._replace(greedy_h=warm[0], greedy_r=warm[1])


def _into(models):
    """A workspace given ``models`` to write the next update into."""
    workspace = algorithm1.Workspace()
    workspace.give(models)
    return workspace


@needs_jit  # without numba update is reference_update
@pytest.mark.parametrize("n_threads", [1, 2])
@pytest.mark.parametrize("warm_start", [False, True])
@pytest.mark.parametrize("irl", [False, True])
def test_update_is_the_reference_bit_for_bit(threads, n_threads, warm_start, irl):
    """The compiled steps (one hand-out to the threads) against reference_update (solve_soft,
    expected_feature_counts, loop_free_counts and irl_step called in turn); into new
    arrays and into a workspace's arrays holding garbage."""
    threads(n_threads)
    tables, params, theta, pi_r, warm, traces, intentions = _models_inputs(3, n_b=100)
    args = dict(state_traces=traces if irl else None, intentions=intentions if irl else None)
    last = _last(warm) if warm_start else None
    fused = algorithm1.update(tables, params, theta, pi_r, last, **args)
    garbage = algorithm1.Models(*(np.full_like(a, 7) for a in fused))
    reused = algorithm1.update(tables, params, theta, pi_r, last, workspace=_into(garbage),
                               **args)
    nxt, ok, joint, phi, term = (np.asarray(t) for t in tables)
    plain = algorithm1.reference_update(
        algorithm1.Tables(nxt.astype(np.int64), ok, joint, phi, term.astype(np.int64)), params,
        theta, pi_r, warm if warm_start else None, traces if irl else None,
        intentions if irl else None)
    for name, a, b, c in zip(algorithm1.Models._fields, fused, reused, plain, strict=True):
        assert a.shape == c.shape and a.tobytes() == c.tobytes(), name
        assert b.tobytes() == c.tobytes(), name
    assert all(x is y for x, y in zip(reused[1:], garbage[1:], strict=True))
    if irl:  # the runs that revealed nothing keep θ; the others moved
        kept = intentions < 0
        assert np.array_equal(fused.theta[kept], theta[kept])
        assert not np.isclose(fused.theta[~kept], theta[~kept]).all(axis=1).any()


def test_update_models_is_deprecated_and_is_update(path):
    """The old call (the tables and parameters as separate arguments) still works: it
    warns, naming update, and gives update's numbers, written into ``out``."""
    tables, params, theta, pi_r, warm, traces, intentions = _models_inputs(5)
    args = dict(state_traces=traces, intentions=intentions)
    expected = algorithm1.update(tables, params, theta, pi_r, _last(warm), **args)
    garbage = algorithm1.Models(*(np.full_like(a, 7) for a in expected))
    with pytest.warns(DeprecationWarning, match=r"algorithm1\.update\(Tables"):
        got = algorithm1.update_models(*tables, theta, pi_r, warm, **params._asdict(), **args,
                                       out=garbage)
    for name, a, b in zip(algorithm1.Models._fields, got, expected, strict=True):
        assert a.tobytes() == b.tobytes(), name
    assert all(x is y for x, y in zip(got[1:], garbage[1:], strict=True))


@pytest.mark.parametrize(("change", "field"), [
    ({"intentions": np.full(30, 3)}, "intentions"),
    ({"intentions": np.zeros(29, np.int64)}, "intentions"),
    ({"theta": np.zeros((30, 5))}, "theta"),
    ({"theta": np.zeros(26)}, "theta"),
    ({"pi_r": np.zeros((30, 2, 36, 12))}, "pi_r"),
    ({"last": _last((np.full((30, 3, 36), 12), np.zeros((30, 3, 36), np.int64)))}, "greedy_h"),
    ({"state_reward": np.zeros((30, 3, 35))}, "state_reward"),
    ({}, "out.q_h"),
    ({"state_traces": [np.array([0, 36])] * 30}, "state_traces"),
])
def test_update_refuses_bad_inputs_before_any_kernel_runs(path, change, field):
    tables, params, theta, pi_r, warm, traces, intentions = _models_inputs(4)
    args = dict(theta=theta, pi_r=pi_r, last=_last(warm), state_traces=traces,
                intentions=intentions) | change
    if field == "out.q_h":
        good = algorithm1.update(tables, params, theta, pi_r, _last(warm))
        args["workspace"] = _into(good._replace(q_h=np.zeros((30, 3, 36, 11))))
    with pytest.raises(ConfigError) as err:
        algorithm1.update(tables, params, args.pop("theta"), args.pop("pi_r"), **args)
    assert err.value.field == field


def test_a_learner_writes_into_arrays_only_with_a_workspace():
    """With a workspace, each update writes into the arrays of the update before last (the
    same numbers as fresh arrays); without one, an array it handed out is never changed."""
    graph, trace = _wheel_trace()
    traces = [trace] * 20
    plain, reusing = Learner(graph, 20), Learner(graph, 20, workspace=algorithm1.Workspace())
    held = []
    for e in range(4):
        for learner in (plain, reusing):
            learner.end_episode(traces if e % 2 else traces[:1] * 20, np.full(20, 1 + e % 2))
        held.append((plain.q_r, plain.q_r.copy(), reusing.q_r))
        for a, b in zip(plain._models, reusing._models, strict=True):
            assert a.tobytes() == b.tobytes()
    assert all(np.array_equal(a, copy) for a, copy, _ in held)  # never overwritten
    assert len({id(a) for a, _, _ in held}) == 4
    assert held[2][2] is held[0][2] and held[3][2] is held[1][2]  # two sets, alternating


def test_a_theta_changed_in_place_is_the_one_the_next_update_learns_from():
    """The Learner keeps θ·φ for the next IRL step; a θ written into in place makes it
    compute θ·φ again: the models of update without the kept θ·φ."""
    graph, trace = _wheel_trace()
    traces, ints = [trace] * 4, np.array([1, 2, -1, 1])
    learner = Learner(graph, 4)
    learner.end_episode(traces, ints)
    learner.theta[1] = 0.5
    last = learner._models
    expected = algorithm1.update(learner._tables, learner._params, learner.theta,
                                 learner.pi_r, last, state_traces=[t.states for t in traces],
                                 intentions=ints)
    learner.end_episode(traces, ints)
    for name, value in (("theta", expected.theta), ("pi_h", expected.pi_h),
                        ("pi_r", expected.pi_r)):
        assert getattr(learner, name).tobytes() == value.tobytes(), name


@needs_jit
def test_the_elimination_order_takes_leaves_before_their_hub():
    """A hub every state moves to, and that moves to every other state: eliminated first
    it would fill its neighbours into a clique; minimum degree takes the leaves first (the
    lowest state on ties) and the hub once only one leaf is left. The transposed table
    (the partner's view) gives the same order."""
    jit = partner_mdp.kernels()
    nxt = np.zeros((5, 2, 2), np.int64)  # (S, own, partner): states 1-4 go to the hub 0
    nxt[0] = [[1, 2], [3, 4]]
    valid = np.ones((5, 2), bool)
    rank = jit.elimination_rank(jit.own_last_index(nxt), valid)
    assert rank.tolist() == [3, 0, 1, 2, 4]
    swapped = np.ascontiguousarray(np.swapaxes(nxt, 1, 2))
    assert jit.elimination_rank(jit.own_last_index(swapped), valid).tolist() == rank.tolist()
    wheel = graph_for("wheel")
    order = jit.elimination_rank(jit.own_last_index(np.array(wheel.next_state)),
                                 np.array(wheel.valid))
    assert sorted(order.tolist()) == list(range(wheel.n_states))  # a permutation
