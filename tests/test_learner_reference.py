"""The Learner's numbers equal those recorded before its update was restructured for speed.

``tests/data/learner_reference.npz`` holds real traces (wheel and hanger, passive humans,
truncated episodes) and the model the Learner had after each update, recorded by
``tests/data/make_learner_reference.py`` from the implementation of commit ef0eadf.
"""

from pathlib import Path

import numpy as np
import pytest

from agents.learner import Learner
from agents.learning import mdp
from agents.protocol import Trace
from hri_bench.run.study import graph_for
from hri_envs.task import mdp as task_mdp
from tests.data.make_learner_reference import ARRAYS, CASES

DATA = Path(__file__).parent / "data" / "learner_reference.npz"


@pytest.fixture(scope="module")
def reference():
    with np.load(DATA) as data:
        return {k: data[k] for k in data.files}


@pytest.mark.parametrize("case", range(len(CASES)))
def test_replayed_traces_give_the_recorded_models(reference, case):
    scenario, *_ = CASES[case]
    states, intentions = reference[f"{case}/states"], reference[f"{case}/intentions"]
    n_e, n_b = intentions.shape
    learner = Learner(graph_for(scenario), n_b, seed=3)
    valid = learner.graph.valid
    for e in range(n_e):
        traces = [Trace(row[row >= 0], np.zeros((row >= 0).sum() - 1, np.int64),
                        np.zeros((row >= 0).sum() - 1, np.int64)) for row in states[e]]
        learner.end_episode(traces, intentions[e])
        for name in ARRAYS:
            np.testing.assert_allclose(getattr(learner, name), reference[f"{case}/{name}"][e],
                                       rtol=0, atol=1e-9, err_msg=f"{name} after episode {e}")
        pi_r = task_mdp.softmax(learner.q_r, valid, learner.config.robot_model_temperature)
        np.testing.assert_allclose(learner.pi_r, pi_r, rtol=0, atol=1e-12)


def test_the_reference_covers_truncation_and_loops(reference):
    """The recorded traces exercise the branches the update has: nothing revealed, loops."""
    truncated = sum(int((reference[f"{i}/intentions"] < 0).sum()) for i in range(len(CASES)))
    assert truncated > 0
    looped = 0
    for i in range(len(CASES)):
        for row in reference[f"{i}/states"].reshape(-1, reference[f"{i}/states"].shape[-1]):
            path = row[row >= 0]
            looped += len(mdp.remove_loops(path)) < len(path)
    assert looped > 0


def test_partner_index_is_cached_per_read_only_table_only():
    g = graph_for("wheel")
    assert task_mdp.partner_index(g.next_state) is task_mdp.partner_index(g.next_state)
    swapped = np.swapaxes(g.next_state, 1, 2)
    assert task_mdp.partner_index(swapped) is not task_mdp.partner_index(g.next_state)
    writeable = g.next_state.copy()
    n_s, n_a = g.n_states, g.n_actions
    first = task_mdp.partner_index(writeable).onehot[0, 0].reshape(n_a, n_s)
    assert first[0].argmax() == g.next_state[0, 0, 0]
    writeable[0, 0, 0] = 1
    changed = task_mdp.partner_index(writeable).onehot[0, 0].reshape(n_a, n_s)
    assert changed[0].argmax() == 1 and changed[0].sum() == 1


def test_partner_transitions_match_a_direct_sum():
    """T(s'|s, a) = Σ_p π(p|s) 1[next(s, a, p) = s'], summed by hand for random policies."""
    g = graph_for("hanger")
    rng = np.random.default_rng(1)
    pi = rng.random((2, g.n_states, g.n_actions))
    pi /= pi.sum(-1, keepdims=True)
    expected = np.zeros((2, g.n_states, g.n_actions, g.n_states))
    for b, s, a, p in np.ndindex(2, g.n_states, g.n_actions, g.n_actions):
        expected[b, s, a, g.next_state[s, a, p]] += pi[b, s, p]
    np.testing.assert_allclose(task_mdp.robot_transition(g.next_state, pi), expected, atol=1e-15)


def test_one_blas_thread_limits_inside_and_restores_after():
    controllers = task_mdp._blas_controllers()
    assert controllers, "numpy's BLAS should be visible to threadpoolctl"
    before = [c.get_num_threads() for c in controllers]
    with task_mdp.one_blas_thread():
        assert [c.get_num_threads() for c in controllers] == [1] * len(controllers)
    assert [c.get_num_threads() for c in controllers] == before
    with pytest.raises(KeyError), task_mdp.one_blas_thread():
        raise KeyError("restored on errors too")
    assert [c.get_num_threads() for c in controllers] == before
