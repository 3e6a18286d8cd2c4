"""The continuous env's arguments: ``sensor=``, the action's scale and ``population=`` checked,
and ``vector_env``, the continuous ids' vector entry point.

:class:`~hri_envs.physics.carry.env.CarryEnv` and its vector form on MuJoCo Warp
(:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`) check their arguments here.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hri_envs.checks import check_real
from hri_envs.envs.backends import carry_vector_backend
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph

__all__ = ["SENSOR_KEYS", "check_population", "check_sensor", "check_step_scale", "vector_env"]

#: The keys of ``sensor=`` (the wrist sensor model's overrides).
SENSOR_KEYS: tuple[str, ...] = ("noise_n", "bias_n", "delay_s")


def check_sensor(sensor: Any) -> dict[str, float]:
    """``sensor=`` (None or a mapping of :data:`SENSOR_KEYS` to finite numbers >= 0) as a
    dict.

    Raises:
        ConfigError: (``field="sensor"``) Anything else: a NaN or inf would reach the
            observation from the first step.
    """
    if sensor is None:
        return {}
    allowed = f"None or a mapping of {', '.join(SENSOR_KEYS)} to finite numbers >= 0"
    if not isinstance(sensor, Mapping):
        raise ConfigError(f"sensor must be {allowed}, got {sensor!r}", field="sensor")
    bad = sorted(map(repr, set(sensor) - set(SENSOR_KEYS)))
    if bad:
        raise ConfigError(f"unknown sensor key(s) {', '.join(bad)}; sensor must be {allowed}",
                          field="sensor")
    return {key: check_real(value, "sensor", low=0.0, label=f"sensor {key!r}",
                            allowed="a finite number >= 0")
            for key, value in sensor.items()}


def check_step_scale(max_step_m: Any, max_step_rad: Any) -> None:
    """The action's scale: ``max_step_m`` [m] and ``max_step_rad`` [rad], finite and > 0.

    Raises:
        ConfigError: (``field`` the argument) Anything else (an infinite step would command
            an infinite target).
    """
    for key, value in (("max_step_m", max_step_m), ("max_step_rad", max_step_rad)):
        check_real(value, key, low=0.0, low_open=True, allowed="a finite number > 0")


def vector_env(num_envs: int = 1, scenario: str = "hanger", *, backend: str = "mjwarp",
               **kwargs: Any) -> Any:
    """``num_envs`` continuous envs stepped together on ``backend`` (the continuous ids'
    ``vector_entry_point``: ``gymnasium.make_vec(id, num_envs=N,
    vectorization_mode="vector_entry_point")``); keyword arguments: those of
    :class:`~hri_envs.physics.carry.env.CarryEnv` and of the vector env
    (:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`).

    Raises:
        ConfigError: ``backend`` has no vector form of these envs.
    """
    return carry_vector_backend(backend)(num_envs, scenario, backend=backend, **kwargs)


def check_population(name: Any, graph: TaskGraph) -> Any:
    """The physical human population ``name`` of ``graph``'s scenario (v1's
    ``population=``).
    """
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    if not isinstance(name, str):
        raise ConfigError(f"population must be a population's name, got {name!r}",
                          field="population")
    return physical_population(name, graph)
