"""Run any protocol agent (:class:`agents.protocol.Agent`) in a Gymnasium robot env.

The benchmark simulates many runs at once on the task graph; this is the plain loop for one
env object, e.g. ``gymnasium.make("hri_envs/Hanger-v0")``::

    env = gymnasium.make("hri_envs/Hanger-v0", preference="down-over-rotate/over-rotate-up")
    robot = Learner(env.unwrapped.graph).single()
    for episode in range(8):
        result = run_episode(env, robot, seed=episode)
        print(episode, result.reward)
"""

from __future__ import annotations

from typing import Any, NamedTuple

import gymnasium as gym
import numpy as np

from agents.protocol import Agent, Trace
from hri_envs.envs.spaces import check_action

__all__ = ["EpisodeResult", "run_episode"]


class EpisodeResult(NamedTuple):
    """What one episode gave.

    Attributes:
        trace: The states and both agents' actions.
        reward: Summed robot cooperation reward.
        intention: Where the episode ended (the intention revealed in hindsight); -1 for a
            truncated episode, which reveals nothing.
        truncated: The episode hit the step limit.
    """

    trace: Trace
    reward: float
    intention: int
    truncated: bool


def run_episode(
    env: gym.Env[Any, Any],
    agent: Agent,
    *,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    learn: bool = True,
) -> EpisodeResult:
    """Play one episode of ``agent`` (the robot) against the env's scripted human.

    The agent sees only the robot's observation; the human's action reaches it through the
    next observation's ``last_human_action``, as on a real robot that infers it.

    Args:
        env: A robot env (``hri_envs/Hanger-v0``, ``hri_envs/Wheel-v0`` or the Panda ones).
        agent: The robot's policy.
        seed: Passed to ``env.reset``.
        options: Passed to ``env.reset`` (``start``, ``intention``, ``turn_back``, ...).
        learn: Call ``agent.end_episode`` with the trace and the revealed intention.

    Raises:
        ActionError: The agent's ``act`` returned something other than an integer in
            [0, A) (a float or ``bool`` is refused, not rounded).
    """
    base = env.unwrapped
    graph = base.graph  # type: ignore[attr-defined]
    obs, _ = env.reset(seed=seed, options=options)
    agent.begin_episode(int(obs["start"]))
    states, robot_actions, human_actions = [int(obs["state"])], [], []
    total, terminated, truncated = 0.0, False, False
    while not (terminated or truncated):
        state = int(obs["state"])
        action = check_action("robot", agent.act(obs), graph.n_actions)
        obs, reward, terminated, truncated, _ = env.step(action)
        human = int(obs["last_human_action"])
        agent.observe(state, action, human, int(obs["state"]))
        states.append(int(obs["state"]))
        robot_actions.append(action)
        human_actions.append(human)
        total += float(reward)
    support = int(graph.support[states[-1]])
    intention = support if terminated else -1
    trace = Trace(np.array(states), np.array(robot_actions, dtype=np.int64),
                  np.array(human_actions, dtype=np.int64))
    if learn:
        agent.end_episode(trace, intention)
    return EpisodeResult(trace, total, intention, bool(truncated))
