"""PettingZoo entry points of the wheel scenario, version 0.

``parallel_env(**kwargs)`` is the native two-agent env
(:class:`~hri_envs.envs.parallel.CooperationParallelEnv` with ``scenario="wheel"``; see it for
the keyword arguments), ``raw_env(**kwargs)`` its unwrapped AEC form and ``env(**kwargs)``
the AEC form with the order-enforcing wrapper.
"""

from hri_envs.envs.aec import entry_points

__all__ = ["env", "parallel_env", "raw_env"]

env, raw_env, parallel_env = entry_points("wheel")
