"""One episode, three implementations: the batched vector env, the PettingZoo parallel env
and the benchmark's ``simulate`` give the same states, actions, rewards and episode ends.

Property test (hypothesis): scenario, preference, r0, step limit, the episodes' start,
intention and turning back, and a deterministic robot policy (a table over state and step
index, read through the observation's action mask) are drawn; the scripted human follows
the preference and is never passive, so nothing is random.
"""

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import hri_envs  # noqa: F401  (registers the ids)
from agents.protocol import BatchAgent
from hri_bench.run.runner import Schedule, simulate
from hri_envs import hanger_v0, wheel_v0
from hri_envs.envs.config import scenario_graph
from hri_envs.humans.scripted import preference_human, preferences_for
from hri_envs.task.graph import HUMAN_BIT, ROBOT_BIT, TOGGLE, WAIT

ENV_IDS = {"hanger": "hri_envs/Hanger-v0", "wheel": "hri_envs/Wheel-v0"}
PARALLEL = {"hanger": hanger_v0, "wheel": wheel_v0}
N_CODES = 16  # policy table entries: 0-5 cooperate, 6-14 a valid action, 15 an invalid one


def robot_action(graph, table, state, t, mask):
    """The scripted robot: depends on (state, step index) only, via the action mask.

    "Cooperate" grasps when the human holds the object alone on a support, lets go when
    the robot holds it alone, and waits otherwise: the human carries (as with the paper's
    passive baseline), so an all-zero table ends its episodes.
    """
    code = int(table[t % len(table), int(state)])
    mask = np.asarray(mask).astype(bool)
    if code < 6:
        alone = graph.support[state] >= 0 and graph.grasp[state] in (HUMAN_BIT, ROBOT_BIT)
        return TOGGLE if alone and mask[TOGGLE] else WAIT
    if code == N_CODES - 1:  # an invalid action (aborts the step) where there is one
        invalid = np.flatnonzero(~mask)
        return int(invalid[0]) if invalid.size else WAIT
    valid = np.flatnonzero(mask)
    return int(valid[code % valid.size])


def new_record():
    return {"states": [], "start": [], "masks": [], "last_human": [], "intention": [],
            "robot": [], "human": [], "rewards": []}


class TableRobot(BatchAgent):
    """The scripted robot for ``simulate``; records what it is shown, per run.

    ``privileged`` makes ``simulate`` put the current intention in the observations.
    """

    name = "table-robot"
    privileged = True

    def __init__(self, graph, table, n_runs):
        super().__init__(n_runs)
        self.graph, self.table = graph, table
        self.records = [new_record() for _ in range(n_runs)]
        self.t = 0

    def begin_episode(self, starts):
        self.t = 0

    def act(self, observations, active):
        out = np.full(self.n_runs, WAIT)
        for i in np.flatnonzero(active):
            rec = self.records[i]
            rec["states"].append(int(observations["state"][i]))
            rec["start"].append(int(observations["start"][i]))
            rec["masks"].append(np.asarray(observations["action_mask"][i]).tolist())
            rec["last_human"].append(int(observations["last_human_action"][i]))
            rec["intention"].append(int(observations["intention"][i]))
            out[i] = robot_action(self.graph, self.table, observations["state"][i], self.t,
                                  observations["action_mask"][i])
        self.t += 1
        return out

    def observe(self, states, robot_actions, human_actions, next_states, active):
        for i in np.flatnonzero(active):
            rec = self.records[i]
            rec["robot"].append(int(robot_actions[i]))
            rec["human"].append(int(human_actions[i]))
            rec["next"] = int(next_states[i])

    def end_episode(self, traces, intentions):
        for rec, trace in zip(self.records, traces, strict=True):
            rec["trace"] = trace


def run_simulate(graph, human, episodes, table, r0, max_cycles):
    n = len(episodes)
    start, goal, turn = (np.array([[e[j]] for e in episodes]) for j in range(3))
    agent = TableRobot(graph, table, n)
    metrics = simulate(graph, agent, human, Schedule(start, goal, turn.astype(bool)),
                       runs=np.arange(n), seed=0, r0=r0, max_steps=max_cycles)
    reward_table = graph.reward(r0)
    records = []
    for i, rec in enumerate(agent.records):
        length = int(metrics.steps[i, 0])
        assert len(rec["robot"]) == len(rec["states"]) == length
        # The trace handed to the agent is the episode it was shown.
        assert rec["trace"].states.tolist() == rec["states"] + [rec["next"]]
        assert rec["trace"].robot_actions.tolist() == rec["robot"]
        assert rec["trace"].human_actions.tolist() == rec["human"]
        rec["states"].append(rec.pop("next"))
        del rec["trace"]
        # R_R of every step, and the reward simulate summed up for the episode.
        rec["rewards"] = [float(reward_table[s, a, h]) for s, a, h in
                          zip(rec["states"], rec["robot"], rec["human"], strict=False)]
        assert metrics.reward[i, 0] == pytest.approx(sum(rec["rewards"]), abs=1e-9)
        rec["end"] = ("truncated" if metrics.truncated[i, 0] else "terminated", length)
        records.append(rec)
    return records


def run_vector(scenario, preference, episodes, table, r0, max_cycles, seed):
    graph, n = scenario_graph(scenario), len(episodes)
    env = gym.make_vec(ENV_IDS[scenario], num_envs=n, vectorization_mode="vector_entry_point",
                       preference=preference, r0=r0, max_cycles=max_cycles)
    start, intention, turn = (np.array([e[j] for e in episodes]) for j in range(3))
    obs, _ = env.reset(seed=seed, options={"start": start, "intention": intention,
                                           "turn_back": turn.astype(bool)})
    records = [new_record() for _ in range(n)]
    ended_before = np.zeros(n, dtype=bool)
    just_ended = np.zeros(n, dtype=bool)
    t = 0
    while True:
        actions = np.full(n, WAIT)
        for i in np.flatnonzero(~ended_before):
            rec = records[i]
            rec["states"].append(int(obs["state"][i]))
            rec["start"].append(int(obs["start"][i]))
            rec["masks"].append(obs["action_mask"][i].tolist())
            rec["last_human"].append(int(obs["last_human_action"][i]))
            rec["intention"].append(int(env.unwrapped.intention[i]))
            actions[i] = robot_action(graph, table, obs["state"][i], t, obs["action_mask"][i])
            rec["robot"].append(int(actions[i]))
        obs, reward, term, trunc, _ = env.step(actions)
        # Next-step autoreset: an env whose episode ended in the previous step restarts now,
        # with reward 0 and no end flags, on its new start support.
        assert np.all(reward[just_ended] == 0.0)
        assert not term[just_ended].any() and not trunc[just_ended].any()
        assert np.all(obs["state"][just_ended] == 4 * obs["start"][just_ended])
        if ended_before.all():
            break
        just_ended = np.zeros(n, dtype=bool)
        for i in np.flatnonzero(~ended_before):
            rec = records[i]
            rec["human"].append(int(obs["last_human_action"][i]))
            rec["rewards"].append(float(reward[i]))
            if term[i] or trunc[i]:
                assert not (term[i] and trunc[i])
                rec["states"].append(int(obs["state"][i]))
                rec["end"] = ("terminated" if term[i] else "truncated", t + 1)
                just_ended[i] = True
        ended_before |= just_ended
        t += 1
        assert t <= max_cycles
    env.close()
    return records


def run_parallel(scenario, human, episode, table, r0, max_cycles):
    graph = scenario_graph(scenario)
    env = PARALLEL[scenario].parallel_env(r0=r0, max_cycles=max_cycles)
    start, intention, turn = episode
    obs, _ = env.reset(seed=0, options={"start": start, "intention": intention,
                                        "turn_back": bool(turn)})
    rec = new_record()
    for t in range(max_cycles + 1):
        assert t < max_cycles, "the episode did not end at the step limit"
        o_r, o_h = obs["robot"], obs["human"]
        assert o_h["state"] == o_r["state"] and o_h["intention"] == env.intention
        rec["states"].append(int(o_r["state"]))
        rec["start"].append(int(o_r["start"]))
        rec["masks"].append(np.asarray(o_r["action_mask"]).tolist())
        rec["last_human"].append(int(o_r["last_human_action"]))
        rec["intention"].append(int(o_h["intention"]))
        a_h = int(human.preferred_action(np.array(o_h["state"]), np.array(o_h["start"]),
                                         np.array(o_h["intention"])))
        a_r = robot_action(graph, table, o_r["state"], t, o_r["action_mask"])
        rec["robot"].append(a_r)
        rec["human"].append(a_h)
        obs, rewards, term, trunc, _ = env.step({"human": a_h, "robot": a_r})
        assert rewards["human"] == rewards["robot"]
        assert term["human"] == term["robot"] and trunc["human"] == trunc["robot"]
        rec["rewards"].append(float(rewards["robot"]))
        if term["robot"] or trunc["robot"]:
            assert not env.agents
            rec["states"].append(int(obs["robot"]["state"]))
            rec["end"] = ("terminated" if term["robot"] else "truncated", t + 1)
            break
    return rec


@st.composite
def scenarios(draw):
    """A scenario, its scripted human's preference, r0, step limit, episodes and a policy."""
    scenario = draw(st.sampled_from(sorted(ENV_IDS)))
    graph = scenario_graph(scenario)
    n_k = graph.n_intentions
    preference = draw(st.sampled_from(preferences_for(scenario)))
    episode = st.tuples(st.integers(0, n_k - 1), st.integers(1, n_k - 1), st.booleans()).map(
        lambda e: (e[0], (e[0] + e[1]) % n_k, e[2]))
    episodes = draw(st.lists(episode, min_size=1, max_size=3))
    period = draw(st.integers(1, 3))
    table = draw(hnp.arrays(np.int64, (period, graph.n_states),
                            elements=st.integers(0, N_CODES - 1), fill=st.nothing()))
    r0 = draw(st.sampled_from([-0.33, -0.25, -0.5, -0.9]))
    max_cycles = draw(st.integers(1, 40))
    return scenario, preference, episodes, table, r0, max_cycles


def check_consistency(scenario, preference, episodes, table, r0, max_cycles, seed=0):
    """Asserts the three implementations agree; returns the vector env's records."""
    graph = scenario_graph(scenario)
    human = preference_human(graph, preference)
    sim = run_simulate(graph, human, episodes, table, r0, max_cycles)
    vec = run_vector(scenario, preference, episodes, table, r0, max_cycles, seed)
    # The parallel env's turning-back point is that of the default preference (its human is
    # an outside agent with no preference; see CooperationParallelEnv's docstring).
    default_turn = preference_human(graph).turn_state
    for j, episode in enumerate(episodes):
        start, intention, turn = episode
        assert vec[j] == sim[j], (j, episode)
        if not turn or default_turn[start, intention] == human.turn_state[start, intention]:
            assert run_parallel(scenario, human, episode, table, r0, max_cycles) == vec[j], (
                j, episode)
        rec = vec[j]
        length = rec["end"][1]
        assert len(rec["states"]) == length + 1 and len(rec["rewards"]) == length
        assert rec["states"][0] == graph.support_state(start, 0)
    return vec


COOPERATIVE = np.zeros((1, 36), dtype=np.int64)  # the robot only grasps and lets go


@settings(max_examples=25, deadline=None)
@given(scenarios(), st.integers(0, 2**32 - 1))
# Paper Table 2, episode 8: A -> (B) A, the human carrying; next to an ordinary episode.
@example(("hanger", "down-over-rotate/over-rotate-up", [(0, 1, True), (1, 0, False)],
          COOPERATIVE, -0.33, 40), 0)
def test_vector_parallel_and_simulate_agree(case, seed):
    check_consistency(*case, seed=seed)


def test_the_comparison_covers_turning_back_and_both_episode_ends():
    """Guards the property test against comparing nothing interesting."""
    hanger = "down-over-rotate/over-rotate-up"
    vec = check_consistency("hanger", hanger, [(0, 1, True), (1, 0, False)],
                            COOPERATIVE, -0.33, 40)
    back, straight = vec
    assert back["intention"][0] == 1 and back["intention"][-1] == 0  # turned back
    assert back["end"][0] == straight["end"][0] == "terminated"
    assert back["states"][-1] == 0 and straight["states"][-1] == 0  # resting on A
    assert min(back["rewards"]) < 0  # the waiting robot paid r0
    busy = np.full((2, 36), 11, dtype=np.int64)  # always the same kind of valid motion
    vec = check_consistency("wheel", "detour", [(2, 0, False)], busy, -0.25, 6)
    assert vec[0]["end"] == ("truncated", 6)
