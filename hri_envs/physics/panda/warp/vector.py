"""N Panda envs stepped together on MuJoCo Warp: :class:`PandaVectorEnv`."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode

from hri_envs.envs.backends import BACKENDS
from hri_envs.envs.config import check_physics_options, scenario_graph
from hri_envs.envs.robot import RobotEnv
from hri_envs.errors import ActionError, ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.seat import HumanLike, human_spec
from hri_envs.humans.spec import HumanSpec
from hri_envs.physics.panda.warp.episode import WarpPhysicsEpisode, WarpSim
from hri_envs.physics.panda.warp.worlds import WarpWorlds
from hri_envs.physics.scene.warp.vector_base import WorldsVectorEnv

__all__ = ["PandaVectorEnv"]


class PandaVectorEnv(WorldsVectorEnv[dict[str, np.ndarray]]):
    """``num_envs`` copies of the Panda env (:class:`~hri_envs.envs.robot.RobotEnv` with the
    physics), their worlds stepped together on MuJoCo Warp.

    ## Description

    The robot-vs-scripted-human task on the simulated Panda, for N episodes at once: every
    env is a :class:`~hri_envs.envs.robot.RobotEnv` on the ``"mjwarp"`` backend whose
    world is one of the N worlds of a shared
    :class:`~hri_envs.physics.panda.warp.worlds.WarpWorlds`; a vector step asks every human for
    its action, simulates all the worlds' abstract steps together (each world as long as
    its step lasts; the others wait frozen) and hands each env its outcome. Made by
    ``gymnasium.make_vec("hri_envs/HangerPanda-v0", num_envs=N,
    vectorization_mode="vector_entry_point")`` (likewise ``WheelPanda-v0``). The Panda ids
    say ``backend="mujoco"``: here that runs the same physics on MuJoCo Warp, since MuJoCo's C
    library steps one world per call (use ``vectorization_mode="async"`` for C worlds in
    processes); ``backend="mjwarp"`` is the same.

    ## Action Space

    ``MultiDiscrete([A] * N)``: one robot action per env.

    ## Observation Space

    The single env's ``Dict`` (``"dict"`` format), batched: ``"state"``, ``"start"``,
    ``"last_human_action"`` (N,) int64 and ``"action_mask"`` (N, A) int8.

    ## Rewards

    (N,) float64, the single env's; 0 in the step that autoresets an env.

    ## Starting State

    As the single env; ``reset(seed=s)`` seeds env *i* with ``s + i`` (as Gymnasium's sync
    vector env does), ``options`` are handed to every env.

    ## Episode End

    As the single env (a fault truncates with ``infos["truncation_reason"]``). Autoreset is
    the graph's vector env's (:class:`~hri_envs.envs.vector.RobotVectorEnv`): next-step by
    default (the step after an episode ends ignores that env's action and returns the first
    observation of a new episode, reward 0, neither terminated nor truncated), or
    ``autoreset_mode=AutoresetMode.SAME_STEP`` (the final observation in
    ``infos["final_obs"]``, masked by ``infos["_final_obs"]``). The single env's ``info``
    keys are batched with Gymnasium's ``_key`` masks.

    ## Arguments

    - ``num_envs``: the number of envs (and worlds) N;
    - ``scenario`` and the single env's arguments (``human``: a
      :class:`~hri_envs.humans.spec.HumanSpec` or a scripted or finite-state human, each env
      seating its own; or its flat keywords ``preference``, ``human_passive``, ...; ``r0``,
      ``max_cycles``, ``physics``, ``reward``), the same for every env;
    - ``backend``: a physics backend (``"mujoco"`` or ``"mjwarp"``; both run here on MuJoCo
      Warp); ``"graph"`` is refused (its vector env is the graph ids');
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
                 physics: dict[str, Any] | None = None, human: HumanLike | None = None,
                 r0: float | None = None, max_cycles: int = 100,
                 reward: str = "paper", **human_keywords: Any) -> None:
        physical = [name for name, spec in BACKENDS.items() if spec.physical]
        if backend not in physical:
            raise ConfigError(f"the Panda vector env runs the physics on MuJoCo Warp; backend "
                              f"must be one of the physics backends {', '.join(physical)}, got "
                              f"{backend!r}", field="backend")
        n = self._configure(num_envs, render_mode, autoreset_mode, "Panda")
        self.backend = "mjwarp"
        human = human_spec(human, human_keywords)
        if not isinstance(human, HumanSpec | ScriptedHuman | FiniteStateHuman):
            raise ConfigError(f"the Panda vector env seats one human per env: give a HumanSpec "
                              f"(or a scripted or finite-state human), not a "
                              f"{type(human).__name__}", field="human")
        kwargs: dict[str, Any] = {"human": human, "r0": r0, "max_cycles": max_cycles,
                                  "physics": physics, "reward": reward}
        self.graph = scenario_graph(scenario)
        options = check_physics_options(
            physics, "mjwarp", human.body if isinstance(human, HumanSpec) else None)
        if "video_path" in options:
            raise ConfigError("the Panda vector env does not record videos; use the single "
                              "env for physics={'video_path': ...}", field="physics")
        self.worlds = WarpWorlds(self.graph, n, options=options, device=device)
        with WarpPhysicsEpisode.SHARED.sharing([WarpSim(self.worlds, i) for i in range(n)]):
            self.envs: list[RobotEnv] = [RobotEnv(scenario, backend="mjwarp", **kwargs)
                                         for _ in range(n)]
        self._batch_spaces(spaces.Discrete(self.graph.n_actions))
        self._obs: list[dict[str, Any]] = [{} for _ in range(n)]

    def _observations(self) -> dict[str, np.ndarray]:
        obs = self._obs
        return {"state": np.array([o["state"] for o in obs], dtype=np.int64),
                "start": np.array([o["start"] for o in obs], dtype=np.int64),
                "last_human_action": np.array([o["last_human_action"] for o in obs],
                                              dtype=np.int64),
                "action_mask": np.stack([o["action_mask"] for o in obs]).astype(np.int8)}

    def action_masks(self) -> np.ndarray:
        """(N, A) bool, each env's valid robot actions."""
        return np.stack([env.action_masks() for env in self.envs])

    def step(self, actions: Any) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray,
                                          np.ndarray, dict[str, Any]]:
        """Every env's robot acts, its human acts; the worlds move together."""
        self._check_started()
        a = np.asarray(actions)
        n, n_a = self.num_envs, self.graph.n_actions
        if a.shape != (n,) or a.dtype.kind not in "iu" or ((a < 0) | (a >= n_a)).any():
            raise ActionError(f"robot actions must be an integer array of shape ({n},) with "
                              f"values 0..{n_a - 1}; got {a.dtype} {a.shape}")
        stepping, infos = self._begin_step()
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        a_h = np.zeros(n, dtype=np.int64)
        seen: list[dict[str, np.ndarray] | None] = [None] * n
        states = np.zeros(n, dtype=np.int64)
        sim_active = np.zeros(n, dtype=bool)
        for i in np.flatnonzero(stepping):
            env = self.envs[i]
            a_h[i], seen[i] = env._human_action(int(a[i]))
            states[i] = env._episode.state
            sim_active[i] = env._episode.fault is None
        results = self.worlds.step(states, a.astype(np.int64), a_h, sim_active)
        final: dict[int, dict[str, Any]] = {}
        for i in np.flatnonzero(stepping):
            env = self.envs[i]
            sim = env._episode.sim  # type: ignore[attr-defined]
            sim.pending = results[i]
            obs, rewards[i], terminated[i], truncated[i], info = env._advance(
                int(a[i]), int(a_h[i]), seen[i])  # type: ignore[arg-type]
            sim.pending = None
            self._obs[i] = obs
            infos = self._add_info(infos, info, int(i))
            if terminated[i] or truncated[i]:
                if self._same_step:
                    final[int(i)] = obs
                    self._obs[i], _ = env.reset()
        self._end_step(terminated, truncated, infos, final)
        return self._observations(), rewards, terminated, truncated, infos
