"""Acting on the belief over goals: QMDP / hindsight optimisation (Javdani, Srinivasa &
Bagnell, *Shared autonomy via hindsight optimization*, RSS 2015).

:class:`GoalQMDP` keeps the same Bayesian filter over the routes to each goal as
:class:`~baselines.physical.blend.GoalBlend` but does not commit to the most likely goal.
Each step it chooses its own motion ``m`` (an embedded twist) from a few candidates, the
one that maximises the value *expected over the posterior* ``b`` of the route hypotheses
``h``, each valued as if its goal were known (the QMDP / hindsight approximation: the
uncertainty is assumed to resolve after this step)::

    m* = argmax_m  Σ_h b_h Q_h(m),
    Q_h(m) = useful_h(m) - λ |m - useful_h(m) u_h|,
    useful_h(m) = min(max(m·u_h, 0), remaining_h / approach_s)

``useful_h`` is the progress [m/s] the motion makes along ``h``'s predicted direction
``u_h`` (no more than what is left of the route); the rest of the motion is what the
human would have to push back, at ``λ`` per m/s (their expected effort, in the units of
progress). Candidates: no motion; each likely route's direction; the posterior's mean
direction; each at the cruising speed and at half of it, held back by the human's pull
(:meth:`~baselines.physical.goal_robot.GoalRobot.speed`). While the likely goals share a
direction (lifting the object off its start, the first move), the mean direction has a
high value under all of them and the robot moves; where they part, no single direction
is worth the expected effort until the posterior favours one. The admittance's twist (the
human's command) is added to the chosen motion: the human keeps full authority over what
the robot adds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from baselines.physical.admittance import tuned
from baselines.physical.goal_robot import GoalRobot, LeadParams, Step
from baselines.physical.routes import FilterParams
from baselines.physical.sensing import unit
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["TUNED_QMDP", "GoalQMDP", "QMDPParams", "expected_values"]


@dataclass(frozen=True)
class QMDPParams:
    """The QMDP robot's parameters.

    Attributes:
        lead: How it leads and infers (:class:`~baselines.physical.goal_robot.LeadParams`).
        effort_weight: λ, the expected effort's weight per m/s of motion the human would
            have to undo.
        min_weight: Route hypotheses below this posterior are not candidates themselves.
    """

    lead: LeadParams = field(default_factory=LeadParams)
    effort_weight: float = 1.0
    min_weight: float = 0.02

    def __post_init__(self) -> None:
        if not self.effort_weight >= 0:
            raise ConfigError(f"effort_weight must be >= 0, got {self.effort_weight!r}",
                              field="effort_weight")


#: The QMDP robot per scenario, chosen on training episodes by ``.venv/bin/python
#: benchmarks/tune_physical_baselines.py --jobs 2 --scenarios hanger,wheel --seeds 4``
#: (its admittance: :data:`~baselines.physical.admittance.TUNED_FIXED`).
TUNED_QMDP: dict[str, QMDPParams] = {
    "hanger": QMDPParams(LeadParams(speed_mps=0.103, filter=FilterParams(kappa_f=1.0)),
                         effort_weight=2.0),
    "wheel": QMDPParams(LeadParams(speed_mps=0.12, yield_n=24.0,
                                   filter=FilterParams(kappa_f=0.0)), effort_weight=0.25),
}


def expected_values(motions: np.ndarray, directions: np.ndarray, remaining: np.ndarray,
                    weights: np.ndarray, effort_weight: float, approach_s: float
                    ) -> np.ndarray:
    """(M,) Σ_h b_h Q_h(m) for candidate motions (M, 6) under hypotheses with directions
    (H, 6), remaining lengths (H,) and weights b (H,) (the module docstring's Q_h).
    """
    along = motions @ directions.T  # (M, H)
    useful = np.minimum(np.maximum(along, 0.0), remaining[None, :] / approach_s)
    rest = motions[:, None, :] - useful[..., None] * directions[None, :, :]  # (M, H, 6)
    q = useful - effort_weight * np.linalg.norm(rest, axis=2)
    return q @ weights


class GoalQMDP(GoalRobot):
    """Chooses the motion that is best in expectation over the goal posterior.

    Args:
        scenario: The scenario's task graph, or a registered scenario's name (resolved
            here): its tuned parameters, :data:`TUNED_QMDP`, unless ``params``.
        params: The parameters.

    Attributes:
        chosen: The last step's chosen motion (6,), embedded.
    """

    name = "goal-qmdp"

    def __init__(self, scenario: TaskGraph | str, params: QMDPParams | None = None) -> None:
        graph = as_graph(scenario)
        if params is None:
            params = tuned(TUNED_QMDP, graph)
        self.qmdp = params
        self.chosen = np.zeros(6)
        super().__init__(graph, params.lead)

    def candidates(self, step: Step) -> np.ndarray:
        """(M, 6) the candidate motions (embedded twists) of this step."""
        assert self.filter is not None
        post, proj = self.filter.posterior, step.proj
        keep = post >= self.qmdp.min_weight
        dirs = [proj.direction[h] for h in np.flatnonzero(keep)]
        dirs.append(unit(post @ proj.direction))
        remaining = float(post @ proj.remaining)
        out = [np.zeros(6)]
        for d in dirs:
            if np.linalg.norm(d) < 1e-9:
                continue
            s = self.speed(d, remaining, step.wrench)
            out += [s * d, 0.5 * s * d]
        return np.array(out)

    def combine(self, step: Step) -> tuple[np.ndarray, np.ndarray]:
        """The admittance's twist plus the motion of greatest expected value."""
        assert self.filter is not None
        motions = self.candidates(step)
        values = expected_values(motions, step.proj.direction, step.proj.remaining,
                                 self.filter.posterior, self.qmdp.effort_weight,
                                 self.params.approach_s)
        self.chosen = motions[int(np.argmax(values))]
        self.own = self.chosen
        speed = float(np.linalg.norm(self.chosen))
        v, w = self.routes.twist_of(unit(self.chosen), speed)
        return step.adm_v + v, step.adm_w + w
