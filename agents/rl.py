"""Standard RL against scripted humans: stable-baselines3 / sb3-contrib training helpers.

- :func:`make_sb3_vec_env`: ``hri_envs/Hanger-v0`` or ``Wheel-v0`` as an SB3 ``VecEnv``,
  stepped by SB3's ``DummyVecEnv`` or ``SubprocVecEnv``, or by the suite's numpy-batched
  :class:`~hri_envs.envs.vector.RobotVectorEnv` through :class:`SB3VectorEnv`;
- :func:`train_maskable_ppo`: sb3-contrib's MaskablePPO, masks from the envs'
  ``action_masks()``;
- :class:`MaskedDQN` and :func:`train_dqn`: DQN that never picks, explores with or
  bootstraps from an invalid action (see the class for how);
- :class:`EpisodeCheckpoints`: a callback that counts training episodes and calls you back at
  given counts (sample-efficiency curves);
- :class:`RandomMasked`: the uniformly random valid-action policy, the floor of RL's
  normalised scores;
- :func:`console_logger`: SB3's logger without the empty ``SB3-<time>`` folder SB3 leaves
  in the temporary directory at every ``learn()`` that logs nowhere.

A trained model plays in the benchmark through :class:`agents.sb3.SB3Agent` (or
``hri-bench study ... --agents learner,sb3:PATH``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from agents.protocol import BatchAgent, Trace, run_streams
from hri_envs.errors import ConfigError, MissingExtraError

try:
    import torch as th
    from gymnasium.vector import AutoresetMode
    from sb3_contrib import MaskablePPO
    from stable_baselines3 import DQN
    from stable_baselines3.common.base_class import BaseAlgorithm
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import HumanOutputFormat, Logger
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv
    from stable_baselines3.dqn.policies import MultiInputPolicy as DQNMultiInputPolicy
    from stable_baselines3.dqn.policies import QNetwork
except ImportError as exc:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError(["stable_baselines3", "sb3_contrib", "torch"], "agents.rl") from exc

__all__ = [
    "DQN_DEFAULTS",
    "INVALID_Q",
    "PPO_DEFAULTS",
    "VEC_KINDS",
    "EpisodeCheckpoints",
    "MaskedDQN",
    "MaskedDQNPolicy",
    "MaskedQNetwork",
    "RandomMasked",
    "SB3VectorEnv",
    "console_logger",
    "make_sb3_vec_env",
    "random_valid_actions",
    "train_dqn",
    "train_maskable_ppo",
]

#: How :func:`make_sb3_vec_env` steps its copies of the env.
VEC_KINDS: tuple[str, ...] = ("vector", "dummy", "subproc")
#: Q-value given to invalid actions by :class:`MaskedQNetwork`.
INVALID_Q = -1e8


def random_valid_actions(rng: np.random.Generator, masks: np.ndarray) -> np.ndarray:
    """(N,) actions drawn uniformly among the valid ones of each (N, A) mask row."""
    masks = np.asarray(masks).reshape(-1, np.shape(masks)[-1]) > 0
    return np.argmax(np.where(masks, rng.random(masks.shape), -1.0), axis=1)


class RandomMasked(BatchAgent):
    """Picks uniformly among the valid actions; run ``r`` draws from ``(seed, r)`` only."""

    name: ClassVar[str] = "random"

    def __init__(self, n_runs: int, *, seed: int = 0, runs: Sequence[int] | None = None) -> None:
        super().__init__(n_runs)
        self.rngs = run_streams(seed, range(n_runs) if runs is None else runs)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Nothing to prepare."""

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """A uniformly random valid action per active run."""
        masks = np.asarray(observations["action_mask"])
        out = np.zeros(self.n_runs, dtype=np.int64)
        for i in np.flatnonzero(active):
            out[i] = random_valid_actions(self.rngs[i], masks[i : i + 1])[0]
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Nothing to record."""

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Nothing to learn."""


# --------------------------------------------------------------------------- vector envs
class SB3VectorEnv(VecEnv):
    """A Gymnasium ``VectorEnv`` (such as ``RobotVectorEnv``) as a stable-baselines3 ``VecEnv``.

    SB3 expects an env that ends an episode to hand back the next episode's first
    observation in the same step, with the final one in ``terminal_observation``: Gymnasium's
    same-step autoreset (``RobotVectorEnv(autoreset_mode=AutoresetMode.SAME_STEP)``, what
    :func:`make_sb3_vec_env` uses) is exactly that. A next-step autoreset env also works, but
    each finished episode is then followed by one *restart step* (action ignored, reward 0)
    that SB3 records as a transition from the final observation to the new first one;
    returns and lengths in ``info["episode"]`` leave it out.

    Methods reached through ``env_method`` (``action_masks`` for MaskablePPO) are called
    once on the batched env and split along the env axis.
    """

    def __init__(self, env: gym.vector.VectorEnv) -> None:
        mode = env.metadata.get("autoreset_mode", AutoresetMode.NEXT_STEP)
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ConfigError(f"autoreset mode {mode} is not supported; allowed: next-step or "
                              "same-step autoreset", field="env")
        self.env = env
        self._next_step_reset = mode == AutoresetMode.NEXT_STEP
        super().__init__(env.num_envs, env.single_observation_space, env.single_action_space)
        n = self.num_envs
        self._restarting = np.zeros(n, dtype=bool)
        self._return = np.zeros(n)
        self._length = np.zeros(n, dtype=np.int64)
        self._actions = np.zeros(n, dtype=np.int64)
        self._t0 = time.perf_counter()

    def reset(self) -> dict[str, np.ndarray] | np.ndarray:
        """Reset every env (seeded by :meth:`seed`'s first seed, if any)."""
        options = self._options[0] or None
        obs, _ = self.env.reset(seed=self._seeds[0], options=options)
        self._reset_seeds()
        self._reset_options()
        self._restarting[:] = False
        self._return[:] = 0.0
        self._length[:] = 0
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the actions (the batched env steps synchronously in :meth:`step_wait`)."""
        self._actions = np.asarray(actions, dtype=np.int64).reshape(self.num_envs)

    def step_wait(
        self,
    ) -> tuple[dict[str, np.ndarray] | np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        """Step all envs; episode ends carry SB3's ``terminal_observation`` info."""
        obs, reward, terminated, truncated, info = self.env.step(self._actions)
        counted = ~self._restarting
        self._return += reward
        self._length += counted
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for key, value in info.items():
            if key.startswith("_") or f"_{key}" not in info:
                continue
            for i in np.flatnonzero(info[f"_{key}"]):
                infos[i][key] = value[i]
        for i in np.flatnonzero(done):
            if self._next_step_reset:
                final = {k: v[i] for k, v in obs.items()} if isinstance(obs, dict) else obs[i]
            else:
                final = info["final_obs"][i]
            infos[i]["terminal_observation"] = final
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            infos[i]["episode"] = {"r": float(self._return[i]), "l": int(self._length[i]),
                                   "t": round(time.perf_counter() - self._t0, 6)}
        self._return[done] = 0.0
        self._length[done] = 0
        self._restarting = done.copy() if self._next_step_reset else np.zeros_like(done)
        return obs, reward.astype(np.float32), done, infos

    def close(self) -> None:
        """Close the batched env."""
        self.env.close()

    def _count(self, indices: Any) -> int:
        return len(list(self._get_indices(indices)))

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The batched env's attribute, once per requested env."""
        return [getattr(self.env, attr_name)] * self._count(indices)

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set an attribute of the batched env."""
        setattr(self.env, attr_name, value)

    def has_attr(self, attr_name: str) -> bool:
        """Whether the batched env has the attribute."""
        return hasattr(self.env, attr_name)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None,
                   **method_kwargs: Any) -> list[Any]:
        """Call a method of the batched env once; split an (N, ...) array result per env."""
        result = getattr(self.env, method_name)(*method_args, **method_kwargs)
        idx = list(self._get_indices(indices))
        if isinstance(result, np.ndarray) and result.shape[:1] == (self.num_envs,):
            return [result[i] for i in idx]
        return [result] * len(idx)

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: Any = None) -> list[bool]:
        """The batched env has no per-env wrappers."""
        return [False] * self._count(indices)

    def get_images(self) -> list[np.ndarray | None]:
        """The batched env does not render."""
        return [None] * self.num_envs


def _make_env(env_id: str, **env_kwargs: Any) -> gym.Env:
    import hri_envs  # noqa: F401  (registers the ids in SubprocVecEnv workers)

    return gym.make(env_id, **env_kwargs)


def make_sb3_vec_env(
    env_id: str = "hri_envs/Hanger-v0",
    n_envs: int = 8,
    vec: str = "vector",
    seed: int = 0,
    **env_kwargs: Any,
) -> VecEnv:
    """``n_envs`` copies of a suite env as an SB3 ``VecEnv``.

    Args:
        env_id: A registered id, e.g. ``"hri_envs/Hanger-v0"`` or ``"hri_envs/Wheel-v0"``.
        n_envs: Number of envs stepped together.
        vec: ``"vector"`` (the numpy-batched ``RobotVectorEnv`` via :class:`SB3VectorEnv`),
            ``"dummy"`` (SB3's ``DummyVecEnv``, one process) or ``"subproc"`` (SB3's
            ``SubprocVecEnv``, one process per env).
        seed: Seed of the first reset.
        **env_kwargs: The env's keywords (``preference``, ``human_passive``, ``r0``, ...).
    """
    import hri_envs  # noqa: F401  (registers the ids)

    if vec not in VEC_KINDS:
        raise ConfigError(f"unknown vec {vec!r}; allowed: {', '.join(VEC_KINDS)}", field="vec")
    if n_envs < 1:
        raise ConfigError(f"n_envs must be >= 1, got {n_envs}", field="n_envs")
    if vec == "vector":
        # Same-step autoreset: SB3 needs the next episode's first observation in the step
        # that ends one (no restart step, no transition across the episode boundary).
        venv: VecEnv = SB3VectorEnv(gym.make_vec(env_id, num_envs=n_envs,
                                                 vectorization_mode="vector_entry_point",
                                                 autoreset_mode=AutoresetMode.SAME_STEP,
                                                 **env_kwargs))
    else:
        cls = SubprocVecEnv if vec == "subproc" else DummyVecEnv
        venv = make_vec_env(_make_env, n_envs=n_envs, vec_env_cls=cls,
                            env_kwargs={"env_id": env_id, **env_kwargs})
    venv.seed(seed)
    return venv


# --------------------------------------------------------------------------- masked DQN
class MaskedQNetwork(QNetwork):
    """A Q-network whose invalid actions (``obs["action_mask"] == 0``) read :data:`INVALID_Q`.

    Masking the output, rather than each use of it, covers every place DQN looks at Q:
    the greedy action, the bootstrap ``max_a' Q_target(s', a')`` (the mask of s' travels in
    the next observation) and the logged values. Taken actions are always valid (see
    :class:`MaskedDQN`), so the regression never targets a masked entry.
    """

    def forward(self, obs: Any) -> th.Tensor:
        """Q-values (B, A) with invalid actions at :data:`INVALID_Q`."""
        q = super().forward(obs)
        return q.masked_fill(obs["action_mask"] <= 0, INVALID_Q)


class MaskedDQNPolicy(DQNMultiInputPolicy):
    """DQN's Dict-observation policy with :class:`MaskedQNetwork` as its online and target net."""

    def __init__(self, observation_space: gym.spaces.Space, *args: Any, **kwargs: Any) -> None:
        if not isinstance(observation_space, gym.spaces.Dict) or \
                "action_mask" not in observation_space.spaces:
            raise ConfigError("MaskedDQNPolicy needs a Dict observation space with an "
                              f"'action_mask' entry; got {observation_space}",
                              field="observation_space")
        super().__init__(observation_space, *args, **kwargs)

    def make_q_net(self) -> MaskedQNetwork:
        """A fresh masked Q-network with its own feature extractor."""
        kwargs = self._update_features_extractor(self.net_args, features_extractor=None)
        return MaskedQNetwork(**kwargs).to(self.device)


class MaskedDQN(DQN):
    """DQN restricted to valid actions, read from the observation's ``action_mask``.

    How invalid actions are handled (masked greedy selection, not remapping): the
    Q-network reports invalid actions as :data:`INVALID_Q` (:class:`MaskedQNetwork`), so
    the greedy policy and the TD target's max only range over valid actions; epsilon
    exploration and the warm-up phase draw uniformly among valid actions instead of the
    whole action space. The env's own rule (an invalid action aborts the step, reward -1)
    therefore never comes into play in training. Use ``"MultiInputPolicy"`` (the default).
    Exploration draws from a NumPy generator seeded with the model's ``seed``.
    """

    policy_aliases: ClassVar[dict[str, type[Any]]] = {"MultiInputPolicy": MaskedDQNPolicy}

    def __init__(self, policy: Any = "MultiInputPolicy", env: Any = None, **kwargs: Any) -> None:
        super().__init__(policy, env, **kwargs)

    def _setup_model(self) -> None:
        super()._setup_model()
        self._explore_rng = np.random.default_rng(self.seed)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_explore_rng"]

    def predict(  # type: ignore[override]
        self,
        observation: dict[str, np.ndarray],
        state: tuple[np.ndarray, ...] | None = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = False,
    ) -> tuple[np.ndarray, tuple[np.ndarray, ...] | None]:
        """Greedy valid action; with probability ``exploration_rate`` (per env, unless
        ``deterministic``) a uniformly random valid one.
        """
        action, state = self.policy.predict(observation, state, episode_start, True)
        if deterministic or self.exploration_rate <= 0:
            return action, state
        masks = np.asarray(observation["action_mask"])
        flat = np.asarray(action).reshape(-1)
        explore = self._explore_rng.random(flat.shape[0]) < self.exploration_rate
        if explore.any():
            flat = np.where(explore, random_valid_actions(self._explore_rng, masks), flat)
        return flat.reshape(np.shape(action)), state

    def _sample_action(
        self, learning_starts: int, action_noise: Any = None, n_envs: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        assert self._last_obs is not None, "call learn() (it resets the env) first"
        obs: dict[str, np.ndarray] = self._last_obs  # type: ignore[assignment]
        if self.num_timesteps < learning_starts:
            action = random_valid_actions(self._explore_rng, obs["action_mask"])
        else:
            action, _ = self.predict(obs, deterministic=False)
        return action, action


# --------------------------------------------------------------------------- training
class EpisodeCheckpoints(BaseCallback):
    """Counts finished training episodes (all envs) and calls ``on_checkpoint(model, n)``
    the first time the count ``n`` reaches each value of ``at``; stops training after the
    last one when ``stop`` is true.
    """

    def __init__(
        self,
        at: Sequence[int] = (),
        on_checkpoint: Callable[[BaseAlgorithm, int], None] | None = None,
        *,
        stop: bool = True,
    ) -> None:
        super().__init__()
        self.at = sorted(int(a) for a in at)
        self.on_checkpoint = on_checkpoint
        self.stop = stop
        self.episodes = 0
        self._next = 0

    def _on_step(self) -> bool:
        self.episodes += int(np.sum(self.locals["dones"]))
        reached = False
        while self._next < len(self.at) and self.episodes >= self.at[self._next]:
            self._next += 1
            reached = True
        if reached and self.on_checkpoint is not None:
            self.on_checkpoint(self.model, self.episodes)
        return not (self.stop and self.at and self._next >= len(self.at))


#: MaskablePPO settings used by :func:`train_maskable_ppo` unless overridden: short rollouts
#: and many epochs (the best of a small sweep on the hanger's sample-efficiency study; with
#: SB3's own defaults, n_steps=2048, PPO needs several times more episodes).
PPO_DEFAULTS: dict[str, Any] = {
    "n_steps": 64, "batch_size": 128, "n_epochs": 10, "learning_rate": 1e-3, "gamma": 0.95,
    "gae_lambda": 0.9, "ent_coef": 0.01, "policy_kwargs": {"net_arch": [64, 64]},
}
#: MaskedDQN settings used by :func:`train_dqn` unless overridden.
DQN_DEFAULTS: dict[str, Any] = {
    "learning_starts": 500, "buffer_size": 50_000, "batch_size": 64, "gamma": 0.95,
    "learning_rate": 1e-3, "train_freq": 1, "target_update_interval": 250,
    "exploration_fraction": 0.3, "exploration_final_eps": 0.02,
    "policy_kwargs": {"net_arch": [64, 64]},
}


def console_logger(verbose: int = 0) -> Logger:
    """SB3's logger for a model that logs nowhere but the console (``model.set_logger``).

    A model without ``tensorboard_log`` otherwise makes an empty ``SB3-<time>`` folder in
    the temporary directory at every ``learn()`` (stable-baselines3's ``configure``), which
    piles up over training runs and tests. The console table is printed as SB3 prints it
    for ``verbose >= 1``.
    """
    return Logger(None, [HumanOutputFormat(sys.stdout)] if verbose >= 1 else [])


def train_maskable_ppo(
    env_id: str = "hri_envs/Hanger-v0",
    total_timesteps: int = 20_000,
    n_envs: int = 8,
    vec: str = "vector",
    seed: int = 0,
    *,
    callback: BaseCallback | None = None,
    ppo_kwargs: Mapping[str, Any] | None = None,
    verbose: int = 0,
    torch_threads: int | None = 1,
    **env_kwargs: Any,
) -> MaskablePPO:
    """Train sb3-contrib's MaskablePPO (``MultiInputPolicy``) against a scripted human.

    Args:
        env_id: ``"hri_envs/Hanger-v0"`` or ``"hri_envs/Wheel-v0"``.
        total_timesteps: Env steps (summed over envs; the vector env's restart steps count).
        n_envs: Envs stepped together.
        vec: ``"vector"``, ``"dummy"`` or ``"subproc"`` (see :func:`make_sb3_vec_env`).
        seed: Seed of the model and the envs.
        callback: An SB3 callback, e.g. :class:`EpisodeCheckpoints`.
        ppo_kwargs: Overrides of :data:`PPO_DEFAULTS` (any MaskablePPO keyword).
        verbose: SB3's verbosity.
        torch_threads: Sets torch's (process-wide) intra-op threads unless None; one thread
            is fastest for these small networks, and several threads on a busy machine
            can make training an order of magnitude slower.
        **env_kwargs: The env's keywords (``preference``, ``human_passive``, ...).
    """
    if torch_threads is not None:
        th.set_num_threads(torch_threads)
    env = make_sb3_vec_env(env_id, n_envs, vec, seed, **env_kwargs)
    kwargs = {**PPO_DEFAULTS, **(ppo_kwargs or {})}
    model = MaskablePPO("MultiInputPolicy", env, seed=seed, verbose=verbose, device="cpu",
                        **kwargs)
    if model.tensorboard_log is None:
        model.set_logger(console_logger(verbose))
    try:
        model.learn(total_timesteps, callback=callback)
    finally:
        env.close()
    return model


def train_dqn(
    env_id: str = "hri_envs/Hanger-v0",
    total_timesteps: int = 20_000,
    n_envs: int = 1,
    vec: str = "dummy",
    seed: int = 0,
    *,
    callback: BaseCallback | None = None,
    dqn_kwargs: Mapping[str, Any] | None = None,
    verbose: int = 0,
    torch_threads: int | None = 1,
    **env_kwargs: Any,
) -> MaskedDQN:
    """Train :class:`MaskedDQN` against a scripted human (arguments as
    :func:`train_maskable_ppo`; ``dqn_kwargs`` override :data:`DQN_DEFAULTS`).
    """
    if torch_threads is not None:
        th.set_num_threads(torch_threads)
    env = make_sb3_vec_env(env_id, n_envs, vec, seed, **env_kwargs)
    kwargs = {**DQN_DEFAULTS, **(dqn_kwargs or {})}
    model = MaskedDQN("MultiInputPolicy", env, seed=seed, verbose=verbose, device="cpu",
                      **kwargs)
    if model.tensorboard_log is None:
        model.set_logger(console_logger(verbose))
    try:
        model.learn(total_timesteps, callback=callback)
    finally:
        env.close()
    return model
