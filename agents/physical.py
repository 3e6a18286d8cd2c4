"""The protocol of robot agents for the continuous physical envs (``*PandaContinuous-v1``).

A robot that carries the object with a simulated human acts at 25 Hz from what it senses.
It plugs into the envs and the physical suite (``hri-bench suite --physical``) through four
calls, the continuous counterpart of :mod:`agents.protocol`:

1. ``begin_episode(task)``: an episode starts; ``task`` is the episode's public facts
   (:class:`~hri_envs.physics.carry.robot_view.RobotTask`: the supports, the start, the task
   graph, the action's scale, the controller's design, the observation's layout);
2. ``act(observation)``: the robot's action (``Box(-1, 1, (7,))``: grip target offset,
   rotation, stiffness) for the robot's observation (the object's pose and velocity, its
   own grip and joints, the wrist sensor's wrench, the start, the supports, the time);
3. ``end_episode(outcome)``: the episode ended (:class:`~hri_envs.physics.carry.robot_view.
   EpisodeOutcome`): where the object came to rest, which reveals the human's goal in
   hindsight, and the episode's figures. Learn here across episodes;
4. optionally ``belief()``: (K,) probabilities over the supports as the human's goal, for
   displays and recordings (None: no belief).

Never the intention, the human or their route during an episode. An agent that needs them
is a *reference*: it sets ``privileged = True``, is handed the env itself
(:meth:`PhysicalAgent.attach`) and is shown as a reference wherever results are shown,
never ranked among robots.

A minimal agent that follows the human's push (a fixed admittance)::

    class Follow(PhysicalAgent):
        name = "follow"

        def begin_episode(self, task):
            self.task = task

        def act(self, observation):
            force = self.task.part(observation, "wrench")[:3]
            step = np.clip(force / 15.0, -1, 1)  # 15 N: a full step (2 cm per 40 ms)
            return np.array([*step, 0, 0, 0, 1.0], dtype=np.float32)

Run one episode with :func:`run_physical_episode`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar, NamedTuple

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.physics.carry.robot_view import EpisodeOutcome, RobotTask

__all__ = ["PhysicalAgent", "PhysicalEpisode", "outcome_of", "run_physical_episode"]


class PhysicalAgent(ABC):
    """A robot agent of the continuous physical envs (see the module docstring)."""

    name: ClassVar[str] = "physical-agent"
    #: A reference that reads the simulation (the human, their route, ι): handed the env by
    #: :meth:`attach` and never ranked among robots.
    privileged: ClassVar[bool] = False

    def attach(self, env: Any) -> None:
        """A privileged agent (a reference) is handed the unwrapped env before each episode.

        Raises:
            ConfigError: The agent is not privileged (robots never get the env).
        """
        raise ConfigError(f"agent {self.name!r} is not privileged: robots never get the env",
                          field="agent")

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode with the public facts ``task``."""

    @abstractmethod
    def act(self, observation: np.ndarray) -> np.ndarray:
        """The robot's (7,) action in [-1, 1] for the robot's observation."""

    def end_episode(self, outcome: EpisodeOutcome) -> None:
        """The episode ended with ``outcome`` (the goal revealed in hindsight)."""

    def belief(self) -> np.ndarray | None:
        """Optional: (K,) probabilities over the supports as the human's goal, or None."""
        return None


def outcome_of(task: RobotTask, info: dict[str, Any], truncated: bool) -> EpisodeOutcome:
    """What an episode that ended with the last step's ``info`` reveals to the robot."""
    placed = int(info.get("placed", -1))
    intention = placed if placed >= 0 and placed != task.start else -1
    return EpisodeOutcome(placed, intention, info.get("fault"), bool(truncated),
                          dict(info.get("episode", {})))


class PhysicalEpisode(NamedTuple):
    """One episode of :func:`run_physical_episode`.

    Attributes:
        outcome: What the episode revealed (and its figures, ``outcome.metrics``).
        reward: The episode's return.
        steps: Its steps.
        info: The last step's ``info``.
    """

    outcome: EpisodeOutcome
    reward: float
    steps: int
    info: dict[str, Any]


def run_physical_episode(env: Any, agent: PhysicalAgent, seed: int | None = None,
                         options: dict[str, Any] | None = None) -> PhysicalEpisode:
    """One episode of ``agent`` on ``env`` (``gymnasium.make``-d or unwrapped).

    The agent gets the episode's :class:`RobotTask` and the robot's observations only,
    unless it is privileged (a reference), which is also handed the unwrapped env.
    """
    base = getattr(env, "unwrapped", env)
    obs, _ = env.reset(seed=seed, options=options)
    if agent.privileged:
        agent.attach(base)
    task = base.robot_task()
    agent.begin_episode(task)
    total, steps = 0.0, 0
    while True:
        obs, reward, term, trunc, info = env.step(agent.act(obs))
        total += float(reward)
        steps += 1
        if term or trunc:
            break
    outcome = outcome_of(task, info, trunc and not term)
    agent.end_episode(outcome)
    return PhysicalEpisode(outcome, total, steps, info)
