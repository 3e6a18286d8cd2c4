"""A trained stable-baselines3 / sb3-contrib model as a robot agent of the protocol.

:class:`SB3Agent` (one stream, :class:`~agents.protocol.Agent`) and :class:`SB3BatchAgent`
(many runs, :class:`~agents.protocol.BatchAgent`, what ``hri-bench study --agents sb3:PATH``
builds) act with a model trained on ``hri_envs/Hanger-v0`` or ``Wheel-v0``. The robot's
protocol observation has the gym env's keys (``state``, ``start``, ``last_human_action``,
``action_mask``), so the model's ``MultiInputPolicy`` reads it as it is. Models are frozen:
``observe`` and ``end_episode`` do nothing.

Invalid actions are never chosen:

- MaskablePPO: the action distribution is built with ``action_masks=`` (sb3-contrib's
  masking, so invalid actions have probability 0);
- other actor-critic models (PPO, A2C): invalid actions' probabilities are set to 0 and the
  rest renormalised;
- DQN (and :class:`agents.rl.MaskedDQN`): the best Q-value among the valid actions.

``deterministic=True`` takes the most probable valid action (DQN: always the greedy valid
one); ``deterministic=False`` samples from the masked distribution with one NumPy generator
per run, seeded by ``(seed, run)``.

Loading never unpickles (docs/environments.md, 'Nothing is loaded with pickle'). SB3's
``.zip`` keeps its hyper-parameters in a JSON ``data`` entry (with some objects
cloudpickled inside) and the network weights as PyTorch state dicts. :func:`load_model`
reads only the JSON: which algorithm saved the file (the policy class's module), the
``policy_kwargs`` (when they are plain JSON, as ``net_arch`` is) and the action-space size
(which scenario); it builds a fresh model for the robot env's spaces and loads the weights with
``set_parameters``, i.e. ``torch.load(weights_only=True)``. ``policy_kwargs`` that SB3
pickled are read from their text form where they are plain literals (the optimizer entries,
irrelevant for acting, are left to the algorithm's defaults); anything else is refused with
a message that says so.
"""

from __future__ import annotations

import ast
import json
import os
import pickle
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from agents.protocol import Agent, BatchAgent, Trace, run_streams
from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.task.scenarios import SCENARIOS

if TYPE_CHECKING:
    from stable_baselines3.common.base_class import BaseAlgorithm

    from hri_envs.task.graph import TaskGraph

__all__ = ["ALGORITHMS", "SB3Agent", "SB3BatchAgent", "detect_algorithm", "load_model"]

#: Algorithms :func:`load_model` can open, by name.
ALGORITHMS: tuple[str, ...] = ("MaskablePPO", "PPO", "A2C", "DQN", "MaskedDQN")
_OBS_KEYS = ("state", "start", "last_human_action", "action_mask")


def _algorithm_class(name: str) -> type[BaseAlgorithm]:
    if name not in ALGORITHMS:
        raise ConfigError(f"unknown SB3 algorithm {name!r}; allowed: {', '.join(ALGORITHMS)}",
                          field="algo")
    try:
        if name == "MaskablePPO":
            from sb3_contrib import MaskablePPO

            return MaskablePPO
        if name == "MaskedDQN":
            from agents.rl import MaskedDQN

            return MaskedDQN
        import stable_baselines3

        return getattr(stable_baselines3, name)
    except ImportError as exc:
        raise MissingExtraError(["stable_baselines3", "sb3_contrib", "torch"],
                                "SB3 models") from exc


def _read_data(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The JSON ``data`` entry of an SB3 ``.zip`` (parsed as JSON only)."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as zf:
            data = json.loads(zf.read("data"))
    except FileNotFoundError:
        raise ConfigError(f"SB3 model file not found: {path}; give the .zip written by "
                          "model.save()", field="path") from None
    except OSError as exc:  # a directory, no permission, ...
        raise ConfigError(f"cannot read the SB3 model {path} ({exc.strerror or exc}); give "
                          "the .zip file written by model.save()", field="path") from None
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError) as exc:
        raise ConfigError(f"{path} is not a stable-baselines3 .zip model ({exc}); give the "
                          ".zip written by model.save()", field="path") from exc
    if not isinstance(data, dict):
        raise ConfigError(f"{path} is not a stable-baselines3 .zip model (bad 'data' entry); "
                          "give the .zip written by model.save()", field="path")
    return data


def detect_algorithm(path: str | os.PathLike[str]) -> str:
    """The algorithm that saved an SB3 ``.zip``, from its JSON metadata (no unpickling).

    Raises:
        ValueError: The file is not an SB3 zip, or its policy class is not one we know.
    """
    data = _read_data(path)
    policy = data.get("policy_class", {})
    module = policy.get("__module__", "") if isinstance(policy, dict) else ""
    if module.startswith("sb3_contrib.common.maskable"):
        return "MaskablePPO"
    if module == "agents.rl":  # MaskedDQNPolicy, the one policy class defined there
        return "MaskedDQN"
    if module == "stable_baselines3.dqn.policies":
        return "DQN"
    if module == "stable_baselines3.common.policies":
        # Shared by PPO and A2C; PPO's saved data has a clip range, A2C's does not.
        return "PPO" if "clip_range" in data else "A2C"
    raise ConfigError(f"cannot tell which algorithm saved {path} (its policy class is from "
                      f"{module or 'an unknown module'}); pass algo= one of "
                      f"{', '.join(ALGORITHMS)}", field="algo")


def _policy_kwargs(path: str | os.PathLike[str], saved: Any) -> dict[str, Any]:
    """The saved ``policy_kwargs`` without unpickling.

    Plain JSON is used as it is. When SB3 pickled the dict (because a value is a class),
    the JSON still lists every entry as text: the optimizer entries are dropped (the
    algorithm sets its own again, and inference does not use them) and the others must be
    Python literals (``net_arch=[64, 64]``), read with :func:`ast.literal_eval`.
    """
    if not isinstance(saved, dict):
        raise ConfigError(f"{path}: policy_kwargs in an unknown form; a dict is allowed",
                          field="path")
    if ":serialized:" not in saved:
        return saved
    out: dict[str, Any] = {}
    for key, text in saved.items():
        if key.startswith(":") or key in ("optimizer_class", "optimizer_kwargs"):
            continue
        try:
            out[key] = ast.literal_eval(str(text))
        except (ValueError, SyntaxError):
            raise ConfigError(
                f"{path}: policy_kwargs[{key!r}] = {text} is not a plain value; the suite "
                "loads only JSON metadata and weights (never pickle). Pass the model object "
                "to SB3Agent instead of a path", field="path"
            ) from None
    return out


def load_model(
    path: str | os.PathLike[str], algo: str | None = None, *, graph: TaskGraph | None = None
) -> BaseAlgorithm:
    """Rebuild a saved SB3 model from its JSON metadata and weights, without unpickling.

    Args:
        path: The ``.zip`` file.
        algo: One of :data:`ALGORITHMS`; by default read from the file's metadata.
        graph: The scenario the model acts in; by default recognised from the saved action
            space's size (10 actions: hanger, 12: wheel).

    Raises:
        ConfigError: (a ``ValueError``) Not a readable SB3 zip (a directory, say), an
            unknown algorithm or scenario, ``policy_kwargs`` that SB3 pickled, weights that
            hold Python objects besides tensors (never unpickled), or weights that do not fit
            the rebuilt network.
    """
    from hri_envs.envs.config import scenario_graph
    from hri_envs.envs.robot import RobotEnv

    name = detect_algorithm(path) if algo is None else algo
    cls = _algorithm_class(name)
    data = _read_data(path)
    policy_kwargs = _policy_kwargs(path, data.get("policy_kwargs", {}))
    if graph is None:
        n = str(data.get("action_space", {}).get("n", ""))
        by_actions = {str(spec.n_actions): name for name, spec in SCENARIOS.items()}
        if n not in by_actions:
            allowed = ", ".join(f"{k} {v}" for k, v in by_actions.items())
            raise ConfigError(f"{path}: cannot tell the scenario from the saved action space "
                              f"(n = {n or '?'}, allowed: {allowed}); pass graph=",
                              field="graph")
        graph = scenario_graph(by_actions[n])
    extra: dict[str, Any] = {"buffer_size": 1} if name in ("DQN", "MaskedDQN") else {}
    model = cls("MultiInputPolicy", RobotEnv(graph.name), policy_kwargs=policy_kwargs,
                device="cpu", **extra)
    try:
        model.set_parameters(str(path), exact_match=True, device="cpu")
    except pickle.UnpicklingError:
        # torch.load(weights_only=True) met a Python object other than tensors. Its own
        # message suggests weights_only=False, i.e. running the payload: not passed on.
        raise ConfigError(f"{path}: the saved weights hold Python objects other than tensors "
                          "(a pickle payload), which are never loaded; give a .zip written "
                          "by model.save() with plain PyTorch state dicts", field="path"
                          ) from None
    except (RuntimeError, ValueError, KeyError) as exc:
        raise ConfigError(f"{path}: the saved weights do not fit a {name} for the "
                          f"{graph.name} robot env ({exc}); pass the algo= and graph= it was "
                          "trained with", field="path") from exc
    return model


class _Policy:
    """Masked action selection for a batch of robot observations."""

    def __init__(self, model: BaseAlgorithm, graph: TaskGraph | None) -> None:
        from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
        from stable_baselines3 import DQN
        from stable_baselines3.common.policies import ActorCriticPolicy

        self.model = model
        self.is_q = isinstance(model, DQN)
        if not self.is_q and not isinstance(model.policy,
                                            ActorCriticPolicy | MaskableActorCriticPolicy):
            raise ConfigError(f"unsupported SB3 model {type(model).__name__}; allowed: "
                              f"{', '.join(ALGORITHMS)}", field="model")
        self.maskable = isinstance(model.policy, MaskableActorCriticPolicy)
        space = model.observation_space
        keys = tuple(getattr(space, "spaces", {}))
        if set(keys) != set(_OBS_KEYS):
            raise ConfigError(f"the model observes {keys or space}, not the robot's "
                              f"observation {_OBS_KEYS}; train it on hri_envs/Hanger-v0 or "
                              "Wheel-v0", field="model")
        self.n_actions = int(model.action_space.n)  # type: ignore[attr-defined]
        if graph is not None:
            n_s = int(space["state"].n)  # type: ignore[index]
            if (n_s, self.n_actions) != (graph.n_states, graph.n_actions):
                raise ConfigError(
                    f"the model was trained with {n_s} states and {self.n_actions} actions; "
                    f"the {graph.name} has {graph.n_states} states and {graph.n_actions} "
                    "actions; pass the graph it was trained on", field="graph"
                )

    def scores(self, obs: Mapping[str, Any]) -> tuple[np.ndarray, np.ndarray]:
        """(B, A) action probabilities (Q-values for DQN) and the (B, A) bool valid mask."""
        import torch as th

        batch = {k: np.asarray(obs[k]).reshape(-1, self.n_actions) if k == "action_mask"
                 else np.asarray(obs[k], dtype=np.int64).reshape(-1) for k in _OBS_KEYS}
        mask = batch["action_mask"] > 0
        policy: Any = self.model.policy  # a DQN, actor-critic or maskable policy
        tensors, _ = policy.obs_to_tensor(batch)
        with th.no_grad():
            if self.is_q:
                out = policy.q_net(tensors)
            elif self.maskable:
                out = policy.get_distribution(tensors, action_masks=mask).distribution.probs
            else:
                out = policy.get_distribution(tensors).distribution.probs
        return out.cpu().numpy().astype(np.float64), mask

    def actions(self, obs: Mapping[str, Any], deterministic: bool,
                uniforms: np.ndarray | None) -> np.ndarray:
        """(B,) valid actions: greedy, or sampled with the given (B,) uniforms."""
        scores, mask = self.scores(obs)
        if self.is_q or deterministic or uniforms is None:
            return np.argmax(np.where(mask, scores, -np.inf), axis=1)
        p = np.where(mask, scores, 0.0)
        total = p.sum(axis=1, keepdims=True)
        uniform = mask / mask.sum(axis=1, keepdims=True)  # if the model gives them all 0
        p = np.where(total > 0, p / np.where(total > 0, total, 1.0), uniform)
        cum = np.cumsum(p, axis=1)
        picked = (uniforms[:, None] >= cum).sum(axis=1)
        return np.minimum(picked, self.n_actions - 1)


def _as_model(path_or_model: Any, algo: str | None, graph: TaskGraph | None = None
              ) -> BaseAlgorithm:
    if isinstance(path_or_model, str | os.PathLike):
        return load_model(path_or_model, algo, graph=graph)
    return path_or_model


class SB3BatchAgent(BatchAgent):
    """A frozen SB3 model acting in ``n_runs`` runs at once (one forward pass per step).

    Args:
        path_or_model: A saved ``.zip`` (opened with :func:`load_model`) or a model object.
        n_runs: Number of runs.
        graph: The scenario's graph, to check that the model fits it (optional).
        deterministic: Most probable valid action, or sample (see the module docs).
        seed: Base seed of the sampling generators (run ``r`` uses ``(seed, r)``).
        runs: Run indices of this batch (default ``range(n_runs)``).
        algo: The algorithm that saved ``path_or_model``, if not to be detected.
    """

    name: ClassVar[str] = "sb3"

    def __init__(
        self,
        path_or_model: str | os.PathLike[str] | BaseAlgorithm,
        n_runs: int = 1,
        *,
        graph: TaskGraph | None = None,
        deterministic: bool = True,
        seed: int = 0,
        runs: Sequence[int] | None = None,
        algo: str | None = None,
    ) -> None:
        super().__init__(n_runs)
        self.model = _as_model(path_or_model, algo, graph)
        self.policy = _Policy(self.model, graph)
        self.deterministic = deterministic
        self.rngs = run_streams(seed, range(n_runs) if runs is None else runs)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Nothing to prepare: the model is memoryless."""

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The model's valid action in every run (randomness only for active runs)."""
        uniforms = None
        if not self.deterministic:
            uniforms = np.zeros(self.n_runs)
            for i in np.flatnonzero(active):
                uniforms[i] = self.rngs[i].random()
        return self.policy.actions(observations, self.deterministic, uniforms).astype(np.int64)

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Frozen model: nothing to record."""

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Frozen model: nothing to learn."""


class SB3Agent(Agent):
    """A frozen SB3 model as a single-stream robot agent.

    Args:
        path_or_model: A saved ``.zip`` (SB3's format, opened with the algorithm's
            weights only, no pickle; see the module docs) or a model object.
        graph: The scenario's graph, to check that the model fits it (optional).
        deterministic: Most probable valid action, or sample from the masked distribution.
        seed: Seed of the sampling generator.
        algo: The algorithm that saved ``path_or_model``, if not to be detected.

    Example::

        from agents.sb3 import SB3Agent
        robot = SB3Agent("ppo_hanger.zip")
        action = robot.act(observation)   # observation of hri_envs/Hanger-v0
    """

    name: ClassVar[str] = "sb3"

    def __init__(
        self,
        path_or_model: str | os.PathLike[str] | BaseAlgorithm,
        graph: TaskGraph | None = None,
        deterministic: bool = True,
        *,
        seed: int = 0,
        algo: str | None = None,
    ) -> None:
        self.model = _as_model(path_or_model, algo, graph)
        self.policy = _Policy(self.model, graph)
        self.deterministic = deterministic
        self.rng = np.random.default_rng(seed)

    def begin_episode(self, start: int) -> None:
        """Nothing to prepare: the model is memoryless."""

    def act(self, observation: Mapping[str, Any]) -> int:
        """The model's action, never an invalid one."""
        u = None if self.deterministic else np.array([self.rng.random()])
        return int(self.policy.actions(observation, self.deterministic, u)[0])

    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        """Frozen model: nothing to record."""

    def end_episode(self, trace: Trace, intention: int) -> None:
        """Frozen model: nothing to learn."""
