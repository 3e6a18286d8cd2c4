"""The JAX figures of ``hri-bench speed``: the functional env and PPO training, per second.

Both need the ``jax`` extra; :func:`measure_jax` reports what it cannot measure instead
of failing (``hri-bench speed`` works without the extra). The env figure is
:func:`hri_envs.jax.speed.jax_env_steps_per_s` (the numpy vector env's workload, jit +
vmap over 4,096 to 65,536 envs, the fastest reported), set against the numpy vector env's
figure of the same run; the training figure is :func:`agents.jax_ppo.train.train` at its
default sizes (1,024 envs × 32 steps per update, GRU of 32), timed over a chunk of updates
after the compiled one.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from hri_envs.errors import ConfigError, MissingExtraError

__all__ = ["JAX_SIZES", "JaxSpeedSize", "measure_jax"]


class JaxSpeedSize(NamedTuple):
    """How much work the JAX figures do.

    Attributes:
        env_envs: Env counts of the JAX env (vmap) to time; the fastest is reported.
        env_steps: Batched steps per timed call.
        env_repeats: Timed calls (the fastest counts).
        ppo_envs: Envs of the PPO training.
        ppo_rollout: Steps per env and update.
        ppo_updates: Updates per timed chunk (one chunk compiles, the next is timed).
    """

    env_envs: tuple[int, ...]
    env_steps: int
    env_repeats: int
    ppo_envs: int
    ppo_rollout: int
    ppo_updates: int


#: ``"full"``: the published figures; ``"tiny"``: everything for real, in seconds.
JAX_SIZES: dict[str, JaxSpeedSize] = {
    "full": JaxSpeedSize((4096, 16_384, 65_536), 200, 3, 1024, 32, 10),
    "tiny": JaxSpeedSize((1024,), 10, 1, 64, 8, 1),
}


def measure_jax(size: str = "full", vector_env_steps_per_s: float | None = None,
                ppo: Any = None) -> dict[str, Any]:
    """The JAX figures as a dict (``jax_*`` keys), or ``{"jax": "<not installed ...>"}``.

    Args:
        size: A key of :data:`JAX_SIZES`.
        vector_env_steps_per_s: The numpy vector env's figure of the same run, for the ratio.
        ppo: The :class:`~agents.jax_ppo.train.TrainConfig` to time instead of the size's
            (its last chunk of updates is timed; at least two chunks).
    """
    if size not in JAX_SIZES:
        raise ConfigError(f"size must be one of {sorted(JAX_SIZES)}, got {size!r}",
                          field="size")
    try:
        MissingExtraError.require(["jax", "optax"], "the JAX figures")
    except MissingExtraError as exc:
        return {"jax": f"not installed: {exc}"}
    from agents.jax_ppo.train import TrainConfig, train  # jax: imported once checked above
    from hri_envs.jax.speed import jax_env_steps_per_s

    z = JAX_SIZES[size]
    runs = [jax_env_steps_per_s(n, steps=z.env_steps, repeats=z.env_repeats)
            for n in z.env_envs]
    env = max(runs, key=lambda r: r.steps_per_s)
    cfg = ppo or TrainConfig(num_envs=z.ppo_envs, rollout=z.ppo_rollout, chunk=z.ppo_updates,
                             total_steps=2 * z.ppo_updates * z.ppo_envs * z.ppo_rollout)
    result = train(cfg)
    timed = sum(result.curve["seconds"][-cfg.chunk:])
    out: dict[str, Any] = {
        "jax_device": env.device,
        "jax_env_envs": env.num_envs,
        "jax_env_steps_per_s": round(env.steps_per_s, 1),
        "jax_env_steps_per_s_by_envs": {r.num_envs: round(r.steps_per_s) for r in runs},
        "jax_ppo_train_steps_per_s": round(cfg.chunk * cfg.steps_per_update / timed, 1),
    }
    if vector_env_steps_per_s:
        out["jax_env_vs_vector_env"] = round(env.steps_per_s / vector_env_steps_per_s, 2)
    return out
