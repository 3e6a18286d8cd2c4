"""PPO with a GRU policy, trained end to end in JAX against a population of scripted humans.

Everything of an update runs under one ``jit``: ``rollout`` steps of ``num_envs``
:class:`~hri_envs.jax.JaxRobotEnv` envs (``lax.scan``), GAE, and ``epochs`` passes of
clipped-PPO minibatch updates, each re-running the GRU over its envs' whole rollout from the
hidden state it started with (truncated back-propagation through time). :func:`train` runs
``chunk`` updates per compiled call and logs after each.

The envs run in *trials*: ``episodes_per_trial`` episodes with one human drawn from the
population (the suite's runs: 8 hanger / 20 wheel episodes with one partner); the GRU state
is kept across a trial's episodes and cleared when a new human comes, and the return (GAE)
runs over the whole trial, so what the robot learns about its partner in one episode pays
in the next. Sampling draws one uniform per env and step (inverse CDF), from a hash like the
env's, not a ``jax.random.categorical`` per env and step: on a CPU random draws are a large
part of a step's cost (docs/rl.md, "What a step of the JAX env costs": the env's own draws
take about a quarter of its step).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from agents.jax_ppo import checkpoint
from agents.jax_ppo.config import MAX_TRIAL, TrainConfig, make_env, training_population
from agents.jax_ppo.network import Inputs, NetConfig, Params, apply, init_params, masked_logits
from hri_envs.jax.env import EnvState, JaxRobotEnv, uniform
from hri_envs.task.actions import WAIT

__all__ = ["MAX_TRIAL", "TrainConfig", "TrainResult", "make_env", "sample_actions", "train",
           "training_population"]


class Memory(NamedTuple):
    """The robot's bookkeeping besides the observation (each (N,)).

    Attributes:
        prev_action: int32, its previous action in the episode (wait at the start).
        last_end: int32, where the previous episode ended (K: none).
        first: bool, the next step is an episode's first.
        new_trial: bool, the next step starts a trial (the GRU state is cleared).
    """

    prev_action: jax.Array
    last_end: jax.Array
    first: jax.Array
    new_trial: jax.Array


class Runner(NamedTuple):
    """What one update hands the next."""

    params: Params
    opt_state: Any
    env_state: EnvState
    obs: dict[str, jax.Array]
    memory: Memory
    hidden: jax.Array
    episode_return: jax.Array
    key: jax.Array


class TrainResult(NamedTuple):
    """A finished training run.

    Attributes:
        params: The trained weights (numpy).
        config: The training config.
        net: The network's sizes.
        curve: Per update: ``steps``, ``episode_return`` (mean over the episodes that ended
            in the update), ``return_by_episode`` (per episode index in the trial),
            ``entropy``, ``value_loss``, and ``seconds`` (wall, per chunk's updates).
        seconds: Training wall time, compilation included.
        compile_seconds: The first chunk's extra time (compilation), estimated.
    """

    params: dict[str, np.ndarray]
    config: TrainConfig
    net: NetConfig
    curve: dict[str, list[Any]]
    seconds: float
    compile_seconds: float


def inputs_of(obs: dict[str, jax.Array], memory: Memory) -> Inputs:
    """The network's inputs from an observation and the robot's memory."""
    return Inputs(obs["state"], obs["start"], obs["last_human_action"], obs["action_mask"],
                  memory.prev_action, memory.last_end, memory.first)


def sample_actions(logits: jax.Array, mask: jax.Array, u: jax.Array) -> jax.Array:
    """(N,) actions from masked logits (N, A) with one uniform each (inverse CDF)."""
    masked = masked_logits(logits, mask)
    cum = jnp.cumsum(jax.nn.softmax(masked, axis=-1), axis=-1)
    a = jnp.minimum(jnp.sum(u[:, None] >= cum, axis=-1), logits.shape[-1] - 1)
    ok = jnp.take_along_axis(mask, a[:, None], axis=-1)[:, 0].astype(bool)
    return jnp.where(ok, a, jnp.argmax(masked, axis=-1)).astype(jnp.int32)


def random_policy_return(cfg: TrainConfig, steps: int = 400, n: int = 2048) -> float:
    """Mean episode return of a robot acting uniformly at random over the valid actions, in
    ``cfg``'s training env (the level a trained policy must beat; seeded by ``cfg.seed``).
    """
    env = make_env(cfg)
    params = env.default_params

    @jax.jit
    def run(key: jax.Array) -> jax.Array:
        obs, state = env.reset_batch(key, n, params)
        zeros = jnp.zeros(obs["action_mask"].shape)

        def body(carry: tuple, t: jax.Array) -> tuple:
            obs, state, ret, total, count = carry
            seed = jax.random.bits(jax.random.fold_in(key, 2 * t), (2,), jnp.uint32)
            action = sample_actions(zeros, obs["action_mask"],
                                    uniform(seed, jnp.arange(n, dtype=jnp.uint32), 0))
            obs, state, r, done, _ = env.step_batch(jax.random.fold_in(key, 2 * t + 1), state,
                                                    action, params)
            ret = ret + r
            total, count = total + jnp.sum(ret * done), count + jnp.sum(done)
            return (obs, state, ret * ~done, total, count), None

        zero = jnp.zeros(())
        (_, _, _, total, count), _ = jax.lax.scan(body, (obs, state, jnp.zeros(n), zero, zero),
                                                  jnp.arange(steps))
        return total / count

    return float(run(jax.random.key(cfg.seed + 1)))


def _make_update(cfg: TrainConfig, env: JaxRobotEnv, optimizer: optax.GradientTransformation
                 ) -> Callable[[Runner, Any], tuple[Runner, dict[str, jax.Array]]]:
    env_params = env.default_params
    n, t_roll, k = cfg.num_envs, cfg.rollout, env.n_supports
    n_trial = cfg.trial_length()
    env_index = jnp.arange(n, dtype=jnp.uint32)

    def rollout_step(carry: tuple, _: Any) -> tuple[tuple, tuple]:
        params, env_state, obs, memory, hidden, ep_ret, key, sums, counts = carry
        key, k_act, k_env = jax.random.split(key, 3)
        x = inputs_of(obs, memory)
        h_in = jnp.where(memory.new_trial[:, None], 0.0, hidden)
        hidden, logits, value = apply(params, x, h_in)
        seed = jax.random.bits(k_act, (2,), jnp.uint32)
        action = sample_actions(logits, x.mask, uniform(seed, env_index, 0))
        logp = jax.nn.log_softmax(masked_logits(logits, x.mask))
        logp_a = jnp.take_along_axis(logp, action[:, None], axis=-1)[:, 0]
        episode = env_state.episode
        obs, env_state, reward, done, info = env.step_batch(k_env, env_state, action, env_params)
        ended_on = jnp.where(info["terminated"], env_params.support[info["final_state"]], k)
        last_end = jnp.where(info["new_trial"], k, jnp.where(done, ended_on, memory.last_end))
        memory_next = Memory(jnp.where(done, WAIT, action).astype(jnp.int32),
                             last_end.astype(jnp.int32), done, info["new_trial"])
        ep_ret = ep_ret + reward
        finished = done.astype(reward.dtype)
        sums = sums.at[episode].add(ep_ret * finished)
        counts = counts.at[episode].add(finished)
        ep_ret = ep_ret * (1.0 - finished)
        out = (x, memory.new_trial, action, logp_a, value, reward, info["new_trial"])
        return (params, env_state, obs, memory_next, hidden, ep_ret, key, sums, counts), out

    grad_fn = jax.value_and_grad(functools.partial(_sequence_loss, cfg), has_aux=True)

    def update(runner: Runner, _: Any) -> tuple[Runner, dict[str, jax.Array]]:
        params = runner.params
        h0 = jnp.where(runner.memory.new_trial[:, None], 0.0, runner.hidden)
        zeros = jnp.zeros(n_trial, jnp.float32)
        carry = (params, runner.env_state, runner.obs, runner.memory, runner.hidden,
                 runner.episode_return, runner.key, zeros, zeros)
        carry, traj = jax.lax.scan(rollout_step, carry, None, length=t_roll)
        _, env_state, obs, memory, hidden, ep_ret, key, sums, counts = carry
        x, reset, action, logp, value, reward, trial_done = traj
        h_last = jnp.where(memory.new_trial[:, None], 0.0, hidden)
        _, _, last_value = apply(params, inputs_of(obs, memory), h_last)
        adv = _advantages(cfg, reward, value, trial_done, last_value)
        batch = (x, reset, action, logp, adv, adv + value)
        key, k_epochs = jax.random.split(key)
        params, opt_state, v_loss, entropy = _ppo_epochs(cfg, optimizer, grad_fn, params,
                                                         runner.opt_state, h0, batch, k_epochs)
        metrics = {"episode_return": sums.sum() / jnp.maximum(counts.sum(), 1.0),
                   "return_by_episode": sums / jnp.maximum(counts, 1.0),
                   "entropy": entropy.mean(), "value_loss": v_loss.mean()}
        runner = Runner(params, opt_state, env_state, obs, memory, hidden, ep_ret, key)
        return runner, metrics

    return update


def _sequence_loss(cfg: TrainConfig, params: Params, h0: jax.Array, batch: tuple
                   ) -> tuple[jax.Array, tuple]:
    """Clipped-PPO loss of a minibatch's envs, the GRU re-run over their whole rollout from
    the hidden states ``h0`` they started with; aux ``(value loss, entropy)``.
    """
    x, reset, action, logp_old, adv, target = batch

    def step(h: jax.Array, xs: tuple) -> tuple[jax.Array, tuple]:
        xi, ri = xs
        h = jnp.where(ri[:, None], 0.0, h)
        h, logits, value = apply(params, xi, h)
        return h, (logits, value)

    _, (logits, value) = jax.lax.scan(step, h0, (x, reset))
    masked = masked_logits(logits, x.mask)
    logp = jax.nn.log_softmax(masked)
    logp_a = jnp.take_along_axis(logp, action[..., None], axis=-1)[..., 0]
    ratio = jnp.exp(logp_a - logp_old)
    adv_n = (adv - adv.mean()) / (adv.std() + 1e-8)
    pg = -jnp.minimum(ratio * adv_n,
                      jnp.clip(ratio, 1 - cfg.clip, 1 + cfg.clip) * adv_n).mean()
    v_loss = 0.5 * ((value - target) ** 2).mean()  # unclipped: trial returns are large
    probs = jnp.exp(logp)
    entropy = -jnp.sum(jnp.where(x.mask.astype(bool), probs * logp, 0.0), axis=-1).mean()
    loss = pg + cfg.vf_coef * v_loss - cfg.ent_coef * entropy
    return loss, (v_loss, entropy)


def _advantages(cfg: TrainConfig, reward: jax.Array, value: jax.Array, trial_done: jax.Array,
                last_value: jax.Array) -> jax.Array:
    """(T, N) GAE over the rollout (scaled rewards; a trial's end cuts the return)."""

    def gae(next_: tuple, xs: tuple) -> tuple[tuple, jax.Array]:
        adv_next, v_next = next_
        r, v, d = xs
        live = 1.0 - d.astype(r.dtype)
        delta = r + cfg.gamma * v_next * live - v
        adv = delta + cfg.gamma * cfg.gae_lambda * live * adv_next
        return (adv, v), adv

    _, adv = jax.lax.scan(gae, (jnp.zeros(cfg.num_envs), last_value),
                          (reward * cfg.reward_scale, value, trial_done), reverse=True)
    return adv


def _ppo_epochs(cfg: TrainConfig, optimizer: optax.GradientTransformation, grad_fn: Callable,
                params: Params, opt_state: Any, h0: jax.Array, batch: tuple,
                key: jax.Array) -> tuple[Params, Any, jax.Array, jax.Array]:
    """``epochs`` passes of minibatch updates (the envs shuffled into ``minibatches``);
    returns the new params and optimiser state, and the value losses and entropies.
    """

    def epoch(state: tuple, key_e: jax.Array) -> tuple[tuple, tuple]:
        params, opt_state = state
        order = jax.random.permutation(key_e, cfg.num_envs).reshape(cfg.minibatches, -1)

        def minibatch(state: tuple, idx: jax.Array) -> tuple[tuple, tuple]:
            params, opt_state = state
            mb = jax.tree.map(lambda a: a[:, idx], batch)
            (_, aux), grads = grad_fn(params, h0[idx], mb)
            updates, opt_state = optimizer.update(grads, opt_state, params)
            return (optax.apply_updates(params, updates), opt_state), aux

        return jax.lax.scan(minibatch, (params, opt_state), order)

    (params, opt_state), (v_loss, entropy) = jax.lax.scan(
        epoch, (params, opt_state), jax.random.split(key, cfg.epochs))
    return params, opt_state, v_loss, entropy


def _init(cfg: TrainConfig, env: JaxRobotEnv, net: NetConfig,
          optimizer: optax.GradientTransformation) -> Runner:
    key = jax.random.key(cfg.seed)
    key, k_net, k_env = jax.random.split(key, 3)
    params = init_params(k_net, net)
    obs, env_state = env.reset_batch(k_env, cfg.num_envs, env.default_params)
    n = cfg.num_envs
    memory = Memory(jnp.full(n, WAIT, jnp.int32), jnp.full(n, env.n_supports, jnp.int32),
                    jnp.ones(n, bool), jnp.ones(n, bool))
    return Runner(params, optimizer.init(params), env_state, obs, memory,
                  jnp.zeros((n, net.hidden)), jnp.zeros(n), key)


@functools.lru_cache(maxsize=4)
def _compiled(cfg: TrainConfig) -> tuple[JaxRobotEnv, NetConfig, optax.GradientTransformation,
                                         Callable[[Runner], tuple[Runner, Any]]]:
    """The env, network sizes, optimiser and jitted chunk of updates of ``cfg`` (kept, so a
    second training with the same config does not compile again).
    """
    env = make_env(cfg)
    net = NetConfig(env.n_states, env.n_supports, env.n_actions, cfg.hidden)
    schedule = optax.linear_schedule(cfg.lr, 0.0, cfg.updates * cfg.epochs * cfg.minibatches)
    optimizer = optax.chain(optax.clip_by_global_norm(cfg.max_grad_norm),
                            optax.adam(schedule, eps=1e-5))
    update = _make_update(cfg, env, optimizer)

    @jax.jit
    def run_chunk(runner: Runner) -> tuple[Runner, dict[str, jax.Array]]:
        return jax.lax.scan(update, runner, None, length=cfg.chunk)

    return env, net, optimizer, run_chunk


def train(cfg: TrainConfig, *, log: Callable[[str], None] | None = None,
          save_to: str | None = None) -> TrainResult:
    """Train a policy; optionally save it (:func:`agents.jax_ppo.checkpoint.save`).

    Args:
        cfg: What and how long.
        log: Called with one line after every chunk of updates (e.g. ``print``).
        save_to: A ``.npz`` path for the trained policy.
    """
    cfg.check()
    env, net, optimizer, run_chunk = _compiled(cfg)
    t_start = time.perf_counter()
    runner = _init(cfg, env, net, optimizer)
    curve: dict[str, list[Any]] = {k: [] for k in ("steps", "episode_return",
                                                    "return_by_episode", "entropy",
                                                    "value_loss", "seconds")}
    chunk_times = []
    for c in range(cfg.updates // cfg.chunk):
        t0 = time.perf_counter()
        runner, metrics = run_chunk(runner)
        metrics = jax.device_get(metrics)
        dt = time.perf_counter() - t0
        chunk_times.append(dt)
        for i in range(cfg.chunk):
            u = c * cfg.chunk + i + 1
            curve["steps"].append(u * cfg.steps_per_update)
            curve["episode_return"].append(float(metrics["episode_return"][i]))
            curve["return_by_episode"].append([float(v) for v in
                                               metrics["return_by_episode"][i]])
            curve["entropy"].append(float(metrics["entropy"][i]))
            curve["value_loss"].append(float(metrics["value_loss"][i]))
            curve["seconds"].append(dt / cfg.chunk)
        if log is not None:
            steps = (c + 1) * cfg.chunk * cfg.steps_per_update
            log(f"update {(c + 1) * cfg.chunk}/{cfg.updates}  steps {steps:,}  "
                f"episode return {curve['episode_return'][-1]:.3f}  "
                f"entropy {curve['entropy'][-1]:.3f}  "
                f"{cfg.chunk * cfg.steps_per_update / dt:,.0f} steps/s")
    seconds = time.perf_counter() - t_start
    steady = float(np.median(chunk_times[1:])) if len(chunk_times) > 1 else chunk_times[0]
    compile_s = max(0.0, chunk_times[0] - steady)
    params = {k: np.asarray(v) for k, v in jax.device_get(runner.params).items()}
    result = TrainResult(params, cfg, net, curve, seconds, compile_s)
    if save_to is not None:
        save(save_to, result)
    return result


def save(path: str, result: TrainResult) -> None:
    """Write a trained policy as a checkpoint (the network, the scenario, the config)."""
    checkpoint.save(path, result.params, {
        "scenario": result.config.scenario, "net": result.net.to_dict(),
        "train": result.config.to_dict(), "train_seconds": round(result.seconds, 2),
        "final_episode_return": result.curve["episode_return"][-1]})
