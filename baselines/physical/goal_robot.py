"""What the goal-inference robots share: an admittance that follows the human, a filter over
the routes to each goal, and the robot's own motion along a predicted route.

:class:`GoalRobot` runs, each step, the fixed admittance (:class:`~baselines.physical.
admittance.FixedAdmittance`, its tuned gains: the human's authority) and the route filter
(:class:`~baselines.physical.routes.RouteFilter`) on the object's pose, the human's
wrench and the motion the human caused (the object's velocity less the robot's own lead
of the last step: a robot that leads the wrong way must not read its own motion as the
human's wish); a subclass turns both into the step's twist (:meth:`GoalRobot.combine`):
predict-then-blend (:mod:`baselines.physical.blend`) or acting on the belief
(:mod:`baselines.physical.hindsight`).

The robot's own motion along a predicted direction ``u`` (embedded, unit) has the speed
(:meth:`GoalRobot.speed`)::

    s = min(speed_mps, remaining / approach_s) x clip(1 + min(f·u, 0) / yield_n, 0, 1)

it slows down towards the route's end (``remaining``: what is left of the route), and
holds back while the human pulls against it (``f·u < 0``, the human's embedded wrench
along ``u``): at ``yield_n`` against it, it stops. The human's reference waits at each
waypoint (their hesitation); a robot that ran on would be pulled back there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from agents.physical import PhysicalAgent
from baselines.physical.admittance import AdmittanceGains, FixedAdmittance, settle_action
from baselines.physical.routes import FilterParams, Projection, RouteFilter, Routes
from baselines.physical.sensing import ObjectState, clamp, object_state, twist_action
from hri_envs.physics.carry.robot_view import RobotTask
from hri_envs.task.graph import TaskGraph

__all__ = ["GoalRobot", "LeadParams", "Step", "embedded_wrench", "lead_speed"]


@dataclass(frozen=True)
class LeadParams:
    """How a goal-inference robot leads along a predicted route.

    Attributes:
        speed_mps: Its cruising speed along the route [m/s, embedded].
        approach_s: Near the route's end its speed is at most the remaining length over
            this time [s] (it arrives without overshooting).
        yield_n: The human's pull against the motion [N, embedded] at which it stops.
        filter: The route filter's parameters.
        admittance: The admittance (None: the scenario's tuned fixed admittance).
    """

    speed_mps: float = 0.2
    approach_s: float = 0.5
    yield_n: float = 3.0
    filter: FilterParams = field(default_factory=FilterParams)
    admittance: AdmittanceGains | None = None


def lead_speed(params: LeadParams, direction: np.ndarray, remaining: float,
               wrench: np.ndarray) -> float:
    """The speed [m/s, embedded] of a robot that leads along ``direction`` (6,, embedded,
    unit) with ``remaining`` [m, embedded] to go while the human's embedded wrench is
    ``wrench`` (6,): ``min(speed_mps, remaining / approach_s) x clip(1 + min(f·u, 0) /
    yield_n, 0, 1)`` (the module docstring).
    """
    pull = min(float(wrench @ direction), 0.0)
    return (min(params.speed_mps, max(remaining, 0.0) / params.approach_s)
            * clamp(1.0 + pull / params.yield_n, 0.0, 1.0))


def embedded_wrench(state: ObjectState, wrench: np.ndarray, lever: float) -> np.ndarray:
    """(6,) the human's wrench (force, torque about the handle: :class:`~baselines.physical.
    sensing.HumanWrench`) as the dual of the embedded pose: ``(F, τ_o / L)`` with the
    torque moved to the object's origin.
    """
    arm = state.handle - state.pose.pos
    return np.concatenate([wrench[:3], (wrench[3:] + np.cross(arm, wrench[:3])) / lever])


class Step:
    """One step's view of the episode for :meth:`GoalRobot.combine`.

    Attributes:
        state: The object's state.
        proj: Where the object lies relative to each route.
        wrench: (6,) the human's wrench, embedded as the dual of the pose: (F, τ / L) with
            τ about the object's origin [N].
        adm_v, adm_w: The admittance's twist about the object's origin [m/s], [rad/s].
    """

    def __init__(self, state: ObjectState, proj: Projection, wrench: np.ndarray,
                 adm_v: np.ndarray, adm_w: np.ndarray) -> None:
        self.state, self.proj, self.wrench = state, proj, wrench
        self.adm_v, self.adm_w = adm_v, adm_w


class GoalRobot(PhysicalAgent):
    """The base of the goal-inference robots (see the module docstring).

    Args:
        graph: The scenario's task graph (the admittance's tuned gains).
        params: How it leads and infers.
    """

    name = "goal-robot"

    def __init__(self, graph: TaskGraph, params: LeadParams) -> None:
        self.params = params
        self.admittance = FixedAdmittance(graph, params.admittance)
        self.task: RobotTask | None = None
        self.filter: RouteFilter | None = None

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: the routes from its start, the prior, a fresh admittance."""
        self.task = task
        self.admittance.begin_episode(task)
        self.routes = Routes(task)
        self.filter = RouteFilter(self.routes, self.params.filter)
        #: (6,) the robot's own lead (embedded twist) of the last step, which a subclass's
        #: combine() sets: the filter reads the human from the rest of the motion.
        self.own = np.zeros(6)

    def belief(self) -> np.ndarray | None:
        """(K,) the posterior over the supports as the human's goal."""
        return None if self.filter is None else self.filter.goals()

    def speed(self, direction: np.ndarray, remaining: float, wrench: np.ndarray) -> float:
        """The robot's speed [m/s, embedded] along ``direction`` (module docstring)."""
        return lead_speed(self.params, direction, remaining, wrench)

    def combine(self, step: Step) -> tuple[np.ndarray, np.ndarray]:
        """The step's object twist (v [m/s] of the origin, ω [rad/s]); subclasses decide
        (and set :attr:`own`, the part that is the robot's own lead, embedded).
        """
        return step.adm_v, step.adm_w

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Admittance, filter update, then :meth:`combine`'s twist, stiff."""
        task, flt = self.task, self.filter
        if task is None or flt is None:
            raise RuntimeError(f"{self.name}: begin_episode was not called")
        state = object_state(task, observation)
        v_h, w = self.admittance.twist(observation, state)
        arm = state.handle - state.pose.pos
        adm_v = v_h + np.cross(w, -arm)  # the admittance's twist moved to the origin
        lever = self.routes.lever
        wrench = embedded_wrench(state, self.admittance.wrench.filtered, lever)
        x = self.routes.embed(state.pose.pos, state.pose.quat)
        # The motion the human caused: the object's, less the robot's own lead last step.
        velocity = np.concatenate([state.vel, lever * state.angvel]) - self.own
        proj = flt.update(x, velocity, wrench)
        v, omega = self.combine(Step(state, proj, wrench, adm_v, w))
        if self.admittance.wrench.settling:
            self.own = np.zeros(6)
            return settle_action(self.admittance.gains)
        return twist_action(task, state, v, omega, self.admittance.gains.stiffness)
