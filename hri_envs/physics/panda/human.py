"""The simulated human's decisions: where their hand goes (the reach and its noise).

The human moves the handle towards their own target (the physical pose of the abstract
state their action leads to) the way people reach: after their reaction delay, the
reference of their arm travels along a minimum-jerk straight line from where the object was
when they started to the target, plus seeded band-limited noise. The arm that turns this
reference into force is embodied in the scene (:mod:`~hri_envs.physics.panda.human_arm`): its
position actuators have the human's stiffness, damping and force limit. A human who waits
(or is still reacting) follows passively: the arm keeps only its damping and inertia.
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import Pose, StraightLine, TrajectorySample, rotation_error

__all__ = ["SimulatedHuman"]


class SimulatedHuman:
    """What the human wants their hand to do.

    Args:
        design: Speeds, reaction delay and noise time constant.
        rng: Generator for the noise.

    Attributes:
        holding: Whether the human holds the object (bit 0 of μ).
        plan: The current reach (object-frame target path), None when passive.
        noise: (6,) the band-limited unit noise (std 1 in steady state, ~1 Hz); the arm
            scales it to force [N] and torque [N m].
    """

    def __init__(self, design: PhysicsDesign, rng: np.random.Generator) -> None:
        self.design = design
        self.rng = rng
        self.holding = False
        self.plan: StraightLine | None = None
        self.t = 0.0
        self.noise = np.zeros(6)
        # Humans reach a little faster than the robot's planned motions.
        self.speed = (design.human_speed_factor * design.linear_speed,
                      design.human_speed_factor * design.angular_speed)

    def reset(self, rng: np.random.Generator) -> None:
        """New episode: not holding, no plan, fresh noise generator."""
        self.rng = rng
        self.holding = False
        self.plan = None
        self.t = 0.0
        self.noise[:] = 0.0

    def reach(self, start: Pose, target: Pose) -> None:
        """Start moving the object from ``start`` to ``target`` (object-frame poses)."""
        self.plan = StraightLine(start, target, *self.speed,
                                 min_duration=self.design.motion_min_duration_s)
        self.t = -self.design.human_delay_s  # the reach starts after the reaction delay

    def stop(self) -> None:
        """Follow passively."""
        self.plan = None

    def at_target(self, pos: np.ndarray, quat: np.ndarray) -> bool:
        """Whether the object is at the plan's target (or there is no plan)."""
        if self.plan is None:
            return True
        goal = self.plan.goal
        d = goal.pos - pos
        if math.sqrt(d.dot(d)) >= self.design.position_tolerance:  # = np.linalg.norm(d)
            return False
        r = rotation_error(goal.quat, quat)
        return math.sqrt(r.dot(r)) < self.design.angle_tolerance

    def advance(self, dt: float) -> TrajectorySample | None:
        """The object-frame reference for the next ``dt`` [s], or None to follow passively.

        Advances the reach and, while reaching, the noise (an Ornstein-Uhlenbeck process of
        time constant ``human_noise_time_s``: band ~1 Hz, unit standard deviation).
        """
        if not self.holding or self.plan is None:
            return None
        if self.t < 0.0:  # still reacting: follows passively
            self.t += dt
            return None
        ref = self.plan.sample(self.t)
        self.t += dt
        tau_n = self.design.human_noise_time_s
        a = min(dt / tau_n, 1.0)
        # n += -n a + √(2a) z, element by element on plain floats (the same numbers).
        k = math.sqrt(2.0 * a)
        z = self.rng.standard_normal(6).tolist()
        self.noise[:] = [n + (-n * a + k * zi) for n, zi in zip(self.noise.tolist(), z,
                                                                   strict=True)]
        return ref
