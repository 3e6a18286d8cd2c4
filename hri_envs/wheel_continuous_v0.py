"""PettingZoo entry points of the wheel's continuous-control env (whole human arm), version 0.

``parallel_env(**kwargs)`` is the two-agent parallel env
(:class:`~hri_envs.physics.continuous_parallel.CarryParallelEnv` with ``scenario="wheel"``;
see :class:`~hri_envs.physics.continuous.CarryEnv` for the keyword arguments) and
``env(**kwargs)`` its AEC form (PettingZoo's ``parallel_to_aec``). The single-agent
Gymnasium form is registered as ``hri_envs/WheelPandaContinuous-v0``.
"""

from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec
from pettingzoo.utils.env import AECEnv

from hri_envs.physics.continuous_parallel import CarryParallelEnv

__all__ = ["env", "parallel_env"]


def parallel_env(**kwargs: Any) -> CarryParallelEnv:
    """The parallel env of the wheel (keyword arguments: ``CarryEnv``'s)."""
    return CarryParallelEnv("wheel", **kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The AEC form of :func:`parallel_env`."""
    return parallel_to_aec(parallel_env(**kwargs))
