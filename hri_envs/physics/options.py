"""The physics options of the mujoco backend (``physics={...}``) and their presets.

The keys themselves are listed once, in the backend registry
(:data:`hri_envs.envs.backends.PHYSICS_PARAMETERS`), and validated there
(:func:`hri_envs.envs.config.check_physics_options`); this module turns validated options
into the parameters of each episode.

=====================  =======  ==========================================================
key                    unit     meaning (default: the scenario's design, docs/physics.md)
=====================  =======  ==========================================================
``human_stiffness``    N/m      the human's arm stiffness (rotational one scaled alike)
``human_force``        N        the most force the human applies per axis (torque alike)
``human_noise``        N        std of the human's band-limited force noise
``human_delay_s``      s        the human's reaction delay before a reach starts
``human_mass``         kg       effective mass of the human's forearm (the hand: +0.1 kg)
``sensor_noise_n``     N        std of the wrist sensor's white noise per control step
``sensor_bias_n``      N        magnitude of its constant bias (random direction)
``sensor_delay_s``     s        its delay
``object_mass``        kg       the object's true mass (the robot compensates the nominal)
``hold_force``         N        the supports' detent force (pull needed to take off)
``human_grip_force``   N        how hard the human's thumb squeezes the handle
``handle_noise_n``     N        std of the handle's touch sensor reading
=====================  =======  ==========================================================

``attempt_invalid`` (bool, default False): the robot physically tries an action the graph
calls invalid instead of refusing it (:meth:`hri_envs.physics.sim.PandaSim.step`).
``preset`` names a set of values (:data:`PRESETS`, per scenario); explicit keys override it.
``randomize`` maps keys to ``(low, high)`` ranges drawn uniformly at each episode's reset
(domain randomisation).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from hri_envs.physics.design import PhysicsDesign

__all__ = ["PRESETS", "PhysicsParams", "PhysicsSettings"]

#: Named parameter sets per scenario. ``weak-human``: a partner with a third of the default
#: stiffness and strength (below the robot's disagreement threshold on the hanger), slower
#: to react and shakier, whose grip the handle barely feels (2.5 N against the robot's
#: 2 N threshold); ``noisy-sensor``: a cheap, uncalibrated, slow wrist sensor and a noisy
#: handle sensor.
PRESETS: dict[str, dict[str, dict[str, float]]] = {
    "weak-human": {
        "hanger": {"human_stiffness": 70.0, "human_force": 3.5, "human_noise": 0.8,
                   "human_delay_s": 0.4, "human_grip_force": 2.5},
        "wheel": {"human_stiffness": 100.0, "human_force": 8.0, "human_noise": 2.0,
                  "human_delay_s": 0.4, "human_grip_force": 2.5},
    },
    "noisy-sensor": {
        "hanger": {"sensor_noise_n": 3.0, "sensor_bias_n": 2.5, "sensor_delay_s": 0.05,
                   "handle_noise_n": 1.0},
        "wheel": {"sensor_noise_n": 6.0, "sensor_bias_n": 5.0, "sensor_delay_s": 0.05,
                  "handle_noise_n": 1.0},
    },
}


@dataclass(frozen=True)
class PhysicsParams:
    """The configurable physical parameters of one episode (units as in the module table)."""

    human_stiffness: float
    human_force: float
    human_noise: float
    human_delay_s: float
    human_mass: float
    sensor_noise_n: float
    sensor_bias_n: float
    sensor_delay_s: float
    object_mass: float
    hold_force: float
    human_grip_force: float
    handle_noise_n: float

    @classmethod
    def of(cls, design: PhysicsDesign) -> PhysicsParams:
        """The defaults of a design."""
        return cls(design.human_stiffness, design.human_force, design.human_noise,
                   design.human_delay_s, design.human_mass, design.sensor_noise_n,
                   design.sensor_bias_n, design.sensor_delay_s, design.object_mass,
                   design.seat_hold, design.human_grip_force, design.handle_noise_n)

    def true_design(self, nominal: PhysicsDesign) -> PhysicsDesign:
        """The nominal design with these parameters (the human's, the seats', the mass)."""
        k = self.human_stiffness / nominal.human_stiffness
        f = self.human_force / nominal.human_force
        return replace(nominal, human_stiffness=self.human_stiffness,
                       human_rot_stiffness=nominal.human_rot_stiffness * k,
                       human_force=self.human_force, human_torque=nominal.human_torque * f,
                       human_noise=self.human_noise, human_delay_s=self.human_delay_s,
                       human_mass=self.human_mass, human_grip_force=self.human_grip_force,
                       seat_hold=self.hold_force, object_mass=self.object_mass,
                       object_inertia=nominal.object_inertia * (self.object_mass
                                                                / nominal.object_mass))


PARAMETER_KEYS: tuple[str, ...] = tuple(f.name for f in fields(PhysicsParams))


class PhysicsSettings:
    """Validated ``physics`` options of one scenario, resolved into episode parameters.

    Args:
        design: The scenario's nominal design.
        options: Options checked by :func:`hri_envs.envs.config.check_physics_options`
            (``video_*`` keys are ignored here).
    """

    def __init__(self, design: PhysicsDesign, options: Mapping[str, Any] | None = None) -> None:
        options = dict(options or {})
        values: dict[str, float] = {}
        preset = options.get("preset")
        if preset is not None:
            values.update(PRESETS[preset][design.scenario])
        values.update({k: float(v) for k, v in options.items() if k in PARAMETER_KEYS})
        self.preset: str | None = preset
        #: The robot physically tries actions the graph calls invalid (docs/physics.md).
        self.attempt_invalid = bool(options.get("attempt_invalid", False))
        self.base = replace(PhysicsParams.of(design), **values)
        self.ranges: dict[str, tuple[float, float]] = {
            k: (float(lo), float(hi)) for k, (lo, hi) in dict(options.get("randomize")
                                                              or {}).items()}

    def draw(self, rng: np.random.Generator) -> PhysicsParams:
        """The parameters of a new episode (randomised keys drawn from ``rng``)."""
        if not self.ranges:
            return self.base
        drawn = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in sorted(self.ranges.items())}
        return replace(self.base, **drawn)
