"""PettingZoo entry points of the wheel's continuous-control env (whole human arm), version 1.

Version 1's reward pays for placing the object at the human's goal, and its ``info`` holds
nothing derived from the intention during an episode
(:class:`~hri_envs.physics.carry.env.CarryEnv`, "Version History"). ``parallel_env(**kwargs)``
is the two-agent parallel env (:class:`~hri_envs.physics.carry.parallel.CarryParallelEnv`
with ``scenario="wheel"``, ``version=1``) and ``env(**kwargs)`` its AEC form. The
single-agent Gymnasium form is registered as ``hri_envs/WheelPandaContinuous-v1``.
"""

from hri_envs.physics.carry.parallel import entry_points

__all__ = ["env", "parallel_env"]

env, parallel_env = entry_points("wheel", version=1)
