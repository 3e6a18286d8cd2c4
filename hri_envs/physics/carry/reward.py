"""The continuous envs' rewards and the figures an episode reports.

Two reward versions:

* **v0** (:class:`RewardWeights`; ids ``*PandaContinuous-v0``, frozen): progress along the
  human's route, minus effort and disagreement, minus a fault. It credits progress without
  placing and costs nothing for a time-out (docs/physics.md says why it was replaced).
* **v1** (:class:`PlacingReward`; ids ``*PandaContinuous-v1``): *placing the object at the
  human's goal is what pays*. Per step the robot pays for the human's effort (the impulse of
  their hand's wrench, one lever for every scenario: :data:`EFFORT_LEVER_M`), for the work
  the human does against the object's motion and for every second the object stalls, until
  these costs reach ``cost_cap`` in the episode (nothing more after that); the episode's end
  pays ``place`` when the object rests on the human's goal, and costs ``fail`` when it ends
  any other way (dropped, slipped, too weak, resting on another support, or the time limit).
  Nothing of the reward before the end depends on where the human wants to go: the goal
  enters only through the terminal term.

  With the cap at ``place`` (the default), an episode's return lies in ``[-fail - place,
  place]``: an episode that placed the object at the goal returns at least 0, one that did
  not at most ``-fail``. So effort is never ranked without completion, and a human whom no
  robot can help (the handle slips whatever it does) costs every robot the same bounded
  amount instead of dwarfing the other episodes.

:class:`EpisodeRecord` accumulates the figures of one episode from the simulation's steps:
the human's effort (also per unit of route progress, at the end), the linear and angular
impulse, peak and RMS interaction force, the object's RMS jerk, the disagreement work, the
time stalled and the time to place.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError

__all__ = ["EFFORT_LEVER_M", "STALL_M", "STALL_RAD", "STALL_S", "EpisodeRecord",
           "PlacingReward", "RewardWeights", "StallClock", "check_weights"]

#: [m] The lever that turns the hand's torque into a comparable force in the v1 effort
#: (∫ |F| + |τ| / lever dt): a hand's breadth, the same for every scenario.
EFFORT_LEVER_M = 0.1
#: The object *stalls* while it moves less than this far [m] and turns less than this [rad]
#: within the last :data:`STALL_S` seconds without resting on a support it was brought to.
STALL_M, STALL_RAD, STALL_S = 0.01, 0.05, 2.0


@dataclass(frozen=True)
class RewardWeights:
    """The v0 reward's weights (``*PandaContinuous-v0``; see :mod:`hri_envs.physics.
    carry.reward`).

    Attributes:
        progress: Reward for the whole route (per unit of route progress).
        effort: Cost per N s of the human's effort.
        disagreement: Cost per J of work the human does against the object's motion.
        fault: Cost of an episode that ends dropped or slipped.
    """

    progress: float = 10.0
    effort: float = 0.02
    disagreement: float = 0.1
    fault: float = 5.0


@dataclass(frozen=True)
class PlacingReward:
    """The v1 reward's weights (``*PandaContinuous-v1``).

    Attributes:
        place: Paid once, when the object comes to rest on the human's goal support.
        fail: Cost of an episode that ends any other way: dropped, slipped, too weak,
            resting on another support, or at the time limit.
        effort: Cost per N s of the human's effort (∫ |F| + |τ| / :data:`EFFORT_LEVER_M` dt
            of their hand's wrench on the handle).
        disagreement: Cost per J of work the human does against the object's motion.
        stall: Cost per second the object stalls (:class:`StallClock`).
        cost_cap: The most the per-step costs (effort, disagreement, stall) take from an
            episode; after that they are not charged.
    """

    place: float = 10.0
    fail: float = 5.0
    effort: float = 0.02
    disagreement: float = 0.1
    stall: float = 0.5
    cost_cap: float = 10.0


def check_weights(cls: type, values: Mapping[str, Any] | None) -> Any:
    """``cls`` (:class:`RewardWeights` or :class:`PlacingReward`) from a mapping of its
    fields, each a finite number >= 0.

    Raises:
        ConfigError: (``field="reward"``) An unknown key or a bad value.
    """
    if values is not None and not isinstance(values, Mapping):
        raise ConfigError(f"reward must be a mapping of weights, got {values!r}",
                          field="reward")
    values = dict(values or {})
    allowed = [f.name for f in fields(cls)]
    bad = sorted(map(str, set(values) - set(allowed)))
    if bad:
        raise ConfigError(f"unknown reward weight(s) {', '.join(map(repr, bad))}; allowed: "
                          f"{', '.join(allowed)}", field="reward")
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value) or value < 0:
            raise ConfigError(f"reward weight {key!r} must be a number >= 0, got {value!r}",
                              field="reward")
    return cls(**{k: float(v) for k, v in values.items()})


class StallClock:
    """Whether the object stalls: it moved less than :data:`STALL_M` and turned less than
    :data:`STALL_RAD` over the last :data:`STALL_S` seconds (sampled once per step).

    Args:
        dt: The step [s].
    """

    def __init__(self, dt: float) -> None:
        self.window = max(1, round(STALL_S / dt))
        self._pos: list[np.ndarray] = []
        self._quat: list[np.ndarray] = []

    def reset(self, pos: np.ndarray, quat: np.ndarray) -> None:
        """A new episode, the object at (``pos``, ``quat``)."""
        self._pos, self._quat = [np.array(pos, float)], [np.array(quat, float)]

    def update(self, pos: np.ndarray, quat: np.ndarray) -> bool:
        """The object's pose after a step; whether it stalls."""
        self._pos.append(np.array(pos, float))
        self._quat.append(np.array(quat, float))
        if len(self._pos) > self.window + 1:
            del self._pos[0], self._quat[0]
        if len(self._pos) <= self.window:
            return False
        moved = float(np.linalg.norm(self._pos[-1] - self._pos[0]))
        cos = min(1.0, abs(float(np.dot(self._quat[-1], self._quat[0]))))
        turned = 2.0 * math.acos(cos)
        return moved < STALL_M and turned < STALL_RAD


class EpisodeRecord:
    """The figures of one episode, accumulated step by step (v1's ``info["episode"]``).

    Args:
        dt: The step [s].
    """

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.reset()

    def reset(self) -> None:
        """A new episode."""
        self.steps = 0
        self.effort = self.linear = self.angular = self.disagreement = 0.0
        self.peak = self.force_sq = self.jerk_sq = self.stall_s = 0.0
        self.ret = 0.0
        self.cost = 0.0  # the per-step costs charged so far (v1: up to the cap)

    def add(self, step: Any, stalled: bool, reward: float) -> None:
        """One step of the simulation (a :class:`~hri_envs.physics.carry.sim.CarryStep`)."""
        self.steps += 1
        self.linear += step.linear_impulse
        self.angular += step.angular_impulse
        self.effort += step.linear_impulse + step.angular_impulse / EFFORT_LEVER_M
        self.disagreement += step.disagreement
        self.peak = max(self.peak, step.peak_force)
        self.force_sq += step.force_sq
        self.jerk_sq += step.jerk_sq
        self.stall_s += self.dt if stalled else 0.0
        self.ret += reward

    def charge(self, cost: float) -> None:
        """A step's per-step cost as charged (after the cap)."""
        self.cost += cost

    def report(self, *, outcome: str, placed: int, intention: int, progress: float,
               fault: str | None) -> dict[str, Any]:
        """The episode's figures (at its end; ``intention`` and ``progress`` are the
        evaluator's: known only now).
        """
        time_s = self.steps * self.dt
        reached = outcome == "placed"
        return {
            "outcome": outcome, "placed": placed, "intention": intention,
            "reached_intention": reached, "fault": fault,
            "time_s": time_s, "time_to_place_s": time_s if reached else math.nan,
            "return": self.ret, "progress": progress,
            "effort": self.effort,
            "effort_per_progress": self.effort / progress if progress > 1e-6 else math.inf,
            "linear_impulse": self.linear, "angular_impulse": self.angular,
            "peak_force": self.peak,
            "rms_force": math.sqrt(self.force_sq / time_s) if time_s > 0 else 0.0,
            "rms_jerk": math.sqrt(self.jerk_sq / time_s) if time_s > 0 else 0.0,
            "disagreement": self.disagreement, "stall_s": self.stall_s,
            "cost": self.cost,
        }
