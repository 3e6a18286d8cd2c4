"""The environments: two-agent PettingZoo, robot-only Gymnasium, and its batched vector form.

The physics backend (``backend="mujoco"``) lives in :mod:`hri_envs.physics`.

=========================  ==========================================================
module                     contents
=========================  ==========================================================
``parallel``               :class:`CooperationParallelEnv` (PettingZoo, human + robot)
``robot``                  :class:`RobotEnv` (Gymnasium, robot vs a scripted human)
``vector``                 :class:`RobotVectorEnv` (N robot envs stepped in numpy)
``aec``                    the turn-based (AEC) form of the parallel env
``episode``                the episode rules shared by all of them, as lookup tables
``spaces``                 observation/action spaces and the action check
``config``                 scenarios, defaults and validation of arguments and options
``render``                 ``ansi`` text and the numpy-drawn ``rgb_array`` side view
``speed``                  throughput measurements (``hri-bench speed``)
``rollout``                :func:`run_episode`: any protocol agent in a robot env
``errors``                 the exceptions
=========================  ==========================================================
"""

from hri_envs.envs.errors import ActionError, BackendUnavailableError, ConfigError, HriEnvError
from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.envs.robot import RobotEnv
from hri_envs.envs.vector import RobotVectorEnv

__all__ = [
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "CooperationParallelEnv",
    "HriEnvError",
    "RobotEnv",
    "RobotVectorEnv",
]
