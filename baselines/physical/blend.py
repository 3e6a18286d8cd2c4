"""Goal inference and predict-then-blend (Dragan & Srinivasa, *A policy-blending formalism
for shared control*, IJRR 32(7):790-805, 2013).

:class:`GoalBlend` *predicts* the human's goal with a Bayesian filter over the routes to
each support (:mod:`baselines.physical.routes`: the likelihood of the human's wrench and
of the motion they cause under each route's predicted direction) and *blends* its own
motion towards the inferred goal with the human's, as the paper's arbitration does::

    v = α v_robot + (1 - α) v_admittance,    α = α_max clip((c - c_lo) / (c_hi - c_lo), 0, 1)

with ``c`` the confidence, the posterior probability of the most likely goal ``g*``;
``v_admittance`` the fixed admittance's twist (the human's command: their push, as the
wrist feels it); ``v_robot`` the robot's motion along ``g*``'s routes (the direction to
their lookahead point, averaged over ``g*``'s routes by posterior) at the speed of
:meth:`~baselines.physical.goal_robot.GoalRobot.speed`. While the goal is uncertain the
robot is the admittance; as the evidence for one goal grows it takes over the motion,
never beyond ``α_max``. The paper's arbitration is a function of the confidence; the
thresholds and ``α_max`` here were tuned (:data:`TUNED_BLEND`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from baselines.physical.admittance import tuned
from baselines.physical.goal_robot import GoalRobot, LeadParams, Step
from baselines.physical.routes import FilterParams
from baselines.physical.sensing import clamp, unit
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["TUNED_BLEND", "BlendParams", "GoalBlend", "arbitration"]


@dataclass(frozen=True)
class BlendParams:
    """The blend's parameters.

    Attributes:
        lead: How it leads and infers (:class:`~baselines.physical.goal_robot.LeadParams`).
        confidence_lo: Below this confidence the robot is the admittance (α = 0).
        confidence_hi: From this confidence α is ``alpha_max``.
        alpha_max: The most the robot's own motion weighs (0-1).
    """

    lead: LeadParams = field(default_factory=LeadParams)
    confidence_lo: float = 0.6
    confidence_hi: float = 0.9
    alpha_max: float = 0.8

    def __post_init__(self) -> None:
        if not 0.0 <= self.confidence_lo < self.confidence_hi <= 1.0:
            raise ConfigError("need 0 <= confidence_lo < confidence_hi <= 1, got "
                              f"{self.confidence_lo!r}, {self.confidence_hi!r}",
                              field="confidence_lo")
        if not 0.0 <= self.alpha_max <= 1.0:
            raise ConfigError(f"alpha_max must be in [0, 1], got {self.alpha_max!r}",
                              field="alpha_max")


#: The blend per scenario, chosen on training episodes by ``.venv/bin/python
#: benchmarks/tune_physical_baselines.py --jobs 2 --scenarios hanger,wheel --seeds 4``
#: (its admittance: :data:`~baselines.physical.admittance.TUNED_FIXED`).
TUNED_BLEND: dict[str, BlendParams] = {
    "hanger": BlendParams(LeadParams(speed_mps=0.42, filter=FilterParams(kappa_f=1.0)),
                          alpha_max=0.6),
    "wheel": BlendParams(LeadParams(speed_mps=0.5), confidence_lo=0.7, alpha_max=0.6),
}


def arbitration(confidence: float, params: BlendParams) -> float:
    """α, the weight of the robot's own motion, for a confidence (0-1) in the goal."""
    ramp = (confidence - params.confidence_lo) / (params.confidence_hi - params.confidence_lo)
    return params.alpha_max * clamp(ramp, 0.0, 1.0)


class GoalBlend(GoalRobot):
    """Predict the goal, then blend the robot's motion towards it with the human's.

    Args:
        scenario: The scenario's task graph, or a registered scenario's name (resolved
            here): its tuned parameters, :data:`TUNED_BLEND`, unless ``params``.
        params: The parameters.

    Attributes:
        alpha: The last step's arbitration weight α.
    """

    name = "goal-blend"

    def __init__(self, scenario: TaskGraph | str, params: BlendParams | None = None) -> None:
        graph = as_graph(scenario)
        if params is None:
            params = tuned(TUNED_BLEND, graph)
        self.blend = params
        self.alpha = 0.0
        super().__init__(graph, params.lead)

    def prediction(self, step: Step) -> tuple[np.ndarray, float]:
        """The inferred goal's direction (embedded, unit) and its route's remaining length
        (both averaged over the goal's routes by posterior).
        """
        assert self.filter is not None
        post, goals = self.filter.posterior, self.routes.goals
        best = int(np.argmax(self.filter.goals()))
        w = np.where(goals == best, post, 0.0)
        w = w / max(float(w.sum()), 1e-12)
        return unit(w @ step.proj.direction), float(w @ step.proj.remaining)

    def combine(self, step: Step) -> tuple[np.ndarray, np.ndarray]:
        """``α v_robot + (1 - α) v_admittance`` (the module docstring)."""
        assert self.filter is not None
        self.alpha = arbitration(float(self.filter.goals().max()), self.blend)
        direction, remaining = self.prediction(step)
        speed = self.speed(direction, remaining, step.wrench) if self.alpha > 0 else 0.0
        v_r, w_r = self.routes.twist_of(direction, speed)
        a = self.alpha
        self.own = a * direction * speed
        return a * v_r + (1 - a) * step.adm_v, a * w_r + (1 - a) * step.adm_w
