"""The recurrent actor-critic: embeddings of what the robot sees, a GRU, two heads.

Pure functions of a parameter dict (the checkpoint's arrays, :mod:`agents.jax_ppo.checkpoint`),
shared by training and the agent. Per step the robot sees (:class:`Inputs`) the state, the
start support, the human's last action, the action mask, its own previous action, whether
this is an episode's first step and where the previous episode ended (the intention the
protocol reveals in ``end_episode``; K = none yet, or cut off). ι is never an input. The
state is embedded together with the start support (one row per pair): whether the object
rests on its start or on a goal changes every right action there. The
GRU's state carries over the episodes of a trial, so it can infer the human's intention
and preference from what it saw.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

__all__ = ["Inputs", "NetConfig", "apply", "init_params", "masked_logits", "param_shapes"]

Params = dict[str, jax.Array]


@dataclass(frozen=True)
class NetConfig:
    """The network's sizes.

    Attributes:
        n_states: S.
        n_supports: K.
        n_actions: A.
        hidden: H, width of the embeddings and of the GRU.
    """

    n_states: int
    n_supports: int
    n_actions: int
    hidden: int = 64

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready."""
        return asdict(self)


class Inputs(NamedTuple):
    """What the robot sees in a step (each with the batch's leading axes).

    Attributes:
        state, start, last_human: int32, the observation's ``state``, ``start`` and
            ``last_human_action``.
        mask: (..., A) the observation's ``action_mask`` (0/1).
        prev_action: int32, the robot's previous action in the episode (wait at its start).
        last_end: int32, where the previous episode ended, K for none (first episode of a
            trial, or cut off at the step limit).
        first: bool, the episode's first step.
    """

    state: jax.Array
    start: jax.Array
    last_human: jax.Array
    mask: jax.Array
    prev_action: jax.Array
    last_end: jax.Array
    first: jax.Array


def param_shapes(cfg: NetConfig) -> dict[str, tuple[int, ...]]:
    """The shape of each parameter :func:`init_params` makes (to check a checkpoint)."""
    h, a, k = cfg.hidden, cfg.n_actions, cfg.n_supports
    return {"emb_state": (cfg.n_states * k, h), "emb_start": (k, h), "emb_human": (a, h),
            "emb_prev": (a, h), "emb_end": (2 * (k + 1), h), "w_mask": (a, h), "b_in": (h,),
            "gru_wx": (h, 3 * h), "gru_wh": (h, 3 * h), "gru_b": (3 * h,), "gru_bhn": (h,),
            "pi_w": (h, a), "pi_b": (a,), "v_w": (h, 1), "v_b": (1,)}


def init_params(key: jax.Array, cfg: NetConfig) -> Params:
    """Initial parameters: embeddings N(0, 1/H), orthogonal-ish GRU and heads (scaled)."""
    h, a, k = cfg.hidden, cfg.n_actions, cfg.n_supports
    keys = jax.random.split(key, 10)

    def normal(key: jax.Array, shape: tuple[int, ...], scale: float) -> jax.Array:
        return jax.random.normal(key, shape) * scale

    return {
        "emb_state": normal(keys[0], (cfg.n_states * k, h), 1.0 / h**0.5),  # (state, start)
        "emb_start": normal(keys[1], (k, h), 1.0 / h**0.5),
        "emb_human": normal(keys[2], (a, h), 1.0 / h**0.5),
        "emb_prev": normal(keys[3], (a, h), 1.0 / h**0.5),
        "emb_end": normal(keys[4], (2 * (k + 1), h), 1.0 / h**0.5),  # (first, last_end)
        "w_mask": normal(keys[5], (a, h), 1.0 / a**0.5),
        "b_in": jnp.zeros(h),
        "gru_wx": normal(keys[6], (h, 3 * h), 1.0 / h**0.5),
        "gru_wh": normal(keys[7], (h, 3 * h), 1.0 / h**0.5),
        "gru_b": jnp.zeros(3 * h),
        "gru_bhn": jnp.zeros(h),
        "pi_w": normal(keys[8], (h, a), 0.01 / h**0.5),
        "pi_b": jnp.zeros(a),
        "v_w": normal(keys[9], (h, 1), 1.0 / h**0.5),
        "v_b": jnp.zeros(1),
    }


def apply(params: Params, x: Inputs, h: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """One step: ``(h', logits, value)`` from the inputs and the GRU state ``h`` (..., H).

    Logits are not masked (see :func:`masked_logits`).
    """
    end = x.last_end + (params["emb_start"].shape[0] + 1) * x.first.astype(jnp.int32)
    k = params["emb_start"].shape[0]
    z = (params["emb_state"][x.state * k + x.start] + params["emb_start"][x.start]
         + params["emb_human"][x.last_human] + params["emb_prev"][x.prev_action]
         + params["emb_end"][end] + x.mask.astype(h.dtype) @ params["w_mask"] + params["b_in"])
    z = jax.nn.relu(z)
    gx = z @ params["gru_wx"] + params["gru_b"]
    gh = h @ params["gru_wh"]
    n = h.shape[-1]
    r = jax.nn.sigmoid(gx[..., :n] + gh[..., :n])
    u = jax.nn.sigmoid(gx[..., n:2 * n] + gh[..., n:2 * n])
    c = jnp.tanh(gx[..., 2 * n:] + r * (gh[..., 2 * n:] + params["gru_bhn"]))
    h = (1.0 - u) * c + u * h
    logits = h @ params["pi_w"] + params["pi_b"]
    value = (h @ params["v_w"] + params["v_b"])[..., 0]
    return h, logits, value


def masked_logits(logits: jax.Array, mask: jax.Array) -> jax.Array:
    """Logits with invalid actions at -1e9 (never chosen, no gradient through them)."""
    return jnp.where(mask.astype(bool), logits, -1e9)
