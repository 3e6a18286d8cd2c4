"""A trained JAX PPO policy as a robot agent of the protocol (``--agents jaxppo:PATH``).

:class:`JaxPPOAgent` plays a checkpoint of :mod:`agents.jax_ppo.train` in studies and the
suite: per run a GRU state, kept across the run's episodes (as over a training trial), and
the same inputs training saw (:class:`~agents.jax_ppo.network.Inputs`): the observation,
its own previous action, the episode's first step, and where the previous episode ended,
which the protocol reveals in ``end_episode``. It acts greedily (the most probable valid
action), so it is deterministic; it does not learn between episodes (its memory adapts).

``PATH`` is a ``.npz`` checkpoint, or a folder holding ``<scenario>.npz`` per scenario (so
one name serves the suite's hanger and wheel tracks).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np

from agents.jax_ppo import checkpoint
from agents.jax_ppo.network import Inputs, NetConfig, apply, masked_logits, param_shapes
from agents.protocol import BatchAgent, Trace
from hri_envs.errors import ConfigError, LearnerStateError
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph

__all__ = ["JaxPPOAgent", "checkpoint_path", "load_checked"]


def checkpoint_path(path: str | os.PathLike[str], scenario: str) -> Path:
    """The checkpoint for ``scenario``: ``path`` itself, or ``path/<scenario>.npz``.

    Raises:
        ConfigError: Neither exists (``field="agents"``).
    """
    p = Path(path)
    if p.is_dir():
        p = p / f"{scenario}.npz"
    if not p.is_file():
        raise ConfigError(f"no JAX PPO checkpoint at {str(p)!r}; give 'jaxppo:FILE.npz' or "
                          "'jaxppo:FOLDER' with <scenario>.npz, as written by "
                          "benchmarks/train_jax_ppo.py", field="agents")
    return p


def load_checked(path: str | os.PathLike[str], graph: TaskGraph
                 ) -> tuple[Path, dict[str, np.ndarray], dict[str, Any]]:
    """``(file, arrays, config)`` of the checkpoint for ``graph``'s scenario, checked to fit
    it; numpy only (JAX's runtime is not started, so a process may still fork after it).

    Raises:
        ConfigError: No checkpoint there (``field="agents"``).
        LearnerStateError: Not a checkpoint, one trained on another scenario, weights that
            are not all finite (:func:`~agents.jax_ppo.checkpoint.load`), or weights that
            do not fit its network's sizes.
    """
    file = checkpoint_path(path, graph.name)
    arrays, config = checkpoint.load(file)
    net = config.get("net")
    if (config.get("scenario") != graph.name or not isinstance(net, dict)
            or (net.get("n_states"), net.get("n_actions")) != (graph.n_states,
                                                              graph.n_actions)):
        raise LearnerStateError(f"{str(file)!r} was trained on the "
                                f"{config.get('scenario')!r} scenario; this study is the "
                                f"{graph.name}")
    try:
        sizes = NetConfig(**net)
        want = param_shapes(sizes)
    except TypeError as exc:
        raise LearnerStateError(f"{str(file)!r}: its network sizes {net!r} are not a "
                                f"NetConfig's ({exc})") from None
    if (sizes.n_supports, type(sizes.hidden)) != (graph.n_intentions, int) or sizes.hidden < 1:
        raise LearnerStateError(f"{str(file)!r}: its network sizes {net!r} do not fit the "
                                f"{graph.name} (K = {graph.n_intentions}, hidden >= 1)")
    got = {k: tuple(v.shape) for k, v in arrays.items()}
    if got != want:
        wrong = sorted(k for k in set(got) | set(want) if got.get(k) != want.get(k))
        raise LearnerStateError(
            f"{str(file)!r}: its weights do not fit its network ({', '.join(wrong[:4])}: "
            f"{[got.get(k) for k in wrong[:4]]}, expected {[want.get(k) for k in wrong[:4]]})")
    return file, arrays, config


@jax.jit
def _act(params: dict[str, jax.Array], x: Inputs, h: jax.Array
         ) -> tuple[jax.Array, jax.Array]:
    h, logits, _ = apply(params, x, h)
    return h, jnp.argmax(masked_logits(logits, x.mask), axis=-1)


class JaxPPOAgent(BatchAgent):
    """A frozen recurrent PPO policy for ``n_runs`` runs (see the module docstring).

    Args:
        path: The checkpoint (or a folder of them, one per scenario).
        graph: The task graph of the study's scenario (must match the checkpoint's).
        n_runs: Runs advanced together.
    """

    name: ClassVar[str] = "jaxppo"

    def __init__(self, path: str | os.PathLike[str], graph: TaskGraph, n_runs: int) -> None:
        super().__init__(n_runs)
        file, arrays, config = load_checked(path, graph)
        net = config["net"]
        self.net = NetConfig(**net)
        self.config: dict[str, Any] = config
        self.path = file
        self.params = {k: jnp.asarray(v) for k, v in arrays.items()}
        n = n_runs
        self.hidden = jnp.zeros((n, self.net.hidden))
        self.prev_action = np.full(n, WAIT, np.int32)
        self.last_end = np.full(n, graph.n_intentions, np.int32)  # K: nothing revealed yet
        self.first = np.ones(n, bool)
        self._k = graph.n_intentions

    def begin_episode(self, starts: np.ndarray) -> None:
        """A new episode: the previous action is a wait, the next step is the first."""
        self.prev_action[:] = WAIT
        self.first[:] = True

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The most probable valid action of each run (inactive runs keep their state)."""
        x = Inputs(jnp.asarray(observations["state"], jnp.int32),
                   jnp.asarray(observations["start"], jnp.int32),
                   jnp.asarray(observations["last_human_action"], jnp.int32),
                   jnp.asarray(observations["action_mask"], jnp.int8),
                   jnp.asarray(self.prev_action), jnp.asarray(self.last_end),
                   jnp.asarray(self.first))
        hidden, action = _act(self.params, x, self.hidden)
        act = np.asarray(active, bool)
        self.hidden = jnp.where(jnp.asarray(act)[:, None], hidden, self.hidden)
        action = np.asarray(action, dtype=np.int64)
        self.prev_action = np.where(act, action, self.prev_action).astype(np.int32)
        self.first &= ~act
        return action

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Nothing: the next observation carries what the step showed."""

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Remember where each episode ended (K where it was cut off: nothing revealed)."""
        ends = np.asarray(intentions, dtype=np.int64)
        self.last_end = np.where(ends >= 0, ends, self._k).astype(np.int32)
