"""The numpy-batched robot env: make_vec, agreement with the single env, autoreset, errors."""

import itertools

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs.envs import RobotEnv, RobotVectorEnv
from hri_envs.errors import ActionError, ConfigError

IDS = ["hri_envs/Hanger-v0", "hri_envs/Wheel-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_make_vec_with_the_vector_entry_point(env_id):
    envs = gym.make_vec(env_id, num_envs=16, vectorization_mode="vector_entry_point")
    assert isinstance(envs.unwrapped, RobotVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, _ = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)
    for _ in range(20):
        obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
        assert envs.observation_space.contains(obs)
        assert rew.shape == term.shape == trunc.shape == (16,)
        assert info["aborted"].shape == info["invalid_action"].shape == (16,)
        assert np.array_equal(envs.unwrapped.action_masks(), obs["action_mask"].astype(bool))


def _pairs(n_supports):
    return [(s, i) for s, i in itertools.product(range(n_supports), repeat=2) if s != i]


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
@pytest.mark.parametrize("turn_back", [False, True])
def test_agrees_with_the_single_env(scenario, turn_back):
    """Same starts, intentions and robot actions, deterministic human: same episodes."""
    single = RobotEnv(scenario, max_cycles=40)
    pairs = _pairs(single.graph.n_intentions) * 4  # (start, intention) per env
    n, n_a = len(pairs), single.action_space.n
    start, intention = (np.array(x) for x in zip(*pairs, strict=True))
    vec = RobotVectorEnv(n, scenario, max_cycles=40)
    obs_v, _ = vec.reset(seed=5, options={"start": start, "intention": intention,
                                          "turn_back": turn_back})
    # robot: the human's preferred action, sometimes replaced by a random one
    rng = np.random.default_rng(3)
    noise = rng.integers(n_a, size=(40, n))
    use_noise = rng.random((40, n)) < 0.3
    trace_v = [obs_v]
    for t in range(40):
        want = single.human.preferred_action(obs_v["state"], start, vec.intention)
        obs_v, rew, term, trunc, info = vec.step(np.where(use_noise[t], noise[t], want))
        trace_v.append((obs_v, rew, term, trunc, info))
    checked = 0
    for j, (s, i) in enumerate(pairs):
        obs, _ = single.reset(seed=0, options={"start": s, "intention": i,
                                               "turn_back": turn_back})
        _assert_same_obs(obs, trace_v[0], j)
        for t in range(40):
            want = single.human.preferred_action(obs["state"], s, single.intention)
            obs, rew, term, trunc, info = single.step(noise[t, j] if use_noise[t, j] else want)
            obs_v, rew_v, term_v, trunc_v, info_v = trace_v[t + 1]
            _assert_same_obs(obs, obs_v, j)
            assert (rew, term, trunc) == (rew_v[j], term_v[j], trunc_v[j])
            assert info["aborted"] == info_v["aborted"][j]
            assert info["invalid_action"] == info_v["invalid_action"][j]
            checked += 1
            if term or trunc:
                break
    assert checked > 4 * n


def _assert_same_obs(obs, obs_v, j):
    for key in ("state", "start", "last_human_action"):
        assert obs[key] == obs_v[key][j], key
    assert np.array_equal(obs["action_mask"], obs_v["action_mask"][j])


def test_next_step_autoreset():
    vec = RobotVectorEnv(64, "hanger", max_cycles=3)
    vec.reset(seed=0)
    wait = np.zeros(64, dtype=np.int64)
    for _ in range(2):
        _, _, term, trunc, _ = vec.step(wait)
        assert not (term | trunc).any()
    _, rew, term, trunc, _ = vec.step(wait)
    assert trunc.all() and not term.any() and (rew == -1.0).all()
    obs, rew, term, trunc, info = vec.step(np.full(64, 3))  # ignored: these envs reset
    assert (rew == 0.0).all() and not (term | trunc).any() and not info["aborted"].any()
    assert np.isin(obs["state"], [0, 4, 8]).all() and (obs["last_human_action"] == 0).all()
    assert (obs["start"] == obs["state"] // 4).all()
    assert len(np.unique(obs["start"])) == 3
    _, _, _, trunc, _ = vec.step(wait)
    assert not trunc.any()  # the step counter restarted


def test_terminated_episodes_restart_while_others_run():
    vec = RobotVectorEnv(2, "hanger")
    vec.reset(seed=0, options={"start": ["B", "A"], "intention": ["C", "B"]})
    # env 0 goes B -> C in 5 steps (the robot helps the human); in env 1 the robot waits,
    # so the human grasps the object and waits for the robot
    for a in (1, 2, 7, 3, 1):
        obs, rew, term, trunc, _ = vec.step(np.array([a, 0]))
    assert term.tolist() == [True, False] and obs["state"][0] == 8
    obs, rew, term, _, _ = vec.step(np.array([0, 0]))
    assert obs["state"][0] in (0, 4, 8) and rew[0] == 0.0 and obs["state"][1] == 1


def test_reset_seed_reproduces():
    vec = RobotVectorEnv(32, "wheel", human_passive=0.3, turn_back=0.5)
    actions = np.random.default_rng(0).integers(12, size=(30, 32))
    runs = []
    for _ in range(2):
        out = [vec.reset(seed=9)[0]["state"]]
        out += [vec.step(a)[0]["state"] for a in actions]
        runs.append(np.array(out))
    assert np.array_equal(runs[0], runs[1])


def test_bad_actions_and_options_raise():
    vec = RobotVectorEnv(4, "hanger")
    with pytest.raises(RuntimeError, match="reset"):
        vec.step(np.zeros(4, dtype=np.int64))
    vec.reset(seed=0)
    with pytest.raises(ActionError, match=r"robot action\(s\) \[10\] .*0\.\.9"):
        vec.step(np.array([0, 10, 1, 2]))
    with pytest.raises(ActionError, match=r"shape \(4,\)"):
        vec.step(np.zeros(3, dtype=np.int64))
    with pytest.raises(ActionError, match="integer"):
        vec.step(np.zeros(4))
    with pytest.raises(ConfigError, match="allowed: start, intention, turn_back"):
        vec.reset(options={"layout": ((0, 2), (1, 2))})
    with pytest.raises(ConfigError, match="must differ"):
        vec.reset(options={"start": "A", "intention": [1, 2, 0, 1]})
    with pytest.raises(ConfigError, match="num_envs"):
        RobotVectorEnv(0)
    with pytest.raises(ConfigError, match="allowed: None"):
        RobotVectorEnv(2, render_mode="rgb_array")


def test_same_step_autoreset_returns_the_next_first_observation():
    env = gym.make_vec("hri_envs/Hanger-v0", num_envs=8, vectorization_mode="vector_entry_point",
                       autoreset_mode=AutoresetMode.SAME_STEP)
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    graph = env.unwrapped.graph
    obs, _ = env.reset(seed=1)
    ended_once = False
    for _ in range(200):
        actions = env.unwrapped.action_masks().argmax(axis=1)  # first valid action
        obs, reward, terminated, truncated, info = env.step(actions)
        ended = terminated | truncated
        if ended.any():
            ended_once = True
            assert np.array_equal(info["_final_obs"], ended)
            for i in np.flatnonzero(ended):
                final = info["final_obs"][i]
                if terminated[i]:  # resting on a goal, nobody holding it
                    assert graph.support[final["state"]] >= 0 and graph.grasp[final["state"]] == 0
                # the returned observation already starts the next episode
                assert obs["state"][i] == 4 * obs["start"][i]
                assert obs["last_human_action"][i] == 0
    assert ended_once
    with pytest.raises(ValueError, match="autoreset_mode must be"):
        gym.make_vec("hri_envs/Hanger-v0", num_envs=2, vectorization_mode="vector_entry_point",
                     autoreset_mode="sometimes")


def test_a_replaced_human_acts_from_the_next_step():
    """The deterministic human's look-up table follows ``env.human`` when it is replaced."""
    from hri_envs.humans.scripted import preference_human

    vec = RobotVectorEnv(4, "wheel", preference="straight")
    obs, _ = vec.reset(seed=0, options={"start": "A", "intention": ["B", "C", "B", "C"]})
    straight, detour = vec.human, preference_human(vec.graph, "detour")
    differ = False
    for _ in range(12):  # the robot follows the straight human until the routes part
        want_s = straight.preferred_action(obs["state"], obs["start"], vec.intention)
        want_d = detour.preferred_action(obs["state"], obs["start"], vec.intention)
        if (want_s != want_d).any():
            differ = True
            break
        obs, *_ = vec.step(want_s)
    assert differ
    vec.human = detour
    obs, *_ = vec.step(np.zeros(4, dtype=np.int64))  # the robot waits: the human acts
    np.testing.assert_array_equal(obs["last_human_action"], want_d)
    vec.human = preference_human(vec.graph, "detour", passive=1.0)  # sampled: always waits
    obs, *_ = vec.step(np.zeros(4, dtype=np.int64))
    assert (obs["last_human_action"] == 0).all()


def test_a_replaced_human_turns_back_where_it_would():
    """A human replaced before reset turns back at its own turning states, not the old one's."""
    from hri_envs.humans.scripted import preference_human

    vec = RobotVectorEnv(4, "wheel", preference="straight")
    detour = preference_human(vec.graph, "detour", turn_back=1.0)
    straight = preference_human(vec.graph, "straight", turn_back=1.0)
    assert (detour.turn_state != straight.turn_state).any()
    vec.human = detour
    vec.reset(seed=0)
    np.testing.assert_array_equal(vec._turn_at, detour.turn_state[vec._start, vec.intention])


# Digests of 60 seeded steps of 16 envs, recorded from the v0 vector env before its step was
# rewritten around the fused StepTable: the same seed must keep giving the same numbers
# (random human draws, turning back, autoresets, both autoreset modes, the reward variant).
FROZEN_V0 = [
    ("hanger", {}, "NextStep", "65b5c927211f2f35"),
    ("wheel", {"human_passive": 0.3, "turn_back": 0.5}, "NextStep", "ea176f795ec1dba9"),
    ("hanger", {"turn_back": 0.4, "reward": "no-free-toggle", "max_cycles": 7}, "SameStep",
     "212b2ab4e5f4f167"),
    ("wheel", {"preference": "detour", "max_cycles": 9}, "SameStep", "5233fc35d7bba965"),
]


@pytest.mark.parametrize(("scenario", "kwargs", "mode", "digest"), FROZEN_V0)
def test_seeded_steps_are_those_of_v0(scenario, kwargs, mode, digest):
    import hashlib

    env = RobotVectorEnv(16, scenario, autoreset_mode=mode, **kwargs)
    rng = np.random.default_rng(1)
    env.reset(seed=7)
    h = hashlib.sha256()
    for _ in range(60):
        mask = env.action_masks()
        obs, reward, term, trunc, info = env.step(np.argmax(rng.random(mask.shape) * mask, 1))
        for a in (obs["state"], obs["start"], obs["last_human_action"], env.intention,
                  reward, term, trunc, info["aborted"], info["invalid_action"]):
            h.update(np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<")).tobytes())
    assert h.hexdigest()[:16] == digest


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
@pytest.mark.parametrize("kwargs", [{}, {"human_passive": 0.5, "turn_back": 0.5}])
def test_returned_arrays_are_never_changed_afterwards(mode, kwargs):
    """Some arrays are handed out without a copy: later steps and resets must not write them."""
    vec = RobotVectorEnv(8, "hanger", autoreset_mode=mode, max_cycles=6, **kwargs)
    rng = np.random.default_rng(0)
    kept = []
    out = vec.reset(seed=3)
    for t in range(40):
        kept.append((out, [np.array(a, copy=True) for a in _arrays(out)]))
        if t == 20:
            out = vec.reset()
            continue
        mask = vec.action_masks()
        out = vec.step(np.argmax(rng.random(mask.shape) * mask, 1))
    restarted = sum(int(o[2].sum() + o[3].sum()) for o, _ in kept if len(o) == 5)
    assert restarted > 8  # episodes ended (and restarted) in place while arrays were kept
    for then, copies in kept:
        for a, b in zip(_arrays(then), copies, strict=True):
            np.testing.assert_array_equal(a, b)


def _arrays(out):
    """Every array of a reset's or a step's return value."""
    found = []
    for x in out:
        if isinstance(x, dict):
            found += [v for k, v in sorted(x.items()) if isinstance(v, np.ndarray)
                      and v.dtype != object]
        elif isinstance(x, np.ndarray):
            found.append(x)
    return found
