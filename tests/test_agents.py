"""The Learner and baselines: the paper's qualitative claims on small seeds, batching,
persistence and robustness."""

import json

import numpy as np
import pytest

from agents import Learner, LearnerStateError, Trace, default_config
from agents.protocol import Agent, Batched
from baselines import Imitator, MaxEntIRL, Oracle, Passive
from hri_bench.run.runner import make_schedule, simulate
from hri_envs.humans.scripted import preference_human
from hri_envs.task.graph import ROTATE, WAIT


class Recorder(Learner):
    """A Learner that remembers the states in which it waited in each episode."""

    def begin_episode(self, starts):
        super().begin_episode(starts)
        self.waited = [[] for _ in range(self.n_runs)]

    def observe(self, states, robot_actions, human_actions, next_states, active):
        for i in np.flatnonzero(active & (robot_actions == WAIT)):
            self.waited[i].append(int(states[i]))
        super().observe(states, robot_actions, human_actions, next_states, active)


def study(graph, agent, human, episodes=8, runs=30, r0=-0.25, seed=0):
    r = np.arange(runs)
    return simulate(graph, agent, human, make_schedule(graph, "random", r, episodes, seed, human),
                    runs=r, seed=seed, r0=r0)


def test_learner_beats_imitator_and_maxent_on_the_wheel(wheel):
    """Paper Fig. 10a: straight preference, r0 = -0.25, deterministic human."""
    human = preference_human(wheel, "straight")
    cfg = default_config("wheel")
    learner = Recorder(wheel, 30, cfg)
    ours = study(wheel, learner, human)
    imitator = study(wheel, Imitator(wheel, 30), human)
    maxent = study(wheel, MaxEntIRL(wheel, 30), human)
    late = slice(5, 8)
    assert ours.reward[:, late].mean() > imitator.reward[:, late].mean() + 0.2
    assert ours.reward[:, late].mean() > maxent.reward[:, late].mean() + 0.2
    assert ours.reward[:, 0].mean() < ours.reward[:, late].mean()  # it learned
    # It waits only where the human reveals the goal: the start's mounting point.
    mounting = set(wheel.mounting_state.tolist())
    waited = {s for run in learner.waited for s in run}
    assert waited <= mounting, [wheel.state_names[s] for s in waited - mounting]
    assert ours.wrong[:, late].mean() < 0.02


def test_oracle_and_passive_bracket_the_learner(wheel):
    human = preference_human(wheel, "straight")
    oracle = study(wheel, Oracle(wheel, human, 20), human, runs=20)
    passive = study(wheel, Passive(wheel, 20), human, runs=20)
    learner = study(wheel, Learner(wheel, 20), human, runs=20)
    assert np.all(oracle.reward == 0.0)
    assert passive.reward.mean() < learner.reward[:, 4:].mean() < 0.0


def test_hanger_learns_the_preferred_actions_in_the_critical_states(hanger):
    """Paper Fig. 8, most frequent preference: the preferred actions become the robot's most
    likely actions for the intention in s4, s1, s3 (s10 is learned more slowly)."""
    human = preference_human(hanger)  # down-over-rotate / over-rotate-up
    learner = Learner(hanger, 40)
    study(hanger, learner, human, episodes=10, runs=40, r0=-0.33)
    w = hanger.waypoint_state
    a, b = 0, 1
    critical = {
        "s4: B low rail-facing, to A: move over to A": (w(1, 0, 1), a, hanger.move_over(a)),
        "s1: A' peg-facing, to B: move over to B": (w(0, 0, 0), b, hanger.move_over(b)),
        "s3: B low peg-facing, to B: rotate": (w(1, 0, 0), b, ROTATE),
    }
    for label, (s, iota, preferred) in critical.items():
        pi_r = learner.robot_policy(s, iota)
        assert np.mean(pi_r.argmax(-1) == preferred) >= 0.8, label
        assert np.median(pi_r[:, preferred] / pi_r[:, WAIT]) > 1.0, label
        assert np.median(learner.human_policy(s, iota)[:, preferred]) > 0.5, label
    s10 = w(1, 1, 1)  # B' rail-facing: moving down to A is learned, if slower
    assert np.median(learner.human_policy(s10, a)[:, hanger.move_to_height(0)]) > 0.5


def test_batched_equals_unbatched(wheel):
    human = preference_human(wheel, "detour")
    runs = np.arange(3)
    sched = make_schedule(wheel, "random", runs, 3, 5, human)
    batch = Learner(wheel, 3, seed=5)
    m = simulate(wheel, batch, human, sched, runs=runs, seed=5, r0=-0.25)
    for i in range(3):
        one = Learner(wheel, 1, seed=5, runs=[i])
        sub = make_schedule(wheel, "random", [i], 3, 5, human)
        mi = simulate(wheel, one, human, sub, runs=[i], seed=5, r0=-0.25)
        np.testing.assert_array_equal(mi.reward[0], m.reward[i])
        np.testing.assert_allclose(one.theta[0], batch.theta[i], atol=1e-12)


def test_learner_policies_are_distributions(hanger):
    learner = Learner(hanger, 2)
    for arr in (learner.pi_h, learner.pi_r):
        np.testing.assert_allclose(arr.sum(-1), 1.0)
        assert np.all(arr[..., ~hanger.valid] == 0.0)
    assert np.all(np.abs(learner.theta) <= 1.0)


def test_belief_never_breaks_and_follows_a_change_of_mind(hanger):
    learner = Learner(hanger, 1)
    learner.begin_episode(np.array([0]))
    # The human does something the model finds impossible (an invalid action index): the
    # belief stays a distribution.
    s = np.array([hanger.waypoint_state(0, 0, 0)])
    learner.pi_h[:] = 0.0
    learner.observe(s, np.array([0]), np.array([9]), s, np.ones(1, bool))
    assert np.all(np.isfinite(learner.belief())) and learner.belief().sum() == pytest.approx(1.0)
    # Restore a model and show evidence for going back to A (the start): belief recovers.
    fresh = Learner(hanger, 1)
    fresh.begin_episode(np.array([0]))
    fresh.pi_h[0, :, s[0], :] = 0.0
    fresh.pi_h[0, 0, s[0], 3] = 1.0  # put on A: only intention A does that
    fresh.pi_h[0, 1:, s[0], 0] = 1.0
    for _ in range(3):
        fresh.observe(s, np.array([0]), np.array([3]), s, np.ones(1, bool))
    assert fresh.belief()[0].argmax() == 0


def test_save_load_round_trip_gives_the_same_actions(tmp_path, hanger):
    human = preference_human(hanger)
    learner = Learner(hanger, 4, seed=3)
    study(hanger, learner, human, episodes=3, runs=4, r0=-0.33, seed=3)
    path = tmp_path / "learner.npz"
    learner.save(path)
    loaded = Learner.load(path, hanger, seed=3)
    np.testing.assert_array_equal(loaded.theta, learner.theta)
    states = np.array([hanger.waypoint_state(1, 1, 1)] * 4)
    for agent in (learner, loaded):
        agent.begin_episode(np.array([1, 1, 1, 1]))
    np.testing.assert_allclose(loaded.policy(states), learner.policy(states))


def test_load_rejects_other_scenarios_and_damage(tmp_path, hanger, wheel):
    path = tmp_path / "h.npz"
    Learner(hanger, 1).save(path)
    with pytest.raises(LearnerStateError, match="hanger"):
        Learner.load(path, wheel)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip file")
    with pytest.raises(LearnerStateError, match="not a readable"):
        Learner.load(bad, hanger)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["pi_r"] = arrays["pi_r"] * np.nan
    nan_path = tmp_path / "nan.npz"
    np.savez(nan_path, **arrays)
    with pytest.raises(LearnerStateError, match="NaN"):
        Learner.load(nan_path, hanger)
    meta = json.loads(str(arrays["meta"]))
    meta["format"] = "something-else"
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(nan_path, **arrays)
    with pytest.raises(LearnerStateError, match="format"):
        Learner.load(nan_path, hanger)


def _saved_arrays(path):
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


@pytest.mark.parametrize(("key", "value", "fragment"), [
    ("theta", 1e308, "theta holds 1e\\+308 .* kept in \\[-1, 1\\]"),
    ("theta", -1.5, "theta holds 1.5 .* kept in \\[-1, 1\\]"),
    ("q_r", 1e308, "q_r holds 1e\\+308 .* within ±10"),
    ("q_r", -50.0, "q_r holds 50 in absolute value"),
])
def test_load_refuses_arrays_out_of_range(tmp_path, hanger, key, value, fragment):
    """θ = 1e308 used to load and divide by zero in episode 2; a Q no rewards give too."""
    path = tmp_path / "learner.npz"
    Learner(hanger, 2).save(path)
    arrays = _saved_arrays(path)
    arrays[key] = arrays[key].copy()
    arrays[key].reshape(-1)[3] = value
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(LearnerStateError, match=fragment):
        Learner.load(path, hanger)


def _deflate_bomb(path, arrays, bombs):
    """``arrays`` as an .npz, but each of ``bombs`` (name -> shape) a member of that shape's
    zeros, deflated (a few hundred kB that declare hundreds of MB)."""
    import io
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, array in arrays.items():
            if name not in bombs:
                buf = io.BytesIO()
                np.lib.format.write_array(buf, array)
                zf.writestr(f"{name}.npy", buf.getvalue())
                continue
            shape = bombs[name]
            buf = io.BytesIO()
            np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False,
                                                       "shape": shape})
            with zf.open(f"{name}.npy", "w", force_zip64=True) as f:
                f.write(buf.getvalue())
                left = int(np.prod(shape)) * 8
                chunk = bytes(8 * 2**20)
                while left > 0:
                    f.write(chunk[:left])
                    left -= len(chunk)


@pytest.mark.parametrize("kind", ["one member", "all consistent"])
def test_a_deflate_bomb_is_refused_before_it_is_inflated(tmp_path, hanger, kind):
    """Each member's header and its size in the zip directory are read first: a member
    that declares 300 MB (a mismatched shape, or a state larger than MAX_STATE_BYTES)
    is refused having allocated next to nothing."""
    import tracemalloc

    path = tmp_path / "learner.npz"
    Learner(hanger, 2).save(path)
    arrays = _saved_arrays(path)
    n_i, n_s, n_a = hanger.n_intentions, hanger.n_states, hanger.n_actions
    if kind == "one member":
        bombs = {"pi_h": (52_000, n_i, n_s, n_a)}  # 300 MB, theta says 2 runs
        fragment = "pi_h has shape"
    else:
        b = 16_000  # every array of 16,000 runs: 276 MB in all
        bombs = {"theta": (b, hanger.n_features), "pi_h": (b, n_i, n_s, n_a),
                 "q_r": (b, n_i, n_s, n_a), "pi_r": (b, n_i, n_s, n_a)}
        fragment = "more than 256 MiB"
    _deflate_bomb(path, arrays, bombs)
    assert path.stat().st_size < 2 * 2**20
    tracemalloc.start()
    try:
        with pytest.raises(LearnerStateError, match=fragment):
            Learner.load(path, hanger)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 32 * 2**20, f"{peak / 2**20:.0f} MiB allocated before refusing"


def test_load_refuses_a_member_whose_size_is_not_its_header(tmp_path, hanger):
    import zipfile

    path = tmp_path / "learner.npz"
    Learner(hanger, 1).save(path)
    arrays = _saved_arrays(path)
    with zipfile.ZipFile(path, "w") as zf:
        for name, array in arrays.items():
            import io

            buf = io.BytesIO()
            np.lib.format.write_array(buf, array)
            zf.writestr(f"{name}.npy", buf.getvalue() + (b"x" * 100 if name == "q_r" else b""))
    with pytest.raises(LearnerStateError, match="q_r takes .* but its header declares"):
        Learner.load(path, hanger)


def test_load_never_unpickles(tmp_path, hanger):
    path = tmp_path / "learner.npz"
    Learner(hanger, 1).save(path)
    arrays = _saved_arrays(path)
    arrays["meta"] = np.array([{"format": "x"}], dtype=object)
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(LearnerStateError, match="meta holds Python objects"):
        Learner.load(path, hanger)


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="r0 must be in"):
        default_config("wheel", r0=0.5)
    with pytest.raises(ValueError, match="unknown parameter"):
        default_config("wheel", tau=3)
    with pytest.raises(ValueError, match="unknown scenario"):
        default_config("kitchen")


def test_user_agents_plug_in_through_batched(wheel):
    class Copycat(Agent):
        name = "copycat"

        def begin_episode(self, start):
            self.episodes = getattr(self, "episodes", 0)

        def act(self, observation):
            a = int(observation["last_human_action"])
            return a if observation["action_mask"][a] else 0

        def observe(self, state, robot_action, human_action, next_state):
            pass

        def end_episode(self, trace, intention):
            assert isinstance(trace, Trace)
            self.episodes += 1

    human = preference_human(wheel, "straight")
    agent = Batched.from_factory(lambda run: Copycat(), range(4))
    m = study(wheel, agent, human, episodes=2, runs=4)
    assert m.reward.shape == (4, 2)
    assert all(a.episodes == 2 for a in agent.agents)
    single = Learner(wheel, 1).single()
    single.begin_episode(0)
    mask = wheel.valid[0].astype(np.int8)
    action = single.act({"state": 0, "start": 0, "last_human_action": 0, "action_mask": mask})
    assert mask[action]


def test_learner_learns_inside_the_gymnasium_env():
    import gymnasium as gym

    import hri_envs  # noqa: F401  (registers the ids)
    from agents.rollout import run_episode

    env = gym.make("hri_envs/Wheel-v0", preference="straight", r0=-0.25)
    robot = Learner(env.unwrapped.graph, 1, default_config("wheel"), seed=0).single()
    rewards = [run_episode(env, robot, seed=e).reward for e in range(10)]
    assert np.mean(rewards[-4:]) > np.mean(rewards[:2]) + 0.3
    assert rewards[-1] >= -0.5


def test_a_truncated_episode_reveals_nothing(wheel):
    """Intention -1 (cut off by the step limit): the IRL models keep their parameters."""
    trace = Trace(np.array([0, 1, 3, wheel.mounting_state[0]]), np.zeros(3, np.int64),
                  np.array([1, 1, 2]))
    for agent in (Learner(wheel, 2), MaxEntIRL(wheel, 2)):
        before = agent.theta.copy()
        agent.end_episode([trace, trace], np.array([-1, 1]))
        np.testing.assert_array_equal(agent.theta[0], before[0])
        assert not np.array_equal(agent.theta[1], before[1])
