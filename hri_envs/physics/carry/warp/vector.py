"""N continuous-control envs stepped together on MuJoCo Warp: :class:`CarryVectorEnv`."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode

from hri_envs.envs.backends import carry_backend
from hri_envs.errors import ActionError, ConfigError
from hri_envs.physics.carry.env import ACTION_SIZE, CarryEnv, check_sensor, check_step_scale
from hri_envs.physics.carry.warp.sim import SHARED, WarpCarrySim
from hri_envs.physics.carry.warp.worlds import WarpCarryWorlds
from hri_envs.physics.scene.design import physical_graph
from hri_envs.physics.scene.warp.vector_base import WorldsVectorEnv

__all__ = ["CarryVectorEnv"]


class CarryVectorEnv(WorldsVectorEnv[np.ndarray]):
    """``num_envs`` copies of the continuous-control env
    (:class:`~hri_envs.physics.carry.env.CarryEnv`), their worlds stepped together on MuJoCo
    Warp.

    ## Description

    The robot carries the object with the simulated whole human arm, N episodes at once:
    every env is a :class:`~hri_envs.physics.carry.env.CarryEnv` on the ``"mjwarp"``
    backend whose world is one of the N worlds of a shared
    :class:`~hri_envs.physics.carry.warp.worlds.WarpCarryWorlds`; a vector step turns every
    robot action into its command, simulates the 40 ms of all the worlds together and hands
    each env its outcome. Made by ``gymnasium.make_vec("hri_envs/HangerPandaContinuous-v0",
    num_envs=N, vectorization_mode="vector_entry_point")`` (likewise
    ``WheelPandaContinuous-v0``).

    ## Action Space

    ``Box(-1, 1, (N, 7), float32)``: one robot action per env (the single env's).

    ## Observation Space

    ``Box(-inf, inf, (N, obs), float32)``: the single env's observations, stacked.

    ## Rewards

    (N,) float64, the single env's; 0 in the step that autoresets an env.

    ## Starting State

    As the single env; ``reset(seed=s)`` seeds env *i* with ``s + i`` (as Gymnasium's sync
    vector env does), ``options`` are handed to every env. A reset places the arms by the C
    backend's IK (one C reset per env).

    ## Episode End

    As the single env. Autoreset: next-step by default (the step after an episode ends
    ignores that env's action and returns the first observation of a new episode, reward
    0, neither terminated nor truncated), or ``autoreset_mode=AutoresetMode.SAME_STEP``
    (the final observation in ``infos["final_obs"]``, masked by ``infos["_final_obs"]``).
    The single env's ``info`` keys are batched with Gymnasium's ``_key`` masks.

    ## Arguments

    - ``num_envs``: the number of envs (and worlds) N;
    - ``scenario`` and the single env's arguments (``drive``, ``human``, ``max_time_s``,
      ``reward``, ``sensor``, ``max_step_m``, ``max_step_rad``), the same for every env;
    - ``backend``: must be ``"mjwarp"``; ``drive``: ``"torque"`` only;
    - ``device``: Warp's device (default: Warp's default, a GPU where there is one);
    - ``render_mode``: must be None;
    - ``autoreset_mode``: ``AutoresetMode.NEXT_STEP`` (default) or ``SAME_STEP``.

    ## Version History

    - v0: initial version.
    """

    def __init__(self, num_envs: int = 1, scenario: str = "hanger", *,
                 backend: str = "mjwarp", device: str | None = None,
                 render_mode: str | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 drive: str = "torque", **kwargs: Any) -> None:
        graph = physical_graph(scenario)
        if backend != "mjwarp":
            raise ConfigError(f"the continuous vector env runs on MuJoCo Warp; backend must be "
                              f"'mjwarp', got {backend!r}", field="backend")
        n = self._configure(num_envs, render_mode, autoreset_mode, "continuous")
        self.backend = backend
        carry_backend(backend, drive)  # the drive runs here (else a clear error)
        check_step_scale(kwargs.get("max_step_m", 0.02), kwargs.get("max_step_rad", 0.06))
        check_sensor(kwargs.get("sensor"))
        self.worlds = WarpCarryWorlds(graph, n, drive,
                                      max_step_m=kwargs.get("max_step_m", 0.02),
                                      max_step_rad=kwargs.get("max_step_rad", 0.06),
                                      sensor=kwargs.get("sensor"), device=device)
        with SHARED.sharing([WarpCarrySim(self.worlds, i) for i in range(n)]):
            self.envs: list[CarryEnv] = [
                CarryEnv(scenario, backend="mjwarp", drive=drive, **kwargs) for _ in range(n)]
        self._batch_spaces(self.envs[0].action_space)
        self._obs = np.zeros((n, self.envs[0].n_obs), dtype=np.float32)

    def _observations(self) -> np.ndarray:
        return self._obs.copy()

    def _actions(self, actions: Any) -> np.ndarray:
        n = self.num_envs
        try:
            given = np.asarray(actions)  # numbers only: no str parsed, no complex cut
            a = given.astype(np.float64) if given.dtype.kind in "iuf" else None
        except (TypeError, ValueError):
            a = None
        if a is None or a.shape != (n, ACTION_SIZE) or not np.all(np.isfinite(a)) \
                or np.any(np.abs(a) > 1.0 + 1e-6):
            raise ActionError(f"the robots' actions must be an array of shape ({n}, "
                              f"{ACTION_SIZE}) of finite numbers in [-1, 1]; got "
                              f"{getattr(a, 'shape', type(actions).__name__)}")
        return np.clip(a, -1.0, 1.0)

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          dict[str, Any]]:
        """Every env's robot acts for 40 ms; the worlds move together."""
        self._check_started()
        a = self._actions(actions)
        n = self.num_envs
        stepping, infos = self._begin_step()
        rewards = np.zeros(n)
        terminated, truncated = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        sim_active = stepping & np.array([env._fault is None for env in self.envs])
        rows = np.flatnonzero(sim_active)
        results = self.worlds.step(self.worlds.commands(rows, a[rows]), sim_active)
        ended: list[int] = []
        for i in np.flatnonzero(stepping):
            env, res = self.envs[i], results[i]
            out = env._after(res) if res is not None else env.step(a[i])
            self._obs[i], rewards[i], terminated[i], truncated[i], info = out
            infos = self._add_info(infos, info, int(i))
            if terminated[i] or truncated[i]:
                ended.append(int(i))
        final: dict[int, np.ndarray] = {}
        if self._same_step:
            final = {e: self._obs[e].copy() for e in ended}  # before the new episodes
            for e in ended:
                self._obs[e], _ = self.envs[e].reset()
        self._end_step(terminated, truncated, infos, final)
        return self._obs.copy(), rewards, terminated, truncated, infos
