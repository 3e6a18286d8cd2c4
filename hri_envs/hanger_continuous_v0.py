"""PettingZoo entry points of the hanger's continuous-control env (whole human arm), version 0.

``parallel_env(**kwargs)`` is the two-agent parallel env
(:class:`~hri_envs.physics.carry.parallel.CarryParallelEnv` with ``scenario="hanger"``;
see :class:`~hri_envs.physics.carry.env.CarryEnv` for the keyword arguments) and
``env(**kwargs)`` its AEC form (PettingZoo's ``parallel_to_aec``). The single-agent
Gymnasium form is registered as ``hri_envs/HangerPandaContinuous-v0``.
"""

from hri_envs.physics.carry.parallel import entry_points

__all__ = ["env", "parallel_env"]

env, parallel_env = entry_points("hanger")
