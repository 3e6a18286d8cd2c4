"""A learned robot: a residual policy over the variable admittance.

The robot acts as the variable admittance (:class:`~baselines.physical.admittance.
VariableAdmittance`) plus a learned correction::

    a_base = VariableAdmittance.act(observation)
    x      = clip((concat(observation, a_base) - mean) / sqrt(var + eps), -clip_obs, clip_obs)
    r      = clip(MLP(x), -1, 1)                   (tanh hidden layers, linear output)
    action = clip(a_base + scale * r, -1, 1)

except once a seat holds the object after it left its start (the base's ``settling``):
then the action is the base's alone, holding still while the seat pulls the object home
(a residual there, the training's exploration noise above all, kept the object from coming
to rest: every episode of a first try timed out). The MLP's last layer starts at zero, so
the untrained policy *is* the variable admittance; training
(``benchmarks/train_physical_rl.py``: PPO of stable-baselines3 on the train split of the
physical humans, observation normalisation by ``VecNormalize``) learns only what improves
on it. :class:`ResidualEnv` is the env the policy is trained on (the base
controller runs inside it, its state reset at every reset), and :class:`ResidualAdmittance`
the numpy-only robot that acts from a checkpoint: an ``.npz`` (never a pickle) holding

=============================  =========================================================
``w0, b0, ..., w{L}, b{L}``    the MLP's layers, ``w{i}`` of shape (out, in)
``obs_mean``, ``obs_var``      the observation normalisation (the input's length)
``clip_obs``, ``epsilon``      its clip and epsilon (scalars)
``scale``                      the residual's scale (a scalar > 0)
``scenario``                   the scenario it was trained on (a string)
=============================  =========================================================

The shipped checkpoints are ``baselines/physical/data/rl-<scenario>.npz``;
docs/physical-baselines.md ("The learned robot") has their budget, curves and figures.
"""

from __future__ import annotations

import itertools
import os
from importlib import resources
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from agents.physical import PhysicalAgent
from baselines.physical.admittance import VariableAdmittance
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.robot_view import RobotTask
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph

__all__ = ["ACTION_SIZE", "ResidualAdmittance", "ResidualEnv", "ResidualPolicy",
           "checkpoint_path", "combine", "load_policy", "save_policy"]

#: The continuous envs' action size (grip offset, rotation, stiffness).
ACTION_SIZE = 7


def combine(base: np.ndarray, residual: np.ndarray, scale: float) -> np.ndarray:
    """The robot's action: ``clip(base + scale * clip(residual, -1, 1), -1, 1)``."""
    r = np.clip(np.asarray(residual, dtype=np.float32), -1.0, 1.0)
    return np.clip(np.asarray(base, dtype=np.float32) + np.float32(scale) * r, -1.0,
                   1.0).astype(np.float32)


class ResidualPolicy:
    """The residual's MLP and its input normalisation (see the module docstring).

    Args:
        weights: The layers' weights, ``(out, in)`` each, the last one's out = 7.
        biases: Their biases.
        obs_mean: The normalisation's mean of the input (observation and base action).
        obs_var: Its variance.
        clip_obs: The normalised input is clipped to ``±clip_obs``.
        epsilon: Added to the variance.
        scale: The residual's scale.
        scenario: The scenario it was trained on.

    Raises:
        ConfigError: Shapes that do not chain, or a bad scalar (``field`` names it).
    """

    def __init__(self, weights: list[np.ndarray], biases: list[np.ndarray],
                 obs_mean: np.ndarray, obs_var: np.ndarray, clip_obs: float = 10.0,
                 epsilon: float = 1e-8, scale: float = 0.3, scenario: str = "") -> None:
        self.weights = [np.asarray(w, dtype=np.float64) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in biases]
        self.obs_mean = np.asarray(obs_mean, dtype=np.float64)
        self.obs_var = np.asarray(obs_var, dtype=np.float64)
        self.clip_obs, self.epsilon = float(clip_obs), float(epsilon)
        self.scale, self.scenario = float(scale), str(scenario)
        self._check()

    def _check(self) -> None:
        if not self.weights or len(self.weights) != len(self.biases):
            raise ConfigError(f"need as many biases as weights (at least one layer), got "
                              f"{len(self.weights)} and {len(self.biases)}", field="w0")
        size = self.obs_mean.shape
        if self.obs_mean.ndim != 1 or self.obs_var.shape != size:
            raise ConfigError(f"obs_mean and obs_var must be vectors of one length, got "
                              f"{self.obs_mean.shape} and {self.obs_var.shape}",
                              field="obs_var")
        if not np.all(self.obs_var >= 0) or not np.all(np.isfinite(self.obs_mean)):
            raise ConfigError("obs_var must be finite and >= 0, obs_mean finite",
                              field="obs_var")
        width = size[0]
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            if w.ndim != 2 or w.shape[1] != width:
                raise ConfigError(f"w{i} must have shape (out, {width}), got {w.shape}",
                                  field=f"w{i}")
            if b.shape != (w.shape[0],):
                raise ConfigError(f"b{i} must have shape ({w.shape[0]},), got {b.shape}",
                                  field=f"b{i}")
            if not (np.all(np.isfinite(w)) and np.all(np.isfinite(b))):
                raise ConfigError(f"w{i}, b{i} must be finite", field=f"w{i}")
            width = w.shape[0]
        if width != ACTION_SIZE:
            raise ConfigError(f"the last layer must have {ACTION_SIZE} outputs, got {width}",
                              field=f"w{len(self.weights) - 1}")
        for key in ("scale", "clip_obs", "epsilon"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ConfigError(f"{key} must be a finite number > 0, got {value!r}",
                                  field=key)

    @property
    def input_size(self) -> int:
        """The input's length: the observation's and the base action's (7)."""
        return int(self.obs_mean.shape[0])

    def residual(self, x: np.ndarray) -> np.ndarray:
        """The (7,) residual in [-1, 1] for the (unnormalised) input ``x``."""
        h = np.clip((np.asarray(x, dtype=np.float64) - self.obs_mean)
                    / np.sqrt(self.obs_var + self.epsilon), -self.clip_obs, self.clip_obs)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = w @ h + b
            if i < last:
                h = np.tanh(h)
        return np.clip(h, -1.0, 1.0)

    def arrays(self) -> dict[str, np.ndarray]:
        """The checkpoint's arrays (what :func:`save_policy` writes)."""
        out: dict[str, np.ndarray] = {}
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            out[f"w{i}"], out[f"b{i}"] = w.astype(np.float32), b.astype(np.float32)
        out.update(obs_mean=self.obs_mean, obs_var=self.obs_var,
                   clip_obs=np.array(self.clip_obs), epsilon=np.array(self.epsilon),
                   scale=np.array(self.scale), scenario=np.array(self.scenario))
        return out

    @classmethod
    def zero(cls, input_size: int, hidden: tuple[int, ...] = (64, 64), scale: float = 0.3,
             scenario: str = "", seed: int = 0) -> ResidualPolicy:
        """A policy whose last layer is zero (the residual is 0 everywhere), the hidden
        layers random: what training starts from.
        """
        rng = np.random.default_rng(seed)
        sizes = (input_size, *hidden, ACTION_SIZE)
        weights = [rng.normal(0, 1 / np.sqrt(i), (o, i)) for i, o in itertools.pairwise(sizes)]
        weights[-1][:] = 0.0
        return cls(weights, [np.zeros(o) for o in sizes[1:]], np.zeros(input_size),
                   np.ones(input_size), scale=scale, scenario=scenario)


def save_policy(policy: ResidualPolicy, path: str | os.PathLike[str]) -> None:
    """Write ``policy`` to ``path`` as an ``.npz`` (no pickle)."""
    np.savez(path, **policy.arrays())  # type: ignore[arg-type]


def load_policy(path: str | os.PathLike[str]) -> ResidualPolicy:
    """The policy in the ``.npz`` at ``path`` (read without pickle).

    Raises:
        ConfigError: A missing or malformed field (``field`` names it).
    """
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise ConfigError(f"cannot read the residual policy {os.fspath(path)!r}: {exc}",
                          field="checkpoint") from None
    layers = sum(1 for k in arrays if k.startswith("w") and k[1:].isdigit())
    required = ["obs_mean", "obs_var", "clip_obs", "epsilon", "scale", "scenario",
                *(f"{p}{i}" for i in range(layers) for p in "wb")]
    for key in required:
        if key not in arrays:
            raise ConfigError(f"the residual policy {os.fspath(path)!r} has no {key!r} "
                              f"(needs {', '.join(required)})", field=key)
    scalars: dict[str, Any] = {}
    for key in ("clip_obs", "epsilon", "scale"):
        value = arrays[key]
        if value.shape != () or value.dtype.kind not in "fiu":
            raise ConfigError(f"{key} must be a number, got {value!r}", field=key)
        scalars[key] = float(value)
    if arrays["scenario"].shape != () or arrays["scenario"].dtype.kind != "U":
        raise ConfigError(f"scenario must be a string, got {arrays['scenario']!r}",
                          field="scenario")
    return ResidualPolicy([arrays[f"w{i}"] for i in range(layers)],
                          [arrays[f"b{i}"] for i in range(layers)],
                          arrays["obs_mean"], arrays["obs_var"],
                          scenario=str(arrays["scenario"]), **scalars)


def checkpoint_path(graph: TaskGraph) -> Path:
    """The shipped checkpoint of ``graph``'s scenario (``baselines/physical/data/rl-<name>.npz``,
    by the scenario's name).
    """
    return Path(str(resources.files("baselines.physical") / "data" / f"rl-{graph.name}.npz"))


class ResidualAdmittance(PhysicalAgent):
    """The learned robot: the variable admittance plus a learned residual (module
    docstring), acting with numpy only.

    Args:
        scenario: The scenario's task graph, or a registered scenario's name (resolved
            here): its variable admittance's tuned gains, and its shipped checkpoint unless
            ``policy``.
        policy: The residual policy (or the path of its ``.npz``).

    Raises:
        ConfigError: No checkpoint for ``scenario``, a malformed one, or one trained on
            another scenario.
    """

    name = "rl"

    def __init__(self, scenario: TaskGraph | str,
                 policy: ResidualPolicy | str | os.PathLike[str] | None = None) -> None:
        graph = as_graph(scenario)
        if policy is None:
            path = checkpoint_path(graph)
            if not path.is_file():
                raise ConfigError(f"no residual policy for scenario {graph.name!r}; allowed: "
                                  "hanger, wheel", field="scenario")
            policy = path
        if not isinstance(policy, ResidualPolicy):
            policy = load_policy(policy)
        if policy.scenario and policy.scenario != graph.name:
            raise ConfigError(f"the residual policy was trained on {policy.scenario!r}, "
                              f"not {graph.name!r}", field="scenario")
        self.scenario = graph.name
        self.policy = policy
        self.base = VariableAdmittance(graph)

    def begin_episode(self, task: RobotTask) -> None:
        """A new episode: the base controller's state is reset."""
        self.base.begin_episode(task)

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The base's action plus the scaled residual, clipped to [-1, 1]."""
        base = self.base.act(observation)
        x = np.concatenate([np.asarray(observation, dtype=np.float64), base])
        if x.shape != (self.policy.input_size,):
            raise ConfigError(f"the residual policy takes {self.policy.input_size - 7} "
                              f"observation values, got {x.shape[0] - 7}",
                              field="observation")
        if self.base.wrench.settling:
            return base
        return combine(base, self.policy.residual(x), self.policy.scale)


class ResidualEnv(gym.Wrapper):
    """The env a residual policy is trained on: its action is the residual in [-1, 1]^7,
    its observation the robot's observation and the base's action after it.

    The base controller (the scenario's :class:`VariableAdmittance`) runs inside: at every
    reset it begins a new episode with the env's :class:`RobotTask`, and each step the
    env is stepped with :func:`combine` of the base's action and the residual, exactly as
    :class:`ResidualAdmittance` acts.

    Args:
        env: A v1 continuous env of ``scenario`` (``gymnasium.make``-d).
        scenario: Its scenario's task graph, or a registered scenario's name (resolved
            here).
        scale: The residual's scale.
    """

    def __init__(self, env: gym.Env, scenario: TaskGraph | str, scale: float) -> None:
        super().__init__(env)
        graph = as_graph(scenario)
        self.scenario, self.scale = graph.name, float(scale)
        self.base = VariableAdmittance(graph)
        size = int(np.prod(env.observation_space.shape or (0,))) + ACTION_SIZE
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (size,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (ACTION_SIZE,), np.float32)
        self._base_action = np.zeros(ACTION_SIZE, dtype=np.float32)

    def _observe(self, obs: np.ndarray) -> np.ndarray:
        self._base_action = self.base.act(obs)
        return np.concatenate([obs, self._base_action]).astype(np.float32)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the env and the base controller."""
        obs, info = self.env.reset(**kwargs)
        self.base.begin_episode(self.env.unwrapped.robot_task())  # type: ignore[attr-defined]
        return self._observe(obs), info

    def step(self, action: np.ndarray
             ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Step the env with the base's action plus the scaled residual ``action``."""
        act = self._base_action if self.base.wrench.settling else combine(
            self._base_action, action, self.scale)
        obs, reward, term, trunc, info = self.env.step(act)
        return self._observe(obs), reward, term, trunc, info
