"""What the vector envs on MuJoCo Warp share (:class:`WorldsVectorEnv`): N single envs, each
on one world of a shared set stepped together, their arguments' checks, resets, next-step
or same-step autoreset and the batched ``final_obs``. The Panda envs'
(:class:`~hri_envs.physics.panda.warp.vector.PandaVectorEnv`) and the continuous envs'
(:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`) say how a vector step
moves their worlds.
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hri_envs.checks import check_whole
from hri_envs.envs.config import check_autoreset_mode
from hri_envs.errors import ConfigError, ResetNeeded

__all__ = ["WorldsVectorEnv"]

_Obs = TypeVar("_Obs")


class WorldsVectorEnv(VectorEnv[_Obs, np.ndarray, np.ndarray]):
    """N single envs whose worlds are stepped together on MuJoCo Warp (the base of the
    vector envs here; a subclass builds the worlds and ``envs``, then calls
    :meth:`_batch_spaces`; its step calls :meth:`_check_started`, checks the actions and
    moves the worlds between :meth:`_begin_step` and :meth:`_end_step`).

    Attributes:
        envs: The single envs.
        num_envs: N.
    """

    metadata: dict[str, Any] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}
    envs: list[Any]
    _obs: Any  # each env's last observation, indexed by env (set by the subclass)

    def _configure(self, num_envs: int, render_mode: str | None,
                   autoreset_mode: AutoresetMode | str, what: str) -> int:
        """The arguments every vector env here checks alike; returns N.

        Raises:
            ConfigError: A render mode, an unknown autoreset mode or a bad ``num_envs``
                (``what`` names the env in the message).
        """
        if render_mode is not None:
            raise ConfigError(f"the {what} vector env does not render; render_mode must be "
                              f"None, got {render_mode!r}", field="render_mode")
        mode = check_autoreset_mode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": mode}
        self._same_step = mode == AutoresetMode.SAME_STEP
        self.num_envs = n = check_whole(num_envs, "num_envs", minimum=1, maximum=1_000_000)
        self.render_mode = None
        return n

    def _batch_spaces(self, single_action_space: spaces.Space[Any]) -> None:
        """The batched spaces of ``envs`` (built); no episode has started."""
        n = self.num_envs
        self.single_observation_space = self.envs[0].observation_space
        self.single_action_space = single_action_space
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self._ended = np.zeros(n, dtype=bool)
        self._needs_reset = True

    def _observations(self) -> _Obs:
        """The envs' last observations, batched."""
        raise NotImplementedError

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[_Obs, dict[str, Any]]:
        """Start N episodes (env *i* seeded with ``seed + i``)."""
        infos: dict[str, Any] = {}
        for i, env in enumerate(self.envs):
            self._obs[i], info = env.reset(seed=None if seed is None else seed + i,
                                           options=options)
            infos = self._add_info(infos, info, i)
        self._ended[:] = False
        self._needs_reset = False
        return self._observations(), infos

    def _check_started(self) -> None:
        """Raise :class:`~hri_envs.errors.ResetNeeded` before the first :meth:`reset`."""
        if self._needs_reset:
            raise ResetNeeded("call reset() before step()")

    def _begin_step(self) -> tuple[np.ndarray, dict[str, Any]]:
        """A vector step's start (its actions checked): the envs whose episode ended last
        step start anew (next-step autoreset, their infos in the step's); returns (N,) bool,
        the envs that step, and the step's infos so far.
        """
        infos: dict[str, Any] = {}
        if self._same_step:
            return np.ones(self.num_envs, dtype=bool), infos
        for i in np.flatnonzero(self._ended):
            self._obs[i], info = self.envs[i].reset()
            infos = self._add_info(infos, info, int(i))
        return ~self._ended, infos

    def _end_step(self, terminated: np.ndarray, truncated: np.ndarray, infos: dict[str, Any],
                  final: dict[int, Any]) -> None:
        """A vector step's end: the same-step final observations ``final`` (by env) into
        ``infos["final_obs"]`` masked by ``infos["_final_obs"]``; with next-step autoreset,
        the envs that ended.
        """
        n = self.num_envs
        if final:
            final_obs = np.full(n, None, dtype=object)
            mask = np.zeros(n, dtype=bool)
            for i, o in final.items():
                final_obs[i], mask[i] = o, True
            infos["final_obs"], infos["_final_obs"] = final_obs, mask
        if not self._same_step:
            self._ended = terminated | truncated

    def close_extras(self, **kwargs: Any) -> None:
        """Close every env."""
        for env in self.envs:
            env.close()
