"""How a continuous step ends badly on the C backend: what
:class:`~hri_envs.physics.carry.sim.CarrySim` measures for the end-of-step rules of
:mod:`~hri_envs.physics.carry.rules` (one world: the object dropped, the simulation diverged,
the handle slipped out of the human's hand), the reasons it gives, and the arm's greatest
lift in its posture.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from hri_envs.physics.carry import rules
from hri_envs.physics.carry.rules import DROP_BELOW_M, SLIP_M, SLIP_RAD
from hri_envs.physics.scene.contacts import touches

if TYPE_CHECKING:
    from hri_envs.physics.carry.periods import PeriodsResult
    from hri_envs.physics.carry.sim import CarrySim

__all__ = ["DROP_BELOW_M", "SLIP_M", "SLIP_RAD", "check_faults", "max_lift_n", "why_slipped"]


def check_faults(sim: CarrySim, pos: np.ndarray, res: PeriodsResult) -> str | None:
    """The fault of a step (:func:`~hri_envs.physics.carry.rules.fault_codes`) whose
    control periods ended with the object at ``pos``, or None: dropped, not finite, or the
    handle slipped out of the human's hand (then they no longer hold it).
    """
    off, angle, codes = np.array([res.off]), np.array([res.angle]), np.empty(1, np.int64)
    rules.fault_codes(np.array([touches(sim.data, sim.scene.floor_geom)]), pos[2:3],
                      np.array([sim.lowest_z]), np.array([res.finite]), off, angle, codes)
    if codes[0] == rules.FAULT_SLIPPED:
        sim.human_holds = False
    return rules.fault_messages(codes, off, angle, np.array([sim.robot_holds]),
                                lambda _: why_slipped(sim))[0]


def why_slipped(sim: CarrySim) -> str:
    """Why the handle slipped or the human cannot carry alone
    (:func:`~hri_envs.physics.carry.rules.slip_reason`): the arm's greatest lift against the
    object's weight, or the grip force; the joints at their strength limit.
    """
    return rules.slip_reason(sim.robot_holds, max_lift_n(sim), sim.design.object_mass * 9.81,
                             float(sim.model.actuator_forcerange[sim.arm.fingers, 1]),
                             sim.joint_names(), sim.sat_counts)


def max_lift_n(sim: CarrySim) -> float:
    """The largest upward force [N] the hand can hold statically in the current posture
    within the human's strength: min over joints of limit / |(Jᵀ ẑ)_j| (0 if a joint
    that must resist has no strength).
    """
    m, data = sim.model, sim.data
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jacSite(m, data, jacp, None, sim.arm.grip_site)
    c = sim.coupling.update(data)
    moment = jacp[2, sim.coupling.dofs].dot(c)  # (n,) torque per N of upward force
    lim = np.minimum(-sim.arm_drive.lo, sim.arm_drive.hi)
    with np.errstate(divide="ignore"):
        ratio = np.where(np.abs(moment) > 1e-9, lim / np.abs(moment), np.inf)
    return float(ratio.min())
