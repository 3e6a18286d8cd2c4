"""The PettingZoo entry points of a scenario: the parallel env and its AEC (turn-based) views,
as PettingZoo's versioned modules export them (:func:`entry_points`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.env import AECEnv
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from hri_envs.envs.parallel import CooperationParallelEnv
from hri_envs.errors import ActionError, ResetNeeded

__all__ = ["CooperationAECEnv", "entry_points", "make_aec_env", "make_raw_aec_env"]


class CooperationAECEnv(parallel_to_aec_wrapper):
    """PettingZoo's AEC view of :class:`~hri_envs.envs.parallel.CooperationParallelEnv`
    (``parallel_to_aec_wrapper``), with the library's errors for a step out of turn.

    Raises (from :meth:`step`):
        ResetNeeded: ``step()`` before ``reset()`` or after the episode ended (no agent
            left), where PettingZoo's converter raises ``AttributeError`` or
            ``KeyError: 'robot'``.
        ActionError: An action other than None for an agent whose episode has ended
            (PettingZoo's "dead step" takes None), where the converter asserts.
    """

    def step(self, action: Any) -> None:
        """Collect ``action`` for :attr:`agent_selection`; the last agent's steps the env."""
        if not getattr(self, "agents", None) or not hasattr(self, "terminations"):
            raise ResetNeeded()
        agent = self.agent_selection
        if (self.terminations[agent] or self.truncations[agent]) and action is not None:
            raise ActionError(f"the episode of {agent!r} has ended: step it with None "
                              f"(PettingZoo's dead step), got {action!r}")
        super().step(action)


def make_raw_aec_env(scenario: str, **kwargs: Any) -> AECEnv:
    """The AEC env without wrappers: the human acts first, then the robot, then the step
    (:class:`CooperationAECEnv`).
    """
    return CooperationAECEnv(CooperationParallelEnv(scenario, **kwargs))


def make_aec_env(scenario: str, **kwargs: Any) -> AECEnv:
    """The AEC env with PettingZoo's order-enforcing wrapper.

    The other classic wrappers do not fit: out-of-space actions already raise a
    ``ValueError`` (``AssertOutOfBoundsWrapper`` would raise an ``AssertionError`` first),
    and masked actions are legal aborted steps (so no ``TerminateIllegalWrapper``).
    """
    return OrderEnforcingWrapper(make_raw_aec_env(scenario, **kwargs))


def entry_points(scenario: str) -> tuple[Callable[..., AECEnv], Callable[..., AECEnv],
                                         Callable[..., CooperationParallelEnv]]:
    """``env``, ``raw_env`` and ``parallel_env`` of a versioned module for ``scenario``.

    ``parallel_env(**kwargs)`` is the native two-agent env (see
    :class:`~hri_envs.envs.parallel.CooperationParallelEnv` for the keyword arguments),
    ``raw_env(**kwargs)`` its unwrapped AEC form and ``env(**kwargs)`` the AEC form with the
    order-enforcing wrapper.
    """

    def parallel_env(**kwargs: Any) -> CooperationParallelEnv:
        return CooperationParallelEnv(scenario, **kwargs)

    def raw_env(**kwargs: Any) -> AECEnv:
        return make_raw_aec_env(scenario, **kwargs)

    def env(**kwargs: Any) -> AECEnv:
        return make_aec_env(scenario, **kwargs)

    parallel_env.__doc__ = (f"The {scenario} as a PettingZoo ``ParallelEnv`` with agents "
                            "\"human\" and \"robot\".")
    raw_env.__doc__ = f"The {scenario} as an AEC env, without wrappers."
    env.__doc__ = f"The {scenario} as an AEC env with the order-enforcing wrapper."
    return env, raw_env, parallel_env
