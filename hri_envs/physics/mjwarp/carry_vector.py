"""N continuous-control envs stepped together on MuJoCo Warp: :class:`CarryVectorEnv`."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hri_envs.checks import check_whole
from hri_envs.envs.backends import carry_backend
from hri_envs.envs.config import check_autoreset_mode
from hri_envs.errors import ActionError, ConfigError, ResetNeeded
from hri_envs.physics.continuous import ACTION_SIZE, CarryEnv, check_sensor, check_step_scale
from hri_envs.physics.mjwarp.carry import WarpCarryWorlds
from hri_envs.physics.mjwarp.carry_sim import SHARED, WarpCarrySim
from hri_envs.task.scenarios import scenario_graph, scenario_spec

__all__ = ["CarryVectorEnv"]


class CarryVectorEnv(VectorEnv[np.ndarray, np.ndarray, np.ndarray]):
    """``num_envs`` copies of the continuous-control env
    (:class:`~hri_envs.physics.continuous.CarryEnv`), their worlds stepped together on MuJoCo
    Warp.

    ## Description

    The robot carries the object with the simulated whole human arm, N episodes at once:
    every env is a :class:`~hri_envs.physics.continuous.CarryEnv` on the ``"mjwarp"``
    backend whose world is one of the N worlds of a shared
    :class:`~hri_envs.physics.mjwarp.carry.WarpCarryWorlds`; a vector step turns every
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

    metadata: dict[str, Any] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, scenario: str = "hanger", *,
                 backend: str = "mjwarp", device: str | None = None,
                 render_mode: str | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 drive: str = "torque", **kwargs: Any) -> None:
        if scenario_spec(scenario).physics_design is None:
            raise ConfigError(f"scenario {scenario!r} has no physical design; allowed: "
                              "hanger, wheel", field="scenario")
        if backend != "mjwarp":
            raise ConfigError(f"the continuous vector env runs on MuJoCo Warp; backend must be "
                              f"'mjwarp', got {backend!r}", field="backend")
        if render_mode is not None:
            raise ConfigError(f"the continuous vector env does not render; render_mode must "
                              f"be None, got {render_mode!r}", field="render_mode")
        mode = check_autoreset_mode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": mode}
        self._same_step = mode == AutoresetMode.SAME_STEP
        self.num_envs = n = check_whole(num_envs, "num_envs", minimum=1, maximum=1_000_000)
        self.backend, self.render_mode = backend, None
        carry_backend(backend, drive)  # the drive runs here (else a clear error)
        check_step_scale(kwargs.get("max_step_m", 0.02), kwargs.get("max_step_rad", 0.06))
        check_sensor(kwargs.get("sensor"))
        self.worlds = WarpCarryWorlds(scenario_graph(scenario), n, drive,
                                      max_step_m=kwargs.get("max_step_m", 0.02),
                                      max_step_rad=kwargs.get("max_step_rad", 0.06),
                                      sensor=kwargs.get("sensor"), device=device)
        with SHARED.sharing([WarpCarrySim(self.worlds, i) for i in range(n)]):
            self.envs = [CarryEnv(scenario, backend="mjwarp", drive=drive, **kwargs)
                         for _ in range(n)]
        self.single_observation_space = self.envs[0].observation_space
        self.single_action_space = self.envs[0].action_space
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self._ended = np.zeros(n, dtype=bool)
        self._obs = np.zeros((n, self.envs[0].n_obs), dtype=np.float32)
        self._needs_reset = True

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start N episodes (env *i* seeded with ``seed + i``)."""
        infos: dict[str, Any] = {}
        for i, env in enumerate(self.envs):
            self._obs[i], info = env.reset(seed=None if seed is None else seed + i,
                                           options=options)
            infos = self._add_info(infos, info, i)
        self._ended[:] = False
        self._needs_reset = False
        return self._obs.copy(), infos

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
        if self._needs_reset:
            raise ResetNeeded("call reset() before step()")
        a = self._actions(actions)
        n = self.num_envs
        rewards = np.zeros(n)
        terminated, truncated = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
        infos: dict[str, Any] = {}
        restart = np.flatnonzero(self._ended) if not self._same_step else np.zeros(0, int)
        for i in restart:  # next-step autoreset
            self._obs[i], info = self.envs[i].reset()
            infos = self._add_info(infos, info, int(i))
        stepping = ~self._ended if not self._same_step else np.ones(n, dtype=bool)
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
        if self._same_step and ended:
            final_obs = np.full(n, None, dtype=object)
            mask = np.zeros(n, dtype=bool)
            for i in ended:  # the final observations first, then the new episodes
                final_obs[i], mask[i] = self._obs[i].copy(), True
            for i in ended:
                self._obs[i], _ = self.envs[i].reset()
            infos["final_obs"], infos["_final_obs"] = final_obs, mask
        if not self._same_step:
            self._ended = terminated | truncated
        return self._obs.copy(), rewards, terminated, truncated, infos

    def close_extras(self, **kwargs: Any) -> None:
        """Close every env."""
        for env in self.envs:
            env.close()
