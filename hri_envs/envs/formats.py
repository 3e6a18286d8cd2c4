"""Observation formats and the human's reward options of the environments.

Three observation formats (docs/environments.md, "Observation formats"):

- ``"dict"`` (default, v0): each agent observes a ``Dict`` of discrete entries; the human's
  has the intention ι, the robot's has not, so the two agents' spaces differ.
- ``"classic"``: PettingZoo's classic-games layout. Every agent observes
  ``{"observation": Box(0, 1, (N,), float32), "action_mask": Box(0, 1, (A,), int8)}`` with
  the *same* space for both agents, so that clients which need one space for all agents
  (SuperSuit's vector envs, Tianshou, TorchRL, RLlib's default modules) work unchanged.
  The observation vector is the concatenation, N = S + K + A + K + 1:

  ============================  =====  ==============================================
  slice                         size   content
  ============================  =====  ==============================================
  ``[0, S)``                    S      one-hot abstract state
  ``[S, S+K)``                  K      one-hot start support
  ``[S+K, S+K+A)``              A      one-hot last human action (as this agent sees it)
  ``[S+K+A, S+2K+A)``           K      one-hot intention ι; all zeros for the robot
  ``S+2K+A``                    1      1.0 when ι is absent (the robot), else 0.0
  ============================  =====  ==============================================

- ``"flat"``: one ``Box(0, 1, (N + A,), float32)`` per agent, the classic vector followed by
  the action mask as 0.0/1.0, the same space for both agents. For clients that take Box
  observations only, such as SuperSuit's ``pad_observations_v0`` and vector-env conversions
  (which reject ``Dict`` spaces) feeding an MLP policy; the mask is then an input, not a
  constraint.

Two human rewards: ``"cooperation"`` (default, v0) pays the human the robot cooperation
reward R_R, as the robot; ``"goal"`` pays the human its own task reward, see
:func:`hri_envs.task.episode.goal_reward`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from hri_envs.errors import ConfigError

__all__ = [
    "HUMAN_REWARDS",
    "OBSERVATION_FORMATS",
    "ClassicLayout",
    "check_human_reward",
    "check_observation_format",
]

#: The values of ``observation_format`` (the first is the default).
OBSERVATION_FORMATS: tuple[str, ...] = ("dict", "classic", "flat")
#: The values of ``human_reward`` (the first is the default).
HUMAN_REWARDS: tuple[str, ...] = ("cooperation", "goal")


def check_observation_format(value: Any) -> str:
    """Validate ``observation_format`` (one of :data:`OBSERVATION_FORMATS`)."""
    if not isinstance(value, str) or value not in OBSERVATION_FORMATS:
        raise ConfigError(
            f"unknown observation_format {value!r}; allowed: "
            f"{', '.join(map(repr, OBSERVATION_FORMATS))}",
            field="observation_format",
        )
    return value


def check_human_reward(value: Any) -> str:
    """Validate ``human_reward`` (one of :data:`HUMAN_REWARDS`)."""
    if not isinstance(value, str) or value not in HUMAN_REWARDS:
        raise ConfigError(
            f"unknown human_reward {value!r}; allowed: {', '.join(map(repr, HUMAN_REWARDS))}",
            field="human_reward",
        )
    return value


class ClassicLayout:
    """The ``"classic"`` (or ``"flat"``) observation of a scenario: space, encoder, decoder.

    Args:
        n_states: S, the number of abstract states.
        n_supports: K, the number of supports (= intentions).
        n_actions: A, the number of actions.
        flat: Encode as the ``"flat"`` format (one vector, the mask appended).

    Attributes:
        size: N = S + 2 K + A + 1, the length of the observation vector.
        space: The observation space shared by both agents.
    """

    def __init__(self, n_states: int, n_supports: int, n_actions: int,
                 flat: bool = False) -> None:
        self.n_states, self.n_supports, self.n_actions = n_states, n_supports, n_actions
        self._start = n_states
        self._last = n_states + n_supports
        self._goal = self._last + n_actions
        self._absent = self._goal + n_supports
        self.size = self._absent + 1
        self.flat = flat
        self.space: spaces.Space[Any] = spaces.Dict({
            "observation": spaces.Box(0.0, 1.0, (self.size,), np.float32),
            "action_mask": spaces.Box(0, 1, (n_actions,), np.int8),
        })
        if flat:
            self.space = spaces.Box(0.0, 1.0, (self.size + n_actions,), np.float32)

    def encode(self, state: int, start: int, last_human: int, intention: int | None,
               mask: np.ndarray) -> Any:
        """One agent's observation; ``intention=None`` for the robot (ι absent).

        Args:
            state: The abstract state.
            start: The start support.
            last_human: The human's last action as this agent observes it.
            intention: ι (the human), or None (the robot).
            mask: (A,) int8, the valid actions; copied.

        Returns:
            ``{"observation": (N,) float32, "action_mask": (A,) int8}``, or for ``flat`` the
            (N + A,) float32 concatenation.
        """
        vec = np.zeros(self.size + self.n_actions if self.flat else self.size, np.float32)
        vec[state] = vec[self._start + start] = vec[self._last + last_human] = 1.0
        vec[self._absent if intention is None else self._goal + intention] = 1.0
        if self.flat:
            vec[self.size:] = mask
            return vec
        return {"observation": vec, "action_mask": mask.copy()}

    def decode(self, observation: np.ndarray) -> dict[str, int | None]:
        """The entries of an observation vector (the inverse of :meth:`encode`).

        Args:
            observation: (N,) the ``"observation"`` entry, or a (N + A,) ``"flat"`` one.

        Returns:
            ``state``, ``start``, ``last_human_action`` as ints, ``intention`` an int or
            None when absent.
        """
        vec = np.asarray(observation)
        if vec.shape not in ((self.size,), (self.size + self.n_actions,)):
            raise ConfigError(f"a classic observation of this scenario has shape "
                              f"({self.size},), a flat one ({self.size + self.n_actions},); "
                              f"got {vec.shape}", field="observation")
        absent = vec[self._absent] > 0.5
        return {
            "state": int(np.argmax(vec[:self._start])),
            "start": int(np.argmax(vec[self._start:self._last])),
            "last_human_action": int(np.argmax(vec[self._last:self._goal])),
            "intention": None if absent else int(np.argmax(vec[self._goal:self._absent])),
        }
