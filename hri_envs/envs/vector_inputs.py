"""The checks of what the numpy vector env is given: its backend, its reset options and
the robots' actions (:class:`~hri_envs.envs.vector.RobotVectorEnv`).

Each refuses a bad value with a :class:`~hri_envs.errors.ConfigError` (or, for actions, an
:class:`~hri_envs.errors.ActionError`) naming what it takes, and returns the value in the
form the env steps with.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hri_envs.envs.backends import backend_spec
from hri_envs.envs.config import RESET_OPTION_KEYS, check_options_mapping, support_index
from hri_envs.errors import ActionError, ConfigError
from hri_envs.task.geometry import Scenario

__all__ = ["VECTOR_OPTION_KEYS", "check_robot_actions", "check_vector_backend",
           "reset_supports", "turn_back_option", "vector_reset_options"]

#: The reset options the vector env takes: ``"start"``, ``"intention"``, ``"turn_back"``.
VECTOR_OPTION_KEYS = RESET_OPTION_KEYS[:3]


def check_vector_backend(backend: str) -> None:
    """Refuse a backend that simulates: the numpy vector env runs on the graph only."""
    spec = backend_spec(backend)
    if not spec.vectorizable:
        batched = ("; or the Panda ids' vector entry point, whose worlds step together on "
                   "MuJoCo Warp: gymnasium.make_vec('hri_envs/HangerPanda-v0', num_envs=N, "
                   "vectorization_mode='vector_entry_point')"
                   if spec.vector_entry is not None else "")
        raise ConfigError(
            f"the numpy vector env runs on the graph only, not backend={backend!r}; "
            "use gymnasium.make_vec(..., vectorization_mode='async') for a simulated backend"
            + batched, field="backend"
        )


def vector_reset_options(options: dict[str, Any] | None) -> dict[str, Any]:
    """``reset``'s options as a new dict, refusing a key other than
    :data:`VECTOR_OPTION_KEYS`.
    """
    options = dict(check_options_mapping({} if options is None else options))
    unknown = sorted(map(repr, set(options) - set(VECTOR_OPTION_KEYS)))
    if unknown:
        raise ConfigError(
            f"unknown reset option(s) {', '.join(unknown)} for the vector env; "
            f"allowed: {', '.join(VECTOR_OPTION_KEYS)}", field="options"
        )
    return options


def reset_supports(value: Any, key: str, scenario: Scenario, num_envs: int) -> np.ndarray:
    """(num_envs,) int64 support indices from reset option ``key``: one support (index or
    name) for every env, or one per env.
    """
    items = np.asarray(value, dtype=object)
    if items.ndim > 1 or items.size not in (1, num_envs):
        raise ConfigError(
            f"reset option {key!r} must be one support or {num_envs} of them "
            f"(shape ({num_envs},)), got shape {items.shape}", field=key
        )
    items = items.reshape(-1)
    idx = np.array([support_index(v, scenario, key) for v in items], dtype=np.int64)
    return np.broadcast_to(idx, (num_envs,)).copy()


def turn_back_option(value: Any, n: int) -> np.ndarray:
    """(n,) bool from reset option ``"turn_back"``: a bool for every env, or one per env."""
    turn = np.asarray(value)
    if turn.dtype != np.bool_ or turn.shape not in ((), (1,), (n,)):
        raise ConfigError(f"reset option 'turn_back' must be a bool or {n} bools "
                          f"(shape ({n},)), got {turn.dtype} of shape {turn.shape}",
                          field="turn_back")
    return np.broadcast_to(turn, (n,))


def check_robot_actions(actions: Any, n: int, n_a: int) -> np.ndarray:
    """The robots' actions as an (n,) int64 array of actions ``0 .. n_a - 1``, else an
    :class:`~hri_envs.errors.ActionError`.
    """
    a = np.asarray(actions)
    if a.shape != (n,) or a.dtype.kind not in "iu":
        raise ActionError(
            f"robot actions must be an integer array of shape ({n},) in the action space "
            f"MultiDiscrete([{n_a}] * {n}): integers 0..{n_a - 1}; got {a.dtype} {a.shape}"
        )
    a64 = a.astype(np.int64, copy=False)
    if a64.view(np.uint64).max() >= n_a:  # negative actions wrap round to huge ones
        bad = a[(a < 0) | (a >= n_a)]
        raise ActionError(
            f"robot action(s) {bad[:5].tolist()} outside the robot's action space: "
            f"valid actions are 0..{n_a - 1}"
        )
    return a64
