"""Observation formats, the human's goal reward, reached_intention and PartnerEnv."""

import re

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

from hri_envs import hanger_v0, wheel_v0
from hri_envs.envs.formats import ClassicLayout
from hri_envs.envs.partner import (
    PartnerEnv,
    following_robot,
    random_valid_policy,
    waiting_policy,
)
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human

MODULES = [pytest.param(hanger_v0, id="hanger"), pytest.param(wheel_v0, id="wheel")]
WAIT, TOGGLE = 0, 1


def preferred(human, state, start, goal):
    return int(human.preferred_action(np.array(state), np.array(start), np.array(goal)))


# ------------------------------------------------------------------------ observation formats
def test_classic_observation_hand_computed():
    env = hanger_v0.parallel_env(observation_format="classic")
    obs, _ = env.reset(seed=0, options={"start": "B", "intention": "C"})
    s, k, a = 24, 3, 10  # hanger: S = 24 states, K = 3 supports, A = 10 actions
    n = s + k + a + k + 1
    assert env.observation_space("human") == env.observation_space("robot")
    assert env.observation_spaces["robot"]["observation"].shape == (n,)
    state = env.state()[0]
    robot = obs["robot"]["observation"]
    human = obs["human"]["observation"]
    assert robot.dtype == np.float32 and robot.shape == (n,)
    assert np.flatnonzero(robot).tolist() == [state, s + 1, s + k + WAIT, n - 1]
    assert np.flatnonzero(human).tolist() == [state, s + 1, s + k + WAIT, s + k + a + 2]
    assert obs["robot"]["action_mask"].dtype == np.int8
    np.testing.assert_array_equal(obs["robot"]["action_mask"], env.graph.valid[state])


@pytest.mark.parametrize("mod", MODULES)
@pytest.mark.parametrize("fmt", ["classic", "flat"])
def test_formats_carry_the_dict_observation(mod, fmt):
    """Same seed, same actions: the other formats decode to the dict format's observation."""
    ref, env = mod.parallel_env(), mod.parallel_env(observation_format=fmt)
    g = ref.graph
    layout = ClassicLayout(g.n_states, g.n_intentions, g.n_actions)
    rng = np.random.default_rng(5)
    for ep in range(3):
        o_ref, _ = ref.reset(seed=ep)
        o, _ = env.reset(seed=ep)
        while ref.agents:
            for agent in ("human", "robot"):
                vec = o[agent] if fmt == "flat" else o[agent]["observation"]
                mask = vec[layout.size:] if fmt == "flat" else o[agent]["action_mask"]
                assert env.observation_space(agent).contains(o[agent])
                d = layout.decode(vec)
                assert d["state"] == o_ref[agent]["state"]
                assert d["start"] == o_ref[agent]["start"]
                assert d["last_human_action"] == o_ref[agent]["last_human_action"]
                assert d["intention"] == o_ref[agent].get("intention")
                np.testing.assert_array_equal(mask, o_ref[agent]["action_mask"])
            acts = {ag: int(rng.choice(np.flatnonzero(o_ref[ag]["action_mask"])))
                    for ag in ("human", "robot")}
            o_ref, r_ref, *_ = ref.step(acts)
            o, r, *_ = env.step(acts)
            assert r == r_ref


def test_default_format_is_v0():
    env = hanger_v0.parallel_env()
    obs, _ = env.reset(seed=0)
    assert set(obs["robot"]) == {"state", "start", "last_human_action", "action_mask"}
    assert set(obs["human"]) == {"state", "start", "last_human_action", "action_mask",
                                 "intention"}
    assert env.observation_spaces["human"] is env.observation_space("human")
    assert env.action_spaces["robot"] == gym.spaces.Discrete(10)


@pytest.mark.parametrize("mod", MODULES)
def test_classic_passes_pettingzoo_tests(mod):
    parallel_api_test(mod.parallel_env(observation_format="classic"), num_cycles=100)
    api_test(mod.env(observation_format="classic"), num_cycles=100)
    parallel_seed_test(lambda **kw: mod.parallel_env(observation_format="classic", **kw))


@pytest.mark.parametrize("fmt", ["classic", "flat"])
def test_robot_env_formats(fmt):
    env = gym.make("hri_envs/Wheel-v0", observation_format=fmt)
    ref = gym.make("hri_envs/Wheel-v0")
    check_env(env.unwrapped, skip_render_check=True)
    g = env.unwrapped.graph
    layout = ClassicLayout(g.n_states, g.n_intentions, g.n_actions)
    o, _ = env.reset(seed=3)
    o_ref, _ = ref.reset(seed=3)
    for _ in range(20):
        vec = o if fmt == "flat" else o["observation"]
        d = layout.decode(vec)
        assert d["intention"] is None and d["state"] == o_ref["state"]
        a = int(np.flatnonzero(o_ref["action_mask"])[-1])
        o, r, term, trunc, _ = env.step(a)
        o_ref, r_ref, *_ = ref.step(a)
        assert r == r_ref
        if term or trunc:
            break


def test_bad_format_and_reward_name_what_is_allowed():
    with pytest.raises(ConfigError, match=re.escape(
            "unknown observation_format 'box'; allowed: 'dict', 'classic', 'flat'")) as e:
        hanger_v0.parallel_env(observation_format="box")
    assert e.value.field == "observation_format"
    with pytest.raises(ConfigError, match=re.escape(
            "unknown human_reward 'selfish'; allowed: 'cooperation', 'goal'")) as e:
        wheel_v0.env(human_reward="selfish")
    assert e.value.field == "human_reward"
    with pytest.raises(ConfigError, match="observation_format"):
        gym.make("hri_envs/Hanger-v0", observation_format=None)
    layout = ClassicLayout(24, 3, 10)
    with pytest.raises(ConfigError, match=re.escape("has shape (41,), a flat one (51,)")):
        layout.decode(np.zeros(40))


# ------------------------------------------------------------------------ the human's reward
@pytest.mark.parametrize("mod", MODULES)
def test_goal_reward_pays_the_human_for_reaching_its_goal(mod):
    """The preferred human with a following robot: 0 every step, +1 for the last one."""
    env = mod.parallel_env(human_reward="goal")
    human, robot = preference_human(env.graph), following_robot(env.graph)
    obs, info = env.reset(seed=0, options={"start": 0, "intention": 1})
    assert info["human"]["reached_intention"] is False
    rewards, robot_rewards = [], []
    while env.agents:
        acts = {"human": preferred(human, obs["human"]["state"], 0, 1),
                "robot": robot(obs["robot"], np.random.default_rng(0))}
        obs, r, term, trunc, info = env.step(acts)
        rewards.append(r["human"])
        robot_rewards.append(r["robot"])
        assert info["robot"]["robot_reward"] == r["robot"]
    assert term["human"] and not trunc["human"]
    assert rewards == [0.0] * (len(rewards) - 1) + [1.0]
    assert info["human"]["reached_intention"] is info["robot"]["reached_intention"] is True
    # the robot keeps R_R: it waits while the human moves, so it collects r0
    assert env.r0 in robot_rewards and 1.0 not in robot_rewards


def test_goal_reward_wrong_support_and_aborted_steps():
    env = hanger_v0.parallel_env(human_reward="goal")
    human, robot = preference_human(env.graph), following_robot(env.graph)
    obs, _ = env.reset(seed=0, options={"start": "A", "intention": "B"})
    # an aborted step: the human takes an action that is not valid in the state
    invalid = int(np.flatnonzero(obs["human"]["action_mask"] == 0)[0])
    obs, r, *_, info = env.step({"human": invalid, "robot": WAIT})
    assert info["human"]["aborted"] and r == {"human": -1.0, "robot": -1.0}
    # the human carries the object to C instead of its goal B
    while env.agents:
        acts = {"human": preferred(human, obs["human"]["state"], 0, 2),
                "robot": robot(obs["robot"], np.random.default_rng(0))}
        obs, r, term, _, info = env.step(acts)
        assert r["human"] == 0.0
    assert term["human"] and env.graph.support[env.state()[0]] == 2
    assert info["human"]["reached_intention"] is False


def test_cooperation_reward_is_the_default():
    env = wheel_v0.parallel_env()
    assert env.human_reward == "cooperation"
    obs, _ = env.reset(seed=1)
    _, r, *_ = env.step({"human": TOGGLE, "robot": WAIT})
    assert r["human"] == r["robot"]


def test_truncated_episode_did_not_reach_the_intention():
    env = gym.make("hri_envs/Hanger-v0", max_cycles=2)
    env.reset(seed=0)
    *_, trunc, info = env.step(WAIT)
    assert info["reached_intention"] is False
    *_, term, trunc, info = env.step(WAIT)
    assert trunc and not term and info["reached_intention"] is False


def test_robot_env_reports_reached_intention():
    env = gym.make("hri_envs/Hanger-v0")
    robot, rng = following_robot(env.unwrapped.graph), np.random.default_rng(0)
    obs, done, info = env.reset(seed=0, options={"start": "A", "intention": "C"})[0], False, {}
    while not done:  # the robot follows; the scripted human leads to its goal
        obs, _, term, trunc, info = env.step(robot(obs, rng))
        done = term or trunc
    assert term and info["reached_intention"] is True


# ------------------------------------------------------------------------ PartnerEnv
@pytest.mark.parametrize("learner", ["robot", "human"])
@pytest.mark.parametrize("fmt", ["dict", "classic", "flat"])
def test_partner_env_passes_gymnasium_checks(learner, fmt):
    env = PartnerEnv(hanger_v0.parallel_env(observation_format=fmt, human_reward="goal"),
                     learner=learner)
    check_env(env, skip_render_check=True)
    assert env.observation_space == env.env.observation_space(learner)


def test_partner_env_with_scripted_human_is_the_robot_env():
    """A scripted human plugged into the parallel env gives the Gymnasium robot env's episode."""
    partner = PartnerEnv(wheel_v0.parallel_env())
    robot_env = gym.make("hri_envs/Wheel-v0")
    for start, goal in [(0, 1), (1, 2), (2, 0)]:
        opts = {"start": start, "intention": goal}
        o1, _ = partner.reset(seed=0, options=opts)
        o2, _ = robot_env.reset(seed=0, options=opts)
        robot, rng = following_robot(partner.env.graph), np.random.default_rng(0)
        for _ in range(30):
            a = robot(o1, rng)
            o1, r1, t1, tr1, i1 = partner.step(a)
            o2, r2, t2, tr2, i2 = robot_env.step(a)
            assert o1["state"] == o2["state"] and r1 == r2 and (t1, tr1) == (t2, tr2)
            assert o1["last_human_action"] == o2["last_human_action"]
            if t1 or tr1:
                assert i1["reached_intention"] == i2["reached_intention"] is True
                break
        else:
            pytest.fail("the episode did not end")


def test_learning_human_with_a_following_robot_can_reach_every_goal():
    env = PartnerEnv(hanger_v0.parallel_env(observation_format="classic",
                                            human_reward="goal"), learner="human")
    human = preference_human(env.env.graph)
    for start, goal in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)]:
        env.reset(seed=0, options={"start": start, "intention": goal})
        ret, done = 0.0, False
        while not done:
            a = preferred(human, env.env.state()[0], start, goal)
            assert env.action_masks()[a]
            _, r, term, trunc, info = env.step(a)
            ret, done = ret + r, term or trunc
        assert term and ret == 1.0 and info["reached_intention"]


def test_partner_policies_and_seeding():
    env = PartnerEnv(hanger_v0.parallel_env(), learner="human", partner=random_valid_policy)
    runs = []
    for _ in range(2):
        env.reset(seed=4, options={"start": 0, "intention": 1})
        states = []
        for _ in range(15):
            o, *_ = env.step(TOGGLE if _ == 0 else WAIT)
            states.append(int(o["state"]))
        runs.append(states)
    assert runs[0] == runs[1]
    assert waiting_policy(None, np.random.default_rng(0)) == WAIT
    env.close()


def test_partner_env_bad_input():
    par = hanger_v0.parallel_env()
    with pytest.raises(ConfigError, match=re.escape(
            "unknown learner 'dog'; allowed: 'human', 'robot'")):
        PartnerEnv(par, learner="dog")
    with pytest.raises(ConfigError, match="a human partner can only play the human"):
        PartnerEnv(par, learner="human", partner=preference_human(par.graph))
    with pytest.raises(ConfigError, match="built for the wheel scenario, not the hanger"):
        PartnerEnv(par, partner=preference_human(wheel_v0.parallel_env().graph))
    with pytest.raises(ConfigError, match="partner must be a human .* or a callable"):
        PartnerEnv(par, partner=3)
    env = PartnerEnv(par)
    with pytest.raises(RuntimeError, match="call reset"):
        env.step(WAIT)


@pytest.mark.parametrize(("turn_back", "expected"), [(1.0, 10), (0.0, 0)])
def test_partner_env_turns_back_as_its_scripted_human_does(turn_back, expected):
    """The env applies the partner's own turning-back rate and turning point."""
    graph = hanger_v0.parallel_env().graph
    env = PartnerEnv(hanger_v0.parallel_env(),
                     partner=preference_human(graph, "over-rotate-down/up-over-rotate",
                                              turn_back=turn_back))
    robot, rng, turned = following_robot(graph), np.random.default_rng(0), 0
    for e in range(20):
        obs, _ = env.reset(seed=e)
        intention, done = env.env.unwrapped.intention, False
        while not done:
            obs, _, term, trunc, _ = env.step(robot(obs, rng))
            done = term or trunc
            turned += env.env.unwrapped.intention != intention
            if env.env.unwrapped.intention != intention:
                break
    assert turned == expected  # B<->C routes have no halfway point: half the episodes
