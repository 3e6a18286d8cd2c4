"""The functional JAX env (the ``jax`` extra): reset and step as pure functions.

``from hri_envs.jax import JaxRobotEnv`` needs ``jax``; without it the import raises
:class:`~hri_envs.errors.MissingExtraError` with the one command that installs it.
``import hri_envs`` never imports this package. See :mod:`hri_envs.jax.env` and
docs/rl.md, "Recurrent PPO in JAX".
"""

from hri_envs.errors import MissingExtraError

MissingExtraError.require(["jax"], "the JAX env (hri_envs.jax)")

from hri_envs.jax.env import (  # noqa: E402  (after the check, so it says what to install)
    EnvParams,
    EnvState,
    JaxRobotEnv,
    Member,
    ResetDraws,
    StepDraws,
    uniforms,
)

__all__ = ["EnvParams", "EnvState", "JaxRobotEnv", "Member", "ResetDraws", "StepDraws",
           "uniforms"]
