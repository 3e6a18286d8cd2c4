"""AEC (turn-based) views of the parallel env, as PettingZoo's versioned modules export them."""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.env import AECEnv
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from hri_envs.envs.parallel import CooperationParallelEnv

__all__ = ["make_aec_env", "make_raw_aec_env"]


def make_raw_aec_env(scenario: str, **kwargs: Any) -> AECEnv:
    """The AEC env without wrappers: the human acts first, then the robot, then the step."""
    return parallel_to_aec_wrapper(CooperationParallelEnv(scenario, **kwargs))


def make_aec_env(scenario: str, **kwargs: Any) -> AECEnv:
    """The AEC env with PettingZoo's order-enforcing wrapper.

    The other classic wrappers do not fit: out-of-space actions already raise a
    ``ValueError`` (``AssertOutOfBoundsWrapper`` would raise an ``AssertionError`` first),
    and masked actions are legal aborted steps (so no ``TerminateIllegalWrapper``).
    """
    return OrderEnforcingWrapper(make_raw_aec_env(scenario, **kwargs))
