"""References and baselines for the continuous-control envs (``*PandaContinuous-v0/v1``).

Each is a :class:`~agents.physical.PhysicalAgent`: told an episode began (with its public
facts, :class:`~hri_envs.physics.robot_view.RobotTask`), asked for an action per 25 Hz step
from the robot's observation, told the episode ended (the goal revealed in hindsight).

* :class:`UpperReference` knows the intention: it follows the human's own reference (the
  grip pose the object would have at the human's reference now) with full stiffness. It
  reads the simulation (``privileged``), so it is a reference, not an agent a robot could
  run.
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

from typing import Any

import numpy as np

from agents.learner import Learner
from agents.physical import PhysicalAgent, run_physical_episode
from agents.protocol import Agent, Trace
from hri_envs.physics.controller import Disagreement
from hri_envs.physics.kinematics import Pose, StraightLine, compose, rotation_error
from hri_envs.physics.observer import StateObserver
from hri_envs.physics.robot_view import EpisodeOutcome, RobotTask
from hri_envs.physics.seats import Seats
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import BOTH, TOGGLE
from hri_envs.task.scenarios import scenario_graph

__all__ = ["PASSIVE_ACTION", "LiftedLearner", "PassiveFloor", "UpperReference",
           "follow_action", "grip_of", "run_episode"]

#: Zero grip offset, zero stiffness: the passive, gravity-compensated robot.
PASSIVE_ACTION = np.array([0, 0, 0, 0, 0, 0, -1.0], dtype=np.float32)


def grip_of(task: RobotTask, observation: np.ndarray) -> Pose:
    """The robot's grip pose in an observation."""
    pos = task.part(observation, "grip_pos").astype(float)
    quat = task.part(observation, "grip_quat").astype(float)
    return Pose(pos, quat / np.linalg.norm(quat))


def follow_action(task: RobotTask, grip: Pose, target: Pose, stiffness: float = 1.0
                  ) -> np.ndarray:
    """The action that moves the robot's grip from ``grip`` towards ``target`` as fast as
    the action allows, with the given stiffness scale (0-1).
    """
    return np.concatenate([
        np.clip((target.pos - grip.pos) / task.max_step_m, -1.0, 1.0),
        np.clip(rotation_error(target.quat, grip.quat) / task.max_step_rad, -1.0, 1.0),
        [2.0 * stiffness - 1.0]]).astype(np.float32)


class UpperReference(PhysicalAgent):
    """Knows the intention and follows the human's reference (privileged: a reference)."""

    name = "upper"
    privileged = True

    def attach(self, env: Any) -> None:
        """Reads the simulation: the human's reference and the grip."""
        self.env = env

    def begin_episode(self, task: RobotTask) -> None:
        """Keeps the episode's task (the action's scale)."""
        self.task = task

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Towards the grip pose of the human's reference, stiff."""
        sim = self.env.sim
        return follow_action(self.task, sim.grip_pose(), sim.human_grip_reference())


class PassiveFloor(PhysicalAgent):
    """The passive, gravity-compensated robot."""

    name = "passive"

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Zero stiffness."""
        return PASSIVE_ACTION.copy()


class LiftedLearner(PhysicalAgent):
    """The paper's Learner on the continuous env, through the motion primitives.

    Args:
        scenario: The scenario's name (its task graph: what the robot knows of the task).
        seed: The Learner's seed.
    """

    name = "learner"

    def __init__(self, scenario: str, seed: int = 0) -> None:
        self.graph = scenario_graph(scenario)
        self.agent: Agent = Learner(self.graph, 1, seed=seed).single()
        self.task: RobotTask | None = None

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: the start support and the supports' places are known."""
        self.task = task
        self.design = task.design
        self.grip_in_object = Pose(self.design.grip_pos, self.design.grip_quat)
        self.davi = Disagreement(self.design)
        self.observer = StateObserver(self.graph, task.geometry, self.design.lever)
        self.seats = Seats(task.geometry, self.design)
        self.start = int(task.start)
        self.state = self.graph.support_state(self.start, BOTH)
        self.states = [self.state]
        self.robot_actions: list[int] = []
        self.human_actions: list[int] = []
        self.action = WAIT
        self.last_human = WAIT
        self.line: StraightLine | None = None
        self.t = 0.0
        self.passive = True
        self._decided = False
        self.agent.begin_episode(self.start)

    def _observe_state(self, observation: np.ndarray) -> int:
        assert self.task is not None
        pos = self.task.part(observation, "object_pos").astype(float)
        quat = self.task.part(observation, "object_quat").astype(float)
        quat = quat / np.linalg.norm(quat)
        seat = self.seats.engaged(pos, quat)
        return self.observer.observe(pos, quat, seat, BOTH).state

    def _decide(self, grip: Pose) -> None:
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
        self.line = StraightLine(grip, goal, d.linear_speed, d.angular_speed,
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

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Follow the current primitive; re-decide when the state changes or it ends."""
        task = self.task
        if task is None:
            raise RuntimeError("begin_episode was not called")
        grip = grip_of(task, observation)
        if not self._decided:  # the episode's first decision, from where the grip is
            self._decided = True
            self._decide(grip)
        s_next = self._observe_state(observation)
        self.t += task.dt
        finished = self.line is None and self.t >= 0.4 or (
            self.line is not None and self.t >= self.line.duration + 0.4)
        if s_next != self.state or finished:
            self._transition(s_next)
            self._decide(grip)
        if self.passive or self.line is None:
            return PASSIVE_ACTION.copy()
        sensed = task.part(observation, "wrench").astype(float)
        moving = self.t < self.line.duration
        zero = np.zeros(3)
        scale = self.davi.update(self.davi.force(
            sensed[:3], sensed[3:], self.line.direction if moving else zero,
            self.line.axis if moving else zero), task.dt)
        if self.davi.yielded:
            self.passive = True
            return PASSIVE_ACTION.copy()
        ref = self.line.sample(self.t)
        return follow_action(task, grip, Pose(ref.pos, ref.quat), stiffness=scale)

    def end_episode(self, outcome: EpisodeOutcome) -> None:
        """Learn from the episode: the intention is revealed where the object was placed."""
        if len(self.robot_actions) == 0:
            self.robot_actions, self.human_actions = [WAIT], [WAIT]
            self.states.append(self.state)
        trace = Trace(np.array(self.states), np.array(self.robot_actions),
                      np.array(self.human_actions))
        self.agent.end_episode(trace, outcome.intention)


def run_episode(env: Any, policy: PhysicalAgent, seed: int | None = None,
                options: dict[str, Any] | None = None) -> dict[str, Any]:
    """One episode of ``policy`` on ``env`` (a ``gym.make``-d env or the unwrapped one)
    as a summary: the return, the human's effort, steps, time, where the object was placed,
    whether at the goal, the fault, the last ``info`` and the outcome
    (:func:`agents.physical.run_physical_episode`; v0 and v1 ids).
    """
    base = getattr(env, "unwrapped", env)
    run = run_physical_episode(env, policy, seed=seed, options=options)
    info = run.info
    effort = float(run.outcome.metrics.get("effort", info.get("episode_effort", 0.0)))
    return {"return": run.reward, "effort": effort, "steps": run.steps,
            "time_s": run.steps * base.sim.dt_step, "placed": run.outcome.placed,
            "reached_intention": bool(info.get("reached_intention", False)),
            "fault": run.outcome.fault, "info": info, "outcome": run.outcome}
