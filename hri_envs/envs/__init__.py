"""The environments: two-agent PettingZoo, robot-only Gymnasium, and its batched vector form.

The physics backend (``backend="mujoco"``) lives in :mod:`hri_envs.physics`.

=========================  ==========================================================
module                     contents
=========================  ==========================================================
``parallel``               :class:`CooperationParallelEnv` (PettingZoo, human + robot)
``robot``                  :class:`RobotEnv` (Gymnasium, robot vs a scripted human)
``vector``                 :class:`RobotVectorEnv` (N robot envs stepped in numpy)
``vector_inputs``          the vector env's checks of its backend, reset options, actions
``aec``                    the turn-based (AEC) form of the parallel env
``partner``                :class:`PartnerEnv` (Gymnasium, one seat, a fixed partner)
``formats``                the "classic"/"flat" observation formats, human rewards
``window``                 ``render_mode="human"``: the window and the display check
``episode``                the episode rules shared by all of them, as lookup tables
``spaces``                 observation/action spaces and the action check
``config``                 scenarios, defaults and validation of arguments and options
``render``                 ``ansi`` text and the numpy-drawn ``rgb_array`` side view
``speed``                  throughput measurements (``hri-bench speed``)
=========================  ==========================================================
"""

from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.envs.partner import PartnerEnv
from hri_envs.envs.robot import RobotEnv
from hri_envs.envs.vector import RobotVectorEnv

__all__ = [
    "CooperationParallelEnv",
    "PartnerEnv",
    "RobotEnv",
    "RobotVectorEnv",
]
