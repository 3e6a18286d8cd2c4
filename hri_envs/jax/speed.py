"""Throughput of the JAX env, for ``hri-bench speed`` (beside the numpy envs' figures).

The workload is :func:`hri_envs.envs.speed.vector_env_steps_per_s`'s: the hanger's default
scripted human, the robot a random valid action per env looked up from a table drawn
before the clock starts (64 draws per state, an offset per env and step); here ``steps``
batched steps of ``num_envs`` envs run under one ``jit`` as a ``lax.scan``, with the env's
own draws (autoresets) from one key per step. The compilation is done before timing.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from hri_envs.envs.speed import valid_choices
from hri_envs.jax.env import JaxRobotEnv

__all__ = ["JaxSpeedResult", "device_name", "jax_env_steps_per_s"]


class JaxSpeedResult(NamedTuple):
    """A throughput measurement of the JAX env."""

    steps_per_s: float
    steps: int
    seconds: float
    num_envs: int
    device: str


def device_name() -> str:
    """The default JAX device, e.g. ``"cpu (TFRT_CPU_0)"``."""
    dev = jax.devices()[0]
    return f"{dev.platform} ({dev})"


def jax_env_steps_per_s(num_envs: int = 65_536, scenario: str = "hanger", steps: int = 200,
                        repeats: int = 3, seed: int = 0,
                        population: str | None = None) -> JaxSpeedResult:
    """Env steps per second (num_envs × steps) of :meth:`JaxRobotEnv.step_batch` under jit.

    Args:
        num_envs: Envs stepped together (vmap).
        scenario: "hanger" or "wheel".
        steps: Batched steps per timed call (one ``lax.scan``).
        repeats: Timed calls; the fastest counts.
        seed: Seed of the action table and of the env's key.
        population: The humans to draw from (:class:`JaxRobotEnv`'s ``population``; None:
            the scenario's default scripted human, the published figure's workload).
    """
    env = JaxRobotEnv(scenario, population=population)
    params = env.default_params
    rng = np.random.default_rng(seed)
    n_s = env.graph.n_states
    table = jnp.asarray(valid_choices(env.graph, rng, 64).reshape(-1), dtype=jnp.int32)  # (64 S,)
    offsets = jnp.asarray(rng.integers(64, size=(64, num_envs)) * n_s, dtype=jnp.int32)

    @jax.jit
    def run(key: jax.Array) -> jax.Array:
        obs, state = env.reset_batch(key, num_envs, params)

        def body(carry: tuple, t: jax.Array) -> tuple:
            obs, state, total = carry
            action = table.at[offsets[t & 63] + obs["state"]].get(  # in range by construction
                mode="promise_in_bounds", wrap_negative_indices=False)
            obs, state, reward, _, _ = env.step_batch(jax.random.fold_in(key, t), state,
                                                      action, params)
            return (obs, state, total + reward.sum()), None

        carry, _ = jax.lax.scan(body, (obs, state, jnp.zeros(())), jnp.arange(steps))
        return carry[2]

    key = jax.random.key(seed)
    run(key).block_until_ready()  # compile
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        run(key).block_until_ready()
        best = min(best, time.perf_counter() - t0)
    return JaxSpeedResult(steps * num_envs / best, steps * num_envs, float(best), num_envs,
                          device_name())
