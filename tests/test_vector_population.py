"""The numpy vector env's population seat: each env's drawn human acts, not a placeholder.

Regression: the env adopted the one-table fast path of the seat's placeholder human when it
was built, and kept it after the population's first draw, so every env played the default
preference (deterministic, never passive, never turning back) whatever the population. A
population's seat now holds per-row tables from the start; the tests below fail whenever the
env acts by one table for a population.
"""

import numpy as np

from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.humans.scripted import preference_human
from hri_envs.task.actions import WAIT


def test_population_members_act_in_the_vector_env():
    env = RobotVectorEnv(64, "hanger", population="mixed-rationality")
    assert env.human.shared is None  # no one shared table, not even before the first draw
    default = preference_human(env.graph)
    obs, _ = env.reset(seed=0)
    off_default = 0
    rng = np.random.default_rng(0)
    for _ in range(100):
        state, start, goal = obs["state"], obs["start"], env.intention
        pick = np.argmax(rng.random(obs["action_mask"].shape) * obs["action_mask"], axis=1)
        obs, _, term, trunc, _ = env.step(pick)
        done = term | trunc
        seen = obs["last_human_action"][~done]
        want = default.preferred_action(state, start, goal)[~done]
        off_default += int((seen != want).sum())
    assert off_default > 0  # Boltzmann members (β in [1, 20]) stray from the preference


def test_population_turning_back_and_passivity_reach_the_vector_env():
    env = RobotVectorEnv(256, "wheel", population="passive-turnback")
    default = preference_human(env.graph)
    obs, _ = env.reset(seed=1)
    assert env.human.shared is None
    assert (env.human.turn_back > 0).any()
    assert (env._turn_at != -1).any()
    waited = 0  # passive members wait where the default preference moves
    for _ in range(20):
        state, start, goal = obs["state"], obs["start"], env.intention
        obs, _, term, trunc, _ = env.step(np.zeros(env.num_envs, dtype=np.int64))
        moves = default.preferred_action(state, start, goal) != WAIT
        waited += int((moves & (obs["last_human_action"] == WAIT) & ~(term | trunc)).sum())
    assert waited > 0
