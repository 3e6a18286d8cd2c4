"""The house's promises: a human who keeps state plays in every seat without touching the
envs' code, and a scenario defined only in the tests runs through the envs, the Learner and
a study."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

from agents.learner import Learner
from agents.rollout import run_episode
from hri_bench.run.study import StudyConfig, run_study, write_outputs
from hri_envs import hanger_v0
from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.envs.partner import PartnerEnv
from hri_envs.envs.robot import RobotEnv
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.errors import ActionError, ConfigError
from hri_envs.humans import BatchedHumans, PopulationHumans
from hri_envs.task.actions import WAIT
from hri_envs.task.scenarios import SCENARIOS, scenario_graph
from tests import scenario_box
from tests.helpers_humans import Copycat

COPYCAT = "tests.helpers_humans:Copycat"


# --------------------------------------------------------------------- a human with state
def test_a_human_with_state_plays_the_pettingzoo_env_through_partner_env():
    env = PartnerEnv(hanger_v0.parallel_env(), partner=Copycat(scenario_graph("hanger")))
    human: Copycat = env.partner.humans[0]  # type: ignore[union-attr]
    rng = np.random.default_rng(0)
    checked = 0
    for episode in range(20):
        obs, _ = env.reset(seed=episode)
        last_robot, done = WAIT, False
        while not done:
            state, start, intention = (int(v) for v in env.env.state()[:3])
            want = human.expected(last_robot, state, start, intention)
            a_r = int(rng.choice(np.flatnonzero(obs["action_mask"])))
            obs, _, term, trunc, _ = env.step(a_r)
            assert int(env.env.state()[3]) == want
            checked += 1
            last_robot, done = a_r, term or trunc
    assert human.copied > 20 and checked > 100


def test_a_human_with_state_plays_in_the_robot_env():
    human = Copycat(scenario_graph("hanger"))
    env = RobotEnv("hanger", human=human)
    robot = Learner(env.graph).single()
    rewards = [run_episode(env, robot, seed=e).reward for e in range(6)]
    assert human.copied > 0 and len(rewards) == 6


def test_a_human_with_state_plays_in_the_vector_env():
    n = 8
    graph = scenario_graph("wheel")
    humans = [Copycat(graph) for _ in range(n)]
    vec = RobotVectorEnv(n, "wheel", human=BatchedHumans(graph, humans))
    obs, _ = vec.reset(seed=3)
    rng = np.random.default_rng(1)
    last_robot = np.full(n, WAIT)
    restarting = np.zeros(n, dtype=bool)
    checked = 0
    for _ in range(300):
        state, start, intention = obs["state"], obs["start"], vec.intention
        want = [humans[i].expected(int(last_robot[i]), int(state[i]), int(start[i]),
                                   int(intention[i])) for i in range(n)]
        a_r = np.array([rng.choice(np.flatnonzero(m)) for m in obs["action_mask"]])
        obs, _, term, trunc, _ = vec.step(a_r)
        for i in np.flatnonzero(~restarting):  # (a restarting env ignores this step)
            assert obs["last_human_action"][i] == want[i]
            checked += 1
        restarting = term | trunc
        last_robot = np.where(restarting, WAIT, a_r)
    assert checked > 1500 and sum(h.copied for h in humans) > 100


def test_a_human_of_ones_own_runs_in_a_study_whatever_the_jobs(tmp_path):
    cfg = dict(agents=("learner", "imitator"), runs=6, episodes=4, population=COPYCAT)
    serial = run_study(StudyConfig("hanger", **cfg))
    pooled = run_study(StudyConfig("hanger", **cfg, jobs=2, executor="process"))
    default = run_study(StudyConfig("hanger", agents=("learner", "imitator"), runs=6,
                                    episodes=4))
    for agent in ("learner", "imitator"):
        a, b = serial.metrics[agent]["reward"], pooled.metrics[agent]["reward"]
        assert a.tobytes() == b.tobytes()
        assert not np.array_equal(a, default.metrics[agent]["reward"])  # it is another human
    assert set(serial.humans) == {COPYCAT}
    write_outputs(serial, tmp_path, plots=False)
    assert COPYCAT in (tmp_path / "episodes.csv").read_text()


@pytest.mark.parametrize(("change", "field"), [
    ({"agents": ("oracle",)}, "agents"),
    ({"human_drift": 2}, "human_drift"),
    ({"population": "tests.helpers_humans:preference_human"}, "population"),
    ({"population": "tests.no_such_module:Human"}, "population"),
])
def test_a_human_of_ones_own_is_refused_before_simulating_where_it_cannot_serve(change, field):
    settings = {"agents": ("learner",), "runs": 2, "population": COPYCAT} | change
    with pytest.raises(ConfigError) as err:
        StudyConfig("hanger", **settings)
    assert err.value.field == field


# --------------------------------------------------------------------- a third scenario
@pytest.fixture(scope="module")
def box():
    scenario_box.register()
    yield scenario_graph("box")
    SCENARIOS.unregister("box")  # the other tests see the suite's two scenarios only


def test_a_scenario_of_the_tests_runs_in_the_pettingzoo_and_gymnasium_envs(box):
    parallel_api_test(CooperationParallelEnv("box"), num_cycles=200)
    env = gym.make("hri_envs/Box-v0")
    check_env(env.unwrapped, skip_render_check=True)
    vec = RobotVectorEnv(16, "box")
    obs, _ = vec.reset(seed=0)
    for _ in range(50):
        obs, *_ = vec.step(np.array([np.flatnonzero(m)[0] for m in obs["action_mask"]]))
    assert box.n_states == 36 and box.n_actions == 12 and box.n_intentions == 3


def test_the_learner_learns_a_scenario_of_the_tests(box):
    """The paper's qualitative result on the new scenario: the Learner gets close to blind,
    far above the Imitator and the Passive robot, within its episodes."""
    result = run_study(StudyConfig("box", agents=("learner", "imitator", "passive", "blind"),
                                   runs=30, seed=1))
    last = {a: m["reward"][:, -2:].mean() for a, m in result.metrics.items()}
    first = result.metrics["learner"]["reward"][:, 0].mean()
    assert last["learner"] > first + 0.3
    assert last["learner"] > max(last["imitator"], last["passive"])
    assert last["learner"] > last["blind"] - 0.25


def test_a_scenario_of_the_tests_has_no_physics(box):
    with pytest.raises(ConfigError, match="no physical design"):
        RobotEnv("box", backend="mujoco")


# --------------------------------------------------------------------- populations in seats
def test_a_population_draws_a_human_per_reset_in_the_vector_env_and_partner_env():
    graph = scenario_graph("hanger")
    vec = RobotVectorEnv(16, "hanger", population="heldout")
    vec.reset(seed=5)
    first = list(vec.human.current)
    assert len({h.name for h in first}) > 8  # each env its own human
    obs, *_ = vec.step(np.zeros(16, np.int64))
    for _ in range(200):  # autoresets draw new humans for the envs that restart
        obs, _, term, trunc, _ = vec.step(np.array([np.flatnonzero(m)[-1]
                                                    for m in obs["action_mask"]]))
    assert [h.name for h in vec.human.current] != [h.name for h in first]
    again = RobotVectorEnv(16, "hanger", population="heldout")
    again.reset(seed=5)
    assert [h.name for h in again.human.current] == [h.name for h in first]

    env = PartnerEnv(hanger_v0.parallel_env(), partner=PopulationHumans(graph, "heldout"))
    names = []
    for seed in (0, 1, 2, 0):
        env.reset(seed=seed)
        names.append(env.partner.name)  # type: ignore[union-attr]
    assert len(set(names[:3])) == 3 and names[3] == names[0]


# --------------------------------------------------------------------- changes of mind
def test_batched_humans_report_only_the_humans_that_can_change_their_minds():
    """BatchedHumans asks no human whose revised_intention is the default, and still hears
    (and checks) one whose class or instance overrides it."""
    graph = scenario_graph("hanger")
    plain = BatchedHumans(graph, [Copycat(graph) for _ in range(3)])
    assert plain.revised_intentions() is None

    class Turner(Copycat):
        def revised_intention(self):
            return 2

    mixed = BatchedHumans(graph, [Copycat(graph), Turner(graph)])
    assert mixed.revised_intentions().tolist() == [-1, 2]
    odd = Copycat(graph)
    odd.revised_intention = lambda: graph.n_intentions  # type: ignore[method-assign]
    with pytest.raises(ActionError, match="revised_intention"):
        BatchedHumans(graph, [Copycat(graph), odd]).revised_intentions()
