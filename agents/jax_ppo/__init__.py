"""A recurrent PPO robot trained end to end in JAX (the ``jax`` extra).

- :mod:`agents.jax_ppo.network`: the GRU actor-critic as pure functions of a dict of arrays;
- :mod:`agents.jax_ppo.train`: PPO under one ``jit`` (rollouts on
  :class:`~hri_envs.jax.JaxRobotEnv`, GAE, updates) in trials of K episodes with one human;
- :mod:`agents.jax_ppo.config`: its :class:`~agents.jax_ppo.config.TrainConfig` (checked,
  JSON-ready) and the population and env it trains in;
- :mod:`agents.jax_ppo.agent`: a saved policy as a :class:`~agents.protocol.BatchAgent`
  (``hri-bench ... --agents jaxppo:PATH``);
- :mod:`agents.jax_ppo.checkpoint`: ``.npz`` of arrays and a JSON config, no pickle.

Importing a submodule without ``jax`` raises :class:`~hri_envs.errors.MissingExtraError`
with the install command.
"""

from hri_envs.errors import MissingExtraError

MissingExtraError.require(["jax", "optax"], "the JAX PPO learner (agents.jax_ppo)")
