"""Interaction measures of the continuous envs, over a leading world axis.

Besides the human's effort (the impulse of their hand's wrench), physical human-robot
interaction studies report the *peak* and *RMS interaction force* and the *jerk* of the
carried object (smoothness). :class:`InteractionMeter` computes them from what each control
period (125 Hz) of a step samples: the magnitude of the force the human's hand puts on the
handle and the object's linear velocity at the period's end. Jerk is the second difference
(the third derivative of the position) of the step's mean velocity, at the env's 25 Hz: the
mean over the step's periods filters the contact chatter that differences at 125 Hz would
amplify, so jerk measures how the object is carried, not the simulator's noise. The first
two steps of an episode carry no jerk. The same arrays serve one world (the C backend) and
N (MuJoCo Warp).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["InteractionMeter", "StepInteraction"]


class StepInteraction(NamedTuple):
    """One step's measures per world, each (R,).

    Attributes:
        peak_force: The largest force [N] the hand put on the handle at a period's end.
        force_sq: ∫ |F|² dt [N² s] (the episode's RMS force is √(Σ force_sq / duration)).
        jerk_sq: ∫ |d³x/dt³|² dt [m² s⁻⁵] of the object's origin.
    """

    peak_force: np.ndarray
    force_sq: np.ndarray
    jerk_sq: np.ndarray


class InteractionMeter:
    """Peak and RMS interaction force and the object's squared jerk, per world.

    Args:
        n: Worlds.
        dt: The sampling period [s] (the control period).
    """

    def __init__(self, n: int, dt: float) -> None:
        self.dt = float(dt)
        self.v_prev = np.zeros((n, 3))  # the last step's mean velocity [m/s]
        self.a_prev = np.zeros((n, 3))  # the last step's acceleration [m/s²]
        self.samples = np.zeros(n, dtype=np.int64)  # mean velocities this episode

    def reset(self, rows: np.ndarray | slice, velocity: np.ndarray | None = None) -> None:
        """New episodes in ``rows``: the object starts at ``velocity`` ((R, 3); default at
        rest), no acceleration sampled yet.
        """
        self.v_prev[rows] = 0.0 if velocity is None else velocity
        self.a_prev[rows] = 0.0
        self.samples[rows] = 1

    def step(self, rows: np.ndarray | slice, force: np.ndarray, velocity: np.ndarray
             ) -> StepInteraction:
        """The measures of one step of the worlds ``rows`` from its periods' samples.

        Args:
            rows: The worlds.
            force: (R, P) the hand's force magnitude [N] at each period's end.
            velocity: (R, P, 3) the object's linear velocity [m/s] at each period's end.
        """
        force = np.asarray(force, dtype=float)
        dt_step = self.dt * force.shape[1]
        v = np.asarray(velocity, dtype=float).mean(axis=1)  # (R, 3) the step's mean
        acc = (v - self.v_prev[rows]) / dt_step
        jerk = (acc - self.a_prev[rows]) / dt_step
        count = self.samples[rows] + 1
        # A jerk sample needs three mean velocities of this episode (the rest is the first).
        jerk_sq = np.einsum("ri,ri->r", jerk, jerk) * (count >= 3) * dt_step
        self.v_prev[rows], self.a_prev[rows], self.samples[rows] = v, acc, count
        return StepInteraction(force.max(axis=1), (force * force).sum(axis=1) * self.dt,
                               jerk_sq)
