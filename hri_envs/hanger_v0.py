"""PettingZoo entry points of the hanger scenario, version 0.

``parallel_env(**kwargs)`` is the native two-agent env
(:class:`~hri_envs.envs.parallel.CooperationParallelEnv` with ``scenario="hanger"``; see
it for the keyword arguments), ``raw_env(**kwargs)`` its unwrapped AEC form and
``env(**kwargs)`` the AEC form with the order-enforcing wrapper.
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.env import AECEnv

from hri_envs.envs.aec import make_aec_env, make_raw_aec_env
from hri_envs.envs.parallel import CooperationParallelEnv

__all__ = ["env", "parallel_env", "raw_env"]


def parallel_env(**kwargs: Any) -> CooperationParallelEnv:
    """The hanger as a PettingZoo ``ParallelEnv`` with agents "human" and "robot"."""
    return CooperationParallelEnv("hanger", **kwargs)


def raw_env(**kwargs: Any) -> AECEnv:
    """The hanger as an AEC env, without wrappers."""
    return make_raw_aec_env("hanger", **kwargs)


def env(**kwargs: Any) -> AECEnv:
    """The hanger as an AEC env with the order-enforcing wrapper."""
    return make_aec_env("hanger", **kwargs)
