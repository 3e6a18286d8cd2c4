"""Action and grasp codes shared by the task graph and the episode rules.

Actions (paper Table 1) have one global numbering for both agents::

    0 wait | 1 grasp/let go | 2 take off | 3 put on | 4 rotate
    5 .. 5+K-1     move over to column k
    5+K .. 5+K+H-1 move (up or down) to height h

Grasp codes μ are two bits: bit 0 the human holds, bit 1 the robot holds.
"""

from __future__ import annotations

__all__ = [
    "BOTH",
    "GRASP_NAMES",
    "HUMAN_BIT",
    "N_FIXED_ACTIONS",
    "PUT_ON",
    "ROBOT_BIT",
    "ROTATE",
    "TAKE_OFF",
    "TOGGLE",
    "WAIT",
]

WAIT, TOGGLE, TAKE_OFF, PUT_ON, ROTATE = 0, 1, 2, 3, 4
#: Actions before the "move over to k" block; every action from TAKE_OFF on is a motion.
N_FIXED_ACTIONS = 5
HUMAN_BIT, ROBOT_BIT, BOTH = 1, 2, 3
GRASP_NAMES = ("held by nobody", "held by the human", "held by the robot", "held by both")
