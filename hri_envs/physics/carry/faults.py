"""How a continuous step ends badly: :class:`~hri_envs.physics.carry.sim.CarrySim`'s checks at
the end of a step (the object dropped, the simulation diverged, the handle slipped out of
the human's hand), the reasons it gives, and the arm's greatest lift in its posture.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from hri_envs.physics.scene.contacts import touches

if TYPE_CHECKING:
    from hri_envs.physics.carry.periods import PeriodsResult
    from hri_envs.physics.carry.sim import CarrySim

__all__ = ["DROP_BELOW_M", "SLIP_M", "SLIP_RAD", "CarryFault", "check_faults", "max_lift_n",
           "why_slipped"]

#: [m], [rad]: the handle has left the hand when this far off, or turned, from its grip.
SLIP_M, SLIP_RAD = 0.03, 0.5
#: [m] the object this far below the lowest support point: dropped.
DROP_BELOW_M = 0.15


class CarryFault(Exception):
    """A step's fault: ``"<kind>: <detail>"``."""


def check_faults(sim: CarrySim, pos: np.ndarray, res: PeriodsResult) -> None:
    """Raise :class:`CarryFault` if the object at ``pos`` dropped, the state is not finite
    or the handle slipped out of the human's hand (then they no longer hold it).
    """
    data, sc = sim.data, sim.scene
    if touches(data, sc.floor_geom) or pos[2] < sim.lowest_z - DROP_BELOW_M:
        raise CarryFault("dropped: the object " + ("hit the floor" if touches(
            data, sc.floor_geom) else "fell below every support"))
    if not res.finite:
        raise CarryFault("unstable: the simulation diverged")
    off, angle = res.off, res.angle
    if off > SLIP_M or angle > SLIP_RAD:
        sim.human_holds = False
        why = why_slipped(sim)
        kind = "slipped" if sim.robot_holds else "dropped"
        raise CarryFault(f"{kind}: the handle slipped out of the human's hand "
                         f"({off * 100:.1f} cm, {math.degrees(angle):.0f}° off); {why}")


def why_slipped(sim: CarrySim) -> str:
    """Why the handle slipped or the human cannot carry alone: the arm's greatest lift
    against the object's weight, or the grip force; the joints at their strength limit.
    """
    sat = [n for n, c in zip(sim.joint_names(), sim.sat_counts, strict=True) if c > 0]
    weight = sim.design.object_mass * 9.81
    lift = max_lift_n(sim)
    if not sim.robot_holds and lift < weight:
        return (f"the arm can lift at most {lift:.1f} N here, the object weighs "
                f"{weight:.1f} N (joints at their strength limit: "
                f"{', '.join(sat) or 'none'})")
    return (f"grip force {sim.model.actuator_forcerange[sim.arm.fingers, 1]:.1f} N; "
            f"joints at their strength limit: {', '.join(sat) or 'none'}")


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
