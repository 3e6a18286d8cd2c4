"""Reading MuJoCo's contacts: what touches the floor, how hard the fingers press on the grip.

The scene (:mod:`hri_envs.physics.scene.build`) lets only the intended pairs collide: the object
with the floor and the supports, the finger pads with the object's grip geometry. These
helpers read the active contacts of ``MjData`` (after ``mj_step``/``mj_forward``) for the
simulation's rules: the object dropped when it touches the floor, a grasp holds only when
both fingers press on the grip.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["finger_forces", "touches"]


def touches(data: mujoco.MjData, geom: int) -> bool:
    """Whether any active contact involves ``geom``."""
    if data.ncon == 0:
        return False
    return bool((data.contact.geom == geom).any())


def finger_forces(model: mujoco.MjModel, data: mujoco.MjData, finger_geoms: np.ndarray,
                  grip_geom: int) -> np.ndarray:
    """Normal contact force [N] of each finger on the grip geometry.

    Args:
        model: The compiled scene.
        data: Its state (contacts computed).
        finger_geoms: (2, n) geom ids of the left and right finger pads.
        grip_geom: Geom id of the object's grip.

    Returns:
        (2,) the summed normal force of the left and of the right finger's contacts with
        the grip (0 for a finger that does not touch it).
    """
    out = np.zeros(2)
    if data.ncon == 0:
        return out
    pairs = data.contact.geom  # (ncon, 2)
    wrench = np.zeros(6)
    for i in np.flatnonzero((pairs == grip_geom).any(axis=1)):
        other = pairs[i, 0] if pairs[i, 1] == grip_geom else pairs[i, 1]
        for side in range(2):
            if other in finger_geoms[side]:
                mujoco.mj_contactForce(model, data, int(i), wrench)
                out[side] += abs(wrench[0])  # the contact frame's x axis is the normal
    return out
