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

from hri_envs.physics.scene.jit import kernel

__all__ = ["InteractionMeter", "StepInteraction", "meter_step"]


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
        force = np.ascontiguousarray(force, dtype=float)
        idx = (np.arange(len(self.samples))[rows] if isinstance(rows, slice)
               else np.asarray(rows, dtype=np.int64))
        out = np.empty((3, len(idx)))
        meter_step(idx, force, np.ascontiguousarray(velocity, dtype=float), self.v_prev,
                   self.a_prev, self.samples, self.dt, out)
        return StepInteraction(out[0], out[1], out[2])


@kernel
def meter_step(rows, force, velocity, v_prev, a_prev, samples, dt, out):
    """InteractionMeter.step's arithmetic per world (compiled): ``out`` (3, R) the peak force,
    ∫ |F|² dt and ∫ |jerk|² dt of the worlds ``rows`` from their samples ``force`` (R, P)
    and ``velocity`` (R, P, 3); their last mean velocity, acceleration and count
    (``v_prev``, ``a_prev``, ``samples``: (N, ...)) updated.
    """
    n_p = force.shape[1]
    dt_step = dt * n_p
    for j in range(len(rows)):
        i = rows[j]
        peak, f_sq, j_sq = -np.inf, 0.0, 0.0
        for p in range(n_p):
            f = force[j, p]
            peak = max(peak, f)
            f_sq += f * f
        count = samples[i] + 1
        for c in range(3):
            v = 0.0
            for p in range(n_p):
                v += velocity[j, p, c]
            v /= n_p  # the step's mean
            a = (v - v_prev[i, c]) / dt_step
            jerk = (a - a_prev[i, c]) / dt_step
            j_sq += jerk * jerk
            v_prev[i, c], a_prev[i, c] = v, a
        samples[i] = count
        # A jerk sample needs three mean velocities of this episode (the rest is the first).
        out[0, j], out[1, j] = peak, f_sq * dt
        out[2, j] = j_sq * dt_step if count >= 3 else 0.0
