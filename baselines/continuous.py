"""References and baselines for the continuous-control envs (``*PandaContinuous-v0``).

Each is a :class:`ContinuousPolicy`: told an episode began (with the env, for what it may
know), asked for an action per 25 Hz step from the robot's observation, told the episode
ended.

* :class:`UpperReference` knows the intention: it follows the human's own reference (the
  grip pose the object would have at the human's reference now) with full stiffness. It
  reads the simulation, so it is a reference, not an agent a robot could run.
* :class:`PassiveFloor`: gravity and payload compensated, zero stiffness (the robot only
  carries the weight; the human drags it).
* :class:`LiftedLearner`: the paper's Learner (:class:`agents.learner.Learner`) lifted
  through the motion primitives of the physics backend: it maps the object's observed pose
  to the closest abstract state, infers the human's action from the states it reaches,
  picks an abstract action and executes it as a minimum-jerk straight line of its grip to
  that action's target state, yielding (turning passive) when its wrist senses the human
  disagree (:class:`~hri_envs.physics.controller.Disagreement`). It learns across episodes
  as in the paper (the intention revealed where the object was placed).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from agents.learner import Learner
from agents.protocol import Agent, Trace
from hri_envs.physics.controller import Disagreement
from hri_envs.physics.kinematics import Pose, StraightLine, compose, rotation_error
from hri_envs.physics.observer import StateObserver
from hri_envs.physics.seats import Seats
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import BOTH, TOGGLE
from hri_envs.task.scenarios import episode_scenario

__all__ = ["PASSIVE_ACTION", "ContinuousPolicy", "LiftedLearner", "PassiveFloor",
           "UpperReference", "follow_action"]

#: Zero grip offset, zero stiffness: the passive, gravity-compensated robot.
PASSIVE_ACTION = np.array([0, 0, 0, 0, 0, 0, -1.0], dtype=np.float32)


def follow_action(env: Any, target: Pose, stiffness: float = 1.0) -> np.ndarray:
    """The action that moves the robot's grip towards ``target`` as fast as the action
    allows, with the given stiffness scale (0-1).
    """
    sim = env.sim
    grip = sim.grip_pose()
    return np.concatenate([
        np.clip((target.pos - grip.pos) / sim.max_step_m, -1.0, 1.0),
        np.clip(rotation_error(target.quat, grip.quat) / sim.max_step_rad, -1.0, 1.0),
        [2.0 * stiffness - 1.0]]).astype(np.float32)


class ContinuousPolicy(ABC):
    """A robot policy for the continuous envs."""

    name = "policy"

    def begin(self, env: Any) -> None:
        """An episode began on ``env`` (the unwrapped :class:`~hri_envs.physics.continuous.
        CarryEnv`).
        """

    @abstractmethod
    def act(self, observation: np.ndarray, env: Any) -> np.ndarray:
        """The robot's (7,) action."""

    def end(self, info: dict[str, Any]) -> None:
        """The episode ended with the last step's ``info``."""


class UpperReference(ContinuousPolicy):
    """Knows the intention and follows the human's reference (privileged)."""

    name = "upper"

    def act(self, observation: np.ndarray, env: Any) -> np.ndarray:
        """Towards the grip pose of the human's reference, stiff."""
        return follow_action(env, env.sim.human_grip_reference())


class PassiveFloor(ContinuousPolicy):
    """The passive, gravity-compensated robot."""

    name = "passive"

    def act(self, observation: np.ndarray, env: Any) -> np.ndarray:
        """Zero stiffness."""
        return PASSIVE_ACTION.copy()


class LiftedLearner(ContinuousPolicy):
    """The paper's Learner on the continuous env, through the motion primitives.

    Args:
        env: The unwrapped env (its task graph, design and action scale: what the robot
            knows of the task; never the intention or the human's reference).
        seed: The Learner's seed.
    """

    name = "learner"

    def __init__(self, env: Any, seed: int = 0) -> None:
        self.graph = env.graph
        self.design = env.sim.design
        self.agent: Agent = Learner(self.graph, 1, seed=seed).single()
        self.grip_in_object = Pose(self.design.grip_pos, self.design.grip_quat)
        self.davi = Disagreement(self.design)
        self._reset_episode(env)

    def _reset_episode(self, env: Any) -> None:
        scenario = episode_scenario(env.scenario_name, env.layout)
        self.observer = StateObserver(self.graph, scenario, self.design.lever)
        self.seats = Seats(scenario, self.design)
        self.start = int(env.start)
        self.state = self.graph.support_state(self.start, BOTH)
        self.states = [self.state]
        self.robot_actions: list[int] = []
        self.human_actions: list[int] = []
        self.action = WAIT
        self.last_human = WAIT
        self.line: StraightLine | None = None
        self.t = 0.0
        self.passive = True

    def begin(self, env: Any) -> None:
        """A new episode: the start support is known to the robot."""
        self._reset_episode(env)
        self.agent.begin_episode(self.start)
        self._decide(env)

    def _observe_state(self, observation: np.ndarray) -> int:
        pos, quat = observation[:3].astype(float), observation[3:7].astype(float)
        quat = quat / np.linalg.norm(quat)
        seat = self.seats.engaged(pos, quat)
        return self.observer.observe(pos, quat, seat, BOTH).state

    def _decide(self, env: Any) -> None:
        g, s = self.graph, self.state
        mask = g.valid[s].astype(np.int8)
        a = int(self.agent.act({"state": s, "start": self.start,
                                "last_human_action": self.last_human, "action_mask": mask}))
        self.action = a
        self.davi.reset()
        self.t = 0.0
        if a == WAIT or a == TOGGLE or not g.valid[s, a]:
            self.line, self.passive = None, True
            return
        target = int(g.next_state[s, a, WAIT])
        pos, quat = self.observer.pose(target)
        goal = compose(Pose(pos, quat), *self.grip_in_object)
        d = self.design
        self.line = StraightLine(env.sim.grip_pose(), goal, d.linear_speed, d.angular_speed,
                                 d.motion_min_duration_s)
        self.passive = False

    def _transition(self, s_next: int) -> None:
        g, s = self.graph, self.state
        human = WAIT
        for a in np.flatnonzero(g.valid[s]):
            if int(g.next_state[s, WAIT, a]) == s_next and a > TOGGLE:
                human = int(a)
                break
        if human != WAIT and human == self.action:
            human = self.action  # the same action as the robot's (they agreed)
        elif s_next == int(g.next_state[s, self.action, WAIT]) and self.action > TOGGLE:
            human = WAIT  # the robot led there, the human followed
        self.agent.observe(s, self.action, human, s_next)
        self.robot_actions.append(self.action)
        self.human_actions.append(human)
        self.states.append(s_next)
        self.last_human, self.state = human, s_next

    def act(self, observation: np.ndarray, env: Any) -> np.ndarray:
        """Follow the current primitive; re-decide when the state changes or it ends."""
        s_next = self._observe_state(observation)
        dt = env.sim.dt_step
        self.t += dt
        finished = self.line is None and self.t >= 0.4 or (
            self.line is not None and self.t >= self.line.duration + 0.4)
        if s_next != self.state or finished:
            self._transition(s_next)
            self._decide(env)
        if self.passive or self.line is None:
            return PASSIVE_ACTION.copy()
        sensed = observation[-(6 + 4 * self.graph.n_intentions + 1):][:6].astype(float)
        moving = self.t < self.line.duration
        zero = np.zeros(3)
        scale = self.davi.update(self.davi.force(
            sensed[:3], sensed[3:], self.line.direction if moving else zero,
            self.line.axis if moving else zero), dt)
        if self.davi.yielded:
            self.passive = True
            return PASSIVE_ACTION.copy()
        ref = self.line.sample(self.t)
        return follow_action(env, Pose(ref.pos, ref.quat), stiffness=scale)

    def end(self, info: dict[str, Any]) -> None:
        """Learn from the episode: the intention is revealed where the object was placed."""
        if len(self.robot_actions) == 0:
            self.robot_actions, self.human_actions = [WAIT], [WAIT]
            self.states.append(self.state)
        trace = Trace(np.array(self.states), np.array(self.robot_actions),
                      np.array(self.human_actions))
        placed = int(info.get("placed", -1))
        self.agent.end_episode(trace, placed if placed != self.start else -1)


def run_episode(env: Any, policy: ContinuousPolicy, seed: int | None = None,
                options: dict[str, Any] | None = None) -> dict[str, Any]:
    """One episode of ``policy`` on ``env`` (a ``gym.make``-d env or the unwrapped one);
    the episode's return, effort, steps, outcome and the last ``info``.
    """
    base = getattr(env, "unwrapped", env)
    obs, _ = env.reset(seed=seed, options=options)
    policy.begin(base)
    total, info = 0.0, {}
    while True:
        obs, reward, term, trunc, info = env.step(policy.act(obs, base))
        total += float(reward)
        if term or trunc:
            break
    policy.end(info)
    return {"return": total, "effort": float(info.get("episode_effort", 0.0)),
            "steps": int(base.steps), "time_s": base.steps * base.sim.dt_step,
            "placed": int(info.get("placed", -1)),
            "reached_intention": bool(info.get("reached_intention", False)),
            "fault": info.get("fault"), "info": info}
