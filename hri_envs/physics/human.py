"""The simulated human's hand: a saturating spring-damper on the object's handle.

The human moves the handle towards their own target (the physical pose of the abstract
state their action leads to) the way people reach: the equilibrium of their arm impedance
travels along a minimum-jerk straight line from where the object was when they started to
the target, and the force (and torque) they apply is a spring-damper towards it, saturated
at what a person comfortably applies, plus seeded band-limited noise. A human who waits
follows passively (no force); a human who does not hold the object applies nothing.
"""

from __future__ import annotations

import numpy as np

from hri_envs.physics.design import PhysicsDesign
from hri_envs.physics.kinematics import Pose, StraightLine, rotation_error

__all__ = ["SimulatedHuman"]


def _saturate(v: np.ndarray, limit: float) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v if n <= limit else v * (limit / n)


class SimulatedHuman:
    """Applies the human's wrench to the object.

    Args:
        design: Gains, force limits, speeds and noise.
        rng: Generator for the force noise.

    Attributes:
        holding: Whether the human holds the object (bit 0 of μ).
        plan: The current reach (object-frame target path), None when passive.
    """

    def __init__(self, design: PhysicsDesign, rng: np.random.Generator) -> None:
        self.design = design
        self.rng = rng
        self.holding = False
        self.plan: StraightLine | None = None
        self.t = 0.0
        self._noise = np.zeros(6)
        # Humans reach a little faster than the robot's planned motions.
        self.speed = (design.human_speed_factor * design.linear_speed,
                      design.human_speed_factor * design.angular_speed)

    def reset(self, rng: np.random.Generator) -> None:
        """New episode: not holding, no plan, fresh noise generator."""
        self.rng = rng
        self.holding = False
        self.plan = None
        self.t = 0.0
        self._noise[:] = 0.0

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
        return bool(np.linalg.norm(goal.pos - pos) < self.design.position_tolerance
                    and np.linalg.norm(rotation_error(goal.quat, quat))
                    < self.design.angle_tolerance)

    def wrench(self, pos: np.ndarray, quat: np.ndarray, vel: np.ndarray, angvel: np.ndarray,
               dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Force [N] and torque [N m] on the object, at its origin, for the next ``dt``.

        Args:
            pos: Object position [m].
            quat: Object orientation.
            vel: Velocity [m/s] of the object's origin.
            angvel: Angular velocity [rad/s].
            dt: Time step [s] (advances the reach and the noise).
        """
        if not self.holding or self.plan is None:
            return np.zeros(3), np.zeros(3)
        design = self.design
        if self.t < 0.0:  # still reacting: follows passively
            self.t += dt
            return np.zeros(3), np.zeros(3)
        ref = self.plan.sample(self.t)
        self.t += dt
        force = (design.human_stiffness * (ref.pos - pos)
                 + design.human_damping * (ref.vel - vel))
        torque = (design.human_rot_stiffness * rotation_error(ref.quat, quat)
                  + design.human_rot_damping * (ref.angvel - angvel))
        tau_n = design.human_noise_time_s  # noise bandwidth: ~1 Hz
        self._noise += (-self._noise * dt / tau_n
                        + np.sqrt(2.0 * dt / tau_n) * self.rng.standard_normal(6))
        force = _saturate(force, design.human_force) + design.human_noise * self._noise[:3]
        torque = (_saturate(torque, design.human_torque)
                  + design.human_noise_torque_lever_m * design.human_noise * self._noise[3:])
        return force, torque
