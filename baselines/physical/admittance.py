"""Admittance control: the robot moves the object where the human pushes it.

Two robots of the continuous envs that follow the human's wrench as felt at the wrist
(:class:`~baselines.physical.sensing.HumanWrench`: the sensor's estimate of the external
wrench, minus the engaged seat's, low-pass filtered), tracking the motion stiffly with
the Cartesian impedance controller:

* :class:`FixedAdmittance`: a damper, ``v = F / D`` and ``ω = τ / D_r`` (F, τ beyond a
  radial deadband), the classic admittance of cooperative manipulation (e.g. Ikeura &
  Inooka, *Variable impedance control of a robot for cooperation with a human*, ICRA 1995,
  with its damping fixed);
* :class:`VariableAdmittance`: the same with a virtual mass ``M v̇ + D v = F`` whose
  damping *falls* while the human pushes along the motion and their push grows (they want
  to go faster) and *rises* when they push against the motion or their push fades (they
  want to slow down or stop). The human's intention is read from the force and its time
  derivative, as Duchaine & Gosselin (*General model of human-robot cooperation using a
  novel velocity based variable impedance control*, WHC 2007) do with ``dF/dt``; the
  mass varies with the damping so that their ratio, the admittance's time constant, stays
  fixed, as in Lecours, Mayer-St-Onge & Gosselin (*Variable admittance control of a
  four-degree-of-freedom intelligent assist device*, ICRA 2012), who vary the damping with
  the human's intended acceleration. What is implemented is written out in
  :meth:`VariableAdmittance.damping`; the thresholds are ours (tuned, below).

The parameters of both were chosen on training episodes only
(``benchmarks/tune_physical_baselines.py``; the command and its output are in
:data:`TUNED_FIXED` and :data:`TUNED_VARIABLE`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent
from baselines.physical.sensing import (
    HumanWrench,
    ObjectState,
    clamp,
    deadband,
    lowpass_alpha,
    object_state,
    twist_action,
    unit,
)
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.robot_view import RobotTask
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["TUNED_FIXED", "TUNED_VARIABLE", "AdmittanceGains", "FixedAdmittance",
           "VariableAdmittance", "VariableGains", "settle_action", "tuned"]


def _require_positive(params: Any, keys: tuple[str, ...]) -> None:
    """Raise a :class:`ConfigError` (``field=`` the key) unless each ``params.<key>`` is > 0."""
    for key in keys:
        if not getattr(params, key) > 0:
            raise ConfigError(f"{key} must be > 0, got {getattr(params, key)!r}", field=key)


@dataclass(frozen=True)
class AdmittanceGains:
    """A fixed admittance's parameters.

    Attributes:
        damping: D [N s/m]: the object moves at ``F / D``.
        rot_damping: D_r [N m s/rad]: it turns at ``τ / D_r`` (τ about its origin).
        deadband_n: Forces below this [N] are ignored (the radial deadband).
        deadband_nm: Torques below this [N m] are ignored.
        filter_s: Time constant [s] of the wrench's low-pass filter.
        stiffness: The impedance controller's stiffness scale while tracking (0-1).
        settle_stiffness: The stiffness scale once a seat holds the object after it left
            its start (:attr:`~baselines.physical.sensing.HumanWrench.settling`): the robot
            stops following and lets the seat pull the object home (0: passive).
    """

    damping: float = 10.0
    rot_damping: float = 1.0
    deadband_n: float = 1.0
    deadband_nm: float = 0.1
    filter_s: float = 0.1
    stiffness: float = 1.0
    settle_stiffness: float = 0.0

    def __post_init__(self) -> None:
        _require_positive(self, ("damping", "rot_damping"))
        for key in ("deadband_n", "deadband_nm", "filter_s"):
            if not getattr(self, key) >= 0:
                raise ConfigError(f"{key} must be >= 0, got {getattr(self, key)!r}",
                                  field=key)
        for key in ("stiffness", "settle_stiffness"):
            if not 0.0 <= getattr(self, key) <= 1.0:
                raise ConfigError(f"{key} must be in [0, 1], got {getattr(self, key)!r}",
                                  field=key)


@dataclass(frozen=True)
class VariableGains:
    """The variable admittance's parameters beyond the fixed one's (whose ``damping`` and
    ``rot_damping`` are the nominal D_0, D_r0).

    Attributes:
        base: The nominal admittance (D_0, D_r0, deadbands, filter, stiffness).
        min_ratio: The damping never falls below this fraction of D_0.
        max_ratio: ... nor rises above this multiple of it.
        force_ref_n: The push [N] along the motion that halves the damping (torques: x
            ``lever_m``); the same push against the motion doubles it.
        rate_s: Weight [s] of the push's rate of change: a push growing by
            ``force_ref_n / rate_s`` per second counts as much as ``force_ref_n``.
        mass_s: The admittance's time constant M / D [s] (0: no virtual mass).
        lever_m: Metres per radian when torques are compared with forces.
    """

    base: AdmittanceGains = AdmittanceGains()
    min_ratio: float = 0.3
    max_ratio: float = 3.0
    force_ref_n: float = 3.0
    rate_s: float = 0.2
    mass_s: float = 0.1
    lever_m: float = 0.1

    def __post_init__(self) -> None:
        if not 0 < self.min_ratio <= 1 <= self.max_ratio:
            raise ConfigError(f"need 0 < min_ratio <= 1 <= max_ratio, got {self.min_ratio!r}"
                              f", {self.max_ratio!r}", field="min_ratio")
        _require_positive(self, ("force_ref_n", "lever_m"))
        for key in ("rate_s", "mass_s"):
            if not getattr(self, key) >= 0:
                raise ConfigError(f"{key} must be >= 0, got {getattr(self, key)!r}",
                                  field=key)


#: The fixed admittance per scenario, chosen on training episodes (seeds 1000-1003, the
#: default human and the three presets) by ``.venv/bin/python
#: benchmarks/tune_physical_baselines.py --jobs 2 --scenarios hanger,wheel --seeds 4``
#: (docs/physical-baselines.md, "How the parameters were chosen").
TUNED_FIXED: dict[str, AdmittanceGains] = {
    "hanger": AdmittanceGains(damping=6.0, rot_damping=0.3, deadband_n=0.5,
                              settle_stiffness=1.0),
    "wheel": AdmittanceGains(damping=20.0, rot_damping=2.0, settle_stiffness=1.0),
}

#: The variable admittance per scenario, chosen likewise (the same command).
TUNED_VARIABLE: dict[str, VariableGains] = {
    "hanger": VariableGains(TUNED_FIXED["hanger"], min_ratio=0.4, force_ref_n=1.5,
                            rate_s=0.1, mass_s=0.05),
    "wheel": VariableGains(TUNED_FIXED["wheel"], min_ratio=0.4, force_ref_n=0.75,
                           rate_s=0.1, mass_s=0.05),
}


def settle_action(gains: AdmittanceGains) -> np.ndarray:
    """The action once the object was put on a seat: hold still at ``settle_stiffness``."""
    return np.array([0, 0, 0, 0, 0, 0, 2.0 * gains.settle_stiffness - 1.0], dtype=np.float32)


def tuned(table: dict[str, Any], graph: TaskGraph | None) -> Any:
    """``table[graph.name]``: a baseline's tuned parameters for ``graph``'s scenario (the
    tables are keyed by the scenario's name).

    Raises:
        ConfigError: (``field="scenario"``) The table has no such scenario (or ``graph`` is
            None).
    """
    name = "" if graph is None else graph.name
    try:
        return table[name]
    except KeyError:
        raise ConfigError(f"no tuned parameters for scenario {name!r}; allowed: "
                          f"{', '.join(table)}", field="scenario") from None


class FixedAdmittance(PhysicalAgent):
    """A fixed admittance: the object moves at ``v = F / D`` and turns at ``ω = τ / D_r``.

    ``F`` and ``τ`` are the human's wrench as the wrist feels it
    (:class:`~baselines.physical.sensing.HumanWrench`: filtered, without the seat's), each
    beyond its radial deadband. The velocity is tracked with the impedance controller at
    ``gains.stiffness`` (:func:`~baselines.physical.sensing.twist_action`).

    Args:
        scenario: The scenario's task graph, or a registered scenario's name (resolved
            here): its tuned gains, :data:`TUNED_FIXED`, unless ``gains``.
        gains: The admittance's parameters.
    """

    name = "admittance"

    def __init__(self, scenario: TaskGraph | str | None = None,
                 gains: AdmittanceGains | None = None) -> None:
        if gains is None:
            gains = tuned(TUNED_FIXED, None if scenario is None else as_graph(scenario))
        self.gains = gains
        self.task: RobotTask | None = None

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: a fresh wrench filter."""
        self.task = task
        self.wrench = HumanWrench(task, self.gains.filter_s)

    def twist(self, observation: np.ndarray, state: ObjectState
              ) -> tuple[np.ndarray, np.ndarray]:
        """The admittance's twist (v [m/s] of the handle, ω [rad/s]) for ``observation``."""
        g = self.gains
        w = self.wrench.update(observation, state)
        return (deadband(w[:3], g.deadband_n) / g.damping,
                deadband(w[3:], g.deadband_nm) / g.rot_damping)

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Move the object with the admittance's twist."""
        task = self._task()
        state = object_state(task, observation)
        v, omega = self.twist(observation, state)
        if self.wrench.settling:
            return settle_action(self.gains)
        return twist_action(task, state, v, omega, self.gains.stiffness, state.handle)

    def _task(self) -> RobotTask:
        if self.task is None:
            raise RuntimeError(f"{self.name}: begin_episode was not called")
        return self.task


class VariableAdmittance(FixedAdmittance):
    """A variable admittance: ``M v̇ + D v = F`` with the damping read from the human's
    intention (see the module docstring and :meth:`damping`); likewise for rotation.

    Args:
        scenario: The scenario's task graph, or a registered scenario's name (resolved
            here): its tuned gains, :data:`TUNED_VARIABLE`, unless ``gains``.
        gains: The parameters.
    """

    name = "variable-admittance"

    def __init__(self, scenario: TaskGraph | str | None = None,
                 gains: VariableGains | None = None) -> None:
        if gains is None:
            gains = tuned(TUNED_VARIABLE, None if scenario is None else as_graph(scenario))
        self.variable = gains
        super().__init__(gains=gains.base)

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: at rest, nominal damping."""
        super().begin_episode(task)
        self.vel = np.zeros(6)  # (v, ω) of the admittance
        self.last = np.zeros(6)  # the last deadbanded wrench
        self.ratio = np.ones(2)  # D / D_0 and D_r / D_r0 of the last step
        self.mass_alpha = lowpass_alpha(task.dt, self.variable.mass_s)

    def damping(self, push: np.ndarray, last: np.ndarray, motion: np.ndarray, scale: float
                ) -> float:
        """The damping ratio D / D_0 for one part (force or torque) of the wrench.

        With ``u`` the direction of the motion (of the push itself when at rest), the push
        along it ``p = F·u`` and its rate ``ṗ = (F - F_prev)·u / dt``::

            a = max(p, 0) + rate_s max(ṗ, 0)     (they push on, harder: accelerate)
            r = max(-p, 0) + rate_s max(-ṗ, 0)   (they hold back, or let go: decelerate)
            D / D_0 = clip((1 + r / f_ref) / (1 + a / f_ref), min_ratio, max_ratio)

        with ``f_ref`` = ``force_ref_n`` (x ``lever_m`` for torques).

        Args:
            push: (3,) this step's deadbanded force [N] (or torque [N m]).
            last: (3,) the previous step's.
            motion: (3,) the admittance's current velocity (or angular velocity).
            scale: 1 for forces, ``lever_m`` for torques.
        """
        g, dt = self.variable, self._task().dt
        u = unit(motion) if np.linalg.norm(motion) > 1e-4 else unit(push)
        along = float(push.dot(u))
        rate = float((push - last).dot(u)) / dt
        accelerate = max(along, 0.0) + g.rate_s * max(rate, 0.0)
        decelerate = max(-along, 0.0) + g.rate_s * max(-rate, 0.0)
        ref = g.force_ref_n * scale
        return clamp((1.0 + decelerate / ref) / (1.0 + accelerate / ref), g.min_ratio,
                     g.max_ratio)

    def twist(self, observation: np.ndarray, state: ObjectState
              ) -> tuple[np.ndarray, np.ndarray]:
        """The admittance's twist: ``v += (F / D - v) dt / (M / D + dt)`` per part."""
        g, v = self.gains, self.variable
        w = self.wrench.update(observation, state)
        push = np.concatenate([deadband(w[:3], g.deadband_n), deadband(w[3:], g.deadband_nm)])
        self.ratio[0] = self.damping(push[:3], self.last[:3], self.vel[:3], 1.0)
        self.ratio[1] = self.damping(push[3:], self.last[3:], self.vel[3:], v.lever_m)
        target = np.concatenate([push[:3] / (g.damping * self.ratio[0]),
                                 push[3:] / (g.rot_damping * self.ratio[1])])
        self.vel += self.mass_alpha * (target - self.vel)
        self.last = push
        return self.vel[:3].copy(), self.vel[3:].copy()

