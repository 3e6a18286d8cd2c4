"""The agents' observation and action spaces, and the action check every env applies."""

from __future__ import annotations

import operator
from typing import Any

import numpy as np
from gymnasium import spaces

from hri_envs.errors import ActionError

__all__ = ["check_action", "human_observation_space", "robot_observation_space"]


def robot_observation_space(n_states: int, n_supports: int, n_actions: int) -> spaces.Dict:
    """What the robot observes: state, start support, the human's last action, valid actions."""
    return spaces.Dict(
        {
            "state": spaces.Discrete(n_states),
            "start": spaces.Discrete(n_supports),
            "last_human_action": spaces.Discrete(n_actions),
            "action_mask": spaces.Box(0, 1, (n_actions,), np.int8),
        }
    )


def human_observation_space(n_states: int, n_supports: int, n_actions: int) -> spaces.Dict:
    """What the human observes: the robot's observation plus the intention ι."""
    robot = robot_observation_space(n_states, n_supports, n_actions)
    return spaces.Dict({**robot.spaces, "intention": spaces.Discrete(n_supports)})


def check_action(agent: str, action: Any, n_actions: int) -> int:
    """``action`` as an int in ``0 .. n_actions - 1``, else an :class:`ActionError`.

    Booleans are refused although Python counts them as integers: ``True`` for "grasp"
    (action 1) is almost always a bug in the caller.
    """
    if isinstance(action, bool | np.bool_):
        raise ActionError(
            f"{agent} action {action!r} is a bool; the {agent}'s action space is "
            f"Discrete({n_actions}): integers 0..{n_actions - 1}"
        )
    if type(action) is not int:
        try:
            action = operator.index(action)
        except TypeError:
            raise ActionError(
                f"{agent} action {action!r} is not an integer; the {agent}'s action space is "
                f"Discrete({n_actions}): integers 0..{n_actions - 1}"
            ) from None
    if not 0 <= action < n_actions:
        raise ActionError(
            f"{agent} action {action} is outside the {agent}'s action space "
            f"Discrete({n_actions}): valid actions are 0..{n_actions - 1}"
        )
    return action
