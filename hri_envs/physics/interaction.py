"""Interaction measures of the continuous envs, over a leading world axis.

Besides the human's effort (the impulse of their hand's wrench), physical human-robot
interaction studies report the *peak* and *RMS interaction force* and the *jerk* of the
carried object (smoothness). :class:`InteractionMeter` computes them from what each control
period (125 Hz) of a step samples: the magnitude of the force the human's hand puts on the
handle and the object's linear velocity at the period's end. Jerk is the second difference
of the sampled velocity (the third derivative of the position), so the first two samples of
an episode carry no jerk. The same arrays serve one world (the C backend) and N (MuJoCo
Warp).
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
        self.v_prev = np.zeros((n, 3))  # the last sampled velocity [m/s]
        self.a_prev = np.zeros((n, 3))  # the last sampled acceleration [m/s²]
        self.samples = np.zeros(n, dtype=np.int64)  # velocities sampled this episode

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
        dt = self.dt
        force = np.asarray(force, dtype=float)
        v = np.concatenate([self.v_prev[rows][:, None], velocity], axis=1)  # (R, P+1, 3)
        acc = np.diff(v, axis=1) / dt  # (R, P, 3)
        a = np.concatenate([self.a_prev[rows][:, None], acc], axis=1)
        jerk = np.diff(a, axis=1) / dt  # (R, P, 3)
        # A jerk sample needs three velocities of this episode: the p-th sample of the step
        # is the (samples + p)-th velocity, valid from the third on.
        count = self.samples[rows][:, None] + np.arange(1, force.shape[1] + 1)[None]
        valid = count >= 3
        jerk_sq = (np.einsum("rpi,rpi->rp", jerk, jerk) * valid).sum(axis=1) * dt
        self.v_prev[rows] = velocity[:, -1]
        self.a_prev[rows] = acc[:, -1]
        self.samples[rows] = count[:, -1]
        return StepInteraction(force.max(axis=1), (force * force).sum(axis=1) * dt, jerk_sq)
