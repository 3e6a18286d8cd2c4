"""References and baselines for the continuous-control envs (``*PandaContinuous-v0/v1``).

Each is a :class:`~agents.physical.PhysicalAgent`: told an episode began (with its public
facts, :class:`~hri_envs.physics.carry.robot_view.RobotTask`), asked for an action per 25 Hz step
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
  picks an abstract action and executes it as a motion of the object towards that
  action's target state. Between its motions (when it waits, toggles or has yielded) it
  follows the human with the fixed admittance (:class:`~baselines.physical.admittance.
  FixedAdmittance`) instead of going limp; it starts a motion only where its model expects
  the human to make that move and once the human pushes that way, and then leads the
  object towards the target state with the admittance's motion added, slowing down while
  the human holds back (:func:`~baselines.physical.goal_robot.lead_speed`) and yielding
  (following them until its next decision) when they hold it back for long. (The v0
  robot's disagreement-aware softening, :class:`~hri_envs.physics.scene.controller.
  Disagreement`, read the wrist's raw wrench against its thresholds and let a turning
  object sag; the admittance keeps the human in control instead.) It learns across
  episodes as in the paper (the intention revealed where the object was placed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agents.learner import Learner
from agents.physical import PhysicalAgent, run_physical_episode
from agents.protocol import Agent, Trace
from baselines.physical.admittance import AdmittanceGains, FixedAdmittance, settle_action
from baselines.physical.goal_robot import LeadParams, embedded_wrench, lead_speed
from baselines.physical.sensing import object_state, twist_action
from hri_envs.physics.carry.robot_view import EpisodeOutcome, RobotTask
from hri_envs.physics.scene.kinematics import Pose, StraightLine, rotation_error
from hri_envs.physics.scene.observer import StateObserver
from hri_envs.physics.scene.seats import Seats
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import BOTH, TOGGLE, TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["PASSIVE_ACTION", "TUNED_LEARNER", "LearnerLead", "LiftedLearner", "PassiveFloor",
           "UpperReference", "follow_action", "grip_of", "run_episode"]

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


@dataclass(frozen=True)
class LearnerLead:
    """How the lifted Learner executes its abstract actions with the human.

    Attributes:
        confidence: It leads with a motion only when its own model of the human expects
            the human to make that same motion with at least this probability
            (``Σ_ι b(ι) π̂_H(a | s, ι)``, the Learner's posterior ``b`` and human model
            ``π̂_H``); otherwise it follows the human (and tells the Learner it waited).
            0: it leads whenever the Learner picks a motion, as the paper's Learner acts.
        engage_n: It starts leading once the human pushes at least this hard [N; torques
            over the design's lever] ...
        engage_cos: ... within ``arccos(engage_cos)`` of the motion (until then, and if
            the human never does, it follows them: the Learner is told it waited).
        lead: The lead's speed, its approach to the target and how it holds back while
            the human pulls against it (:class:`~baselines.physical.goal_robot.
            LeadParams`; its ``filter`` is not used).
        yield_s: Held back (the human pulling against the lead by ``lead.yield_n`` or
            more) this long [s], it yields: it follows the human until its next decision
            (the paper's robot yields to a human who disagrees, Sect. 4.3).
        admittance: How it follows the human (None: the scenario's tuned fixed admittance,
            :data:`~baselines.physical.admittance.TUNED_FIXED`).
    """

    confidence: float = 0.3
    engage_n: float = 1.0
    engage_cos: float = 0.7
    lead: LeadParams = field(default_factory=LeadParams)
    yield_s: float = 0.3
    admittance: AdmittanceGains | None = None


#: The lifted Learner's execution per scenario, chosen on training episodes by
#: ``.venv/bin/python benchmarks/tune_physical_baselines.py --jobs 2 --scenarios
#: hanger,wheel --seeds 4`` (its admittance: :data:`~baselines.physical.admittance.
#: TUNED_FIXED`).
TUNED_LEARNER: dict[str, LearnerLead] = {
    "hanger": LearnerLead(lead=LeadParams(speed_mps=0.3)),
    "wheel": LearnerLead(engage_cos=0.5, lead=LeadParams(speed_mps=0.245)),
}


class LiftedLearner(PhysicalAgent):
    """The paper's Learner on the continuous env, through the motion primitives.

    Args:
        scenario: The scenario's task graph (what the robot knows of the task), or a
            registered scenario's name (resolved here).
        seed: The Learner's seed.
        lead: How it executes its abstract actions (default: the scenario's tuned
            :data:`TUNED_LEARNER`).
    """

    name = "learner"

    def __init__(self, scenario: TaskGraph | str, seed: int = 0,
                 lead: LearnerLead | None = None) -> None:
        self.graph = as_graph(scenario)
        self.agent: Agent = Learner(self.graph, 1, seed=seed).single()
        self.task: RobotTask | None = None
        self.lead = lead if lead is not None else TUNED_LEARNER.get(self.graph.name,
                                                                    LearnerLead())
        self.follow = FixedAdmittance(self.graph, self.lead.admittance)

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: the start support and the supports' places are known."""
        self.task = task
        self.follow.begin_episode(task)
        self.design = task.design
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
        self.engaged = False
        self.t = self.held_s = 0.0
        self.passive = True
        self._decided = False
        self.agent.begin_episode(self.start)

    def _observe_state(self, pose: Pose) -> int:
        """The abstract state the object has arrived at (the last one while on the way)."""
        seat = self.seats.engaged(pose.pos, pose.quat)
        seen = self.observer.observe(pose.pos, pose.quat, seat, BOTH)
        d = self.design
        if seat < 0 and (seen.position_error > _ARRIVED * d.position_tolerance
                         or seen.angle_error > _ARRIVED * d.angle_tolerance):
            return self.state  # on the way: the object has not arrived at a new state yet
        return seen.state

    def _decide(self, obj: Pose) -> None:
        g, s = self.graph, self.state
        mask = g.valid[s].astype(np.int8)
        a = int(self.agent.act({"state": s, "start": self.start,
                                "last_human_action": self.last_human, "action_mask": mask}))
        if a > TOGGLE and self.expected(s, a) < self.lead.confidence:
            a = WAIT  # not sure enough the human goes there: follow them instead
        self.action = a
        self.t, self.engaged, self.held_s = 0.0, False, 0.0
        if a == WAIT or a == TOGGLE or not g.valid[s, a]:
            self.line, self.passive = None, True
            return
        target = Pose(*self.observer.pose(int(g.next_state[s, a, WAIT])))
        d = self.design  # the line: the primitive's target, its nominal duration, direction
        self.line = StraightLine(obj, target, d.linear_speed, d.angular_speed,
                                 d.motion_min_duration_s)
        self.passive = False

    def expected(self, state: int, action: int) -> float:
        """How likely the Learner's model finds it that the human makes ``action`` in
        ``state`` (``Σ_ι b(ι) π̂_H(action | state, ι)``).
        """
        batch = self.agent.batch  # type: ignore[attr-defined]
        return float(batch.posterior[0] @ batch.pi_h[0, :, state, action])

    def agrees(self, wrench: np.ndarray) -> bool:
        """The human pushes the way of the current primitive: their embedded wrench
        (``(F, τ / L)`` about the object's origin) has at least ``engage_n`` and points
        within ``arccos(engage_cos)`` of the line's embedded motion ``(Δp, L Δθ)``.
        """
        assert self.line is not None
        motion = np.concatenate([self.line.delta, self.design.lever * self.line.rotvec])
        push, norm = float(np.linalg.norm(wrench)), float(np.linalg.norm(motion))
        if push < self.lead.engage_n or norm < 1e-9:
            return False
        return float(wrench @ motion) >= self.lead.engage_cos * push * norm

    def _transition(self, s_next: int) -> None:
        g, s = self.graph, self.state
        if self.action > TOGGLE and not self.engaged:
            self.action = WAIT  # the human never went its way: it followed them
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
        """Lead along the current primitive (with the human's admittance added), or follow
        the human between primitives; re-decide when the object arrives at another
        abstract state or the primitive's time is up.
        """
        task = self.task
        if task is None:
            raise RuntimeError("begin_episode was not called")
        state = object_state(task, observation)
        v, w = self.follow.twist(observation, state)  # the filter runs every step
        if not self._decided:  # the episode's first decision, from where the object is
            self._decided = True
            self._decide(state.pose)
        s_next = self._observe_state(state.pose)
        self.t += task.dt
        finished = self.line is None and self.t >= 0.4 or (
            self.line is not None and self.t >= self.line.duration + 0.4)
        if s_next != self.state or finished:
            self._transition(s_next)
            self._decide(state.pose)
        if self.follow.wrench.settling:  # put on a seat: let it pull the object home
            return settle_action(self.follow.gains)
        stiffness = self.follow.gains.stiffness
        lever = self.design.lever
        wrench = embedded_wrench(state, self.follow.wrench.filtered, lever)
        if self.passive or self.line is None or not (self.engaged or self.agrees(wrench)):
            return twist_action(task, state, v, w, stiffness, state.handle)
        self.engaged = True
        goal = self.line.goal
        to_go = np.concatenate([goal.pos - state.pose.pos,
                                lever * rotation_error(goal.quat, state.pose.quat)])
        remaining = float(np.linalg.norm(to_go))
        direction = to_go / remaining if remaining > 1e-9 else np.zeros(6)
        speed = lead_speed(self.lead.lead, direction, remaining, wrench)
        held = float(wrench @ direction) <= -self.lead.lead.yield_n
        self.held_s = self.held_s + task.dt if held else 0.0
        if self.held_s >= self.lead.yield_s:  # held back for long: yield, follow them
            self.passive = True
        v = v + np.cross(w, state.pose.pos - state.handle)  # the admittance at the origin
        return twist_action(task, state, v + speed * direction[:3],
                            w + speed * direction[3:] / lever, stiffness)

    def end_episode(self, outcome: EpisodeOutcome) -> None:
        """Learn from the episode: the intention is revealed where the object was placed."""
        if len(self.robot_actions) == 0:
            self.robot_actions, self.human_actions = [WAIT], [WAIT]
            self.states.append(self.state)
        trace = Trace(np.array(self.states), np.array(self.robot_actions),
                      np.array(self.human_actions))
        self.agent.end_episode(trace, outcome.intention)


#: The object has arrived at an abstract state within this multiple of the design's
#: position and angle tolerances (half-way between two states it is at neither: the
#: Learner's next decision waits until the human's move is done).
_ARRIVED = 1.5


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
