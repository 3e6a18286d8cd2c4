"""The robots of the continuous physical envs by name, for people in the loop and replays.

The physical evaluation's robots are registered in ``baselines.physical.PHYSICAL_AGENTS``
(each entry makes the agent for one run, ``entry(scenario, seed)``, and says whether it is
privileged). Where that registry is not installed yet, the two robots of
:mod:`baselines.continuous` stand in: ``passive`` (the floor) and ``learner`` (the paper's
Learner through motion primitives).

A person cannot face a privileged robot (a reference that reads the simulated human's
route, which a person does not have): :func:`check_robot` refuses them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from hri_envs.errors import ConfigError

if TYPE_CHECKING:  # the physics needs the mujoco extra, which the CLI may run without
    from agents.physical import PhysicalAgent

__all__ = ["DEFAULT_ORDER", "check_robot", "default_robot", "make_robot", "robot_names"]

#: The default robot: the first of these the registry has (the best shipped robots first:
#: docs/physical-baselines.md ranks the variable admittance closest to the upper reference).
DEFAULT_ORDER: tuple[str, ...] = ("variable-admittance", "admittance", "learner", "passive")


def _registry() -> dict[str, tuple[Callable[[str, int], PhysicalAgent], bool]]:
    """The registry: name -> (factory, privileged)."""
    try:
        module: Any = importlib.import_module("baselines.physical")
    except ImportError:
        from baselines.continuous import LiftedLearner, PassiveFloor  # noqa: PLC0415

        return {"passive": (lambda scenario, seed: PassiveFloor(), False),
                "learner": (lambda scenario, seed: LiftedLearner(scenario, seed=seed), False)}
    return {name: (entry, bool(entry.privileged))
            for name, entry in module.PHYSICAL_AGENTS.items()}


def robot_names(*, privileged: bool = False) -> tuple[str, ...]:
    """The registered robots' names (the privileged references too if asked)."""
    return tuple(n for n, (_, p) in _registry().items() if privileged or not p)


def default_robot() -> str:
    """The robot a person faces unless told otherwise (:data:`DEFAULT_ORDER`)."""
    names = robot_names()
    return next((n for n in DEFAULT_ORDER if n in names), names[0])


def check_robot(name: Any, field: str = "agent") -> str:
    """``name`` if it is a registered robot a person may face.

    Raises:
        ConfigError: Unknown, or a privileged reference (``field``), listing the allowed.
    """
    registry = _registry()
    allowed = ", ".join(robot_names())
    if not isinstance(name, str) or name not in registry:
        raise ConfigError(f"unknown physical robot {name!r}; allowed: {allowed}", field=field)
    if registry[name][1]:
        raise ConfigError(f"robot {name!r} is a reference that reads the simulated human's "
                          f"route and cannot face a person; allowed: {allowed}", field=field)
    return name


def make_robot(name: str, scenario: str, seed: int = 0) -> PhysicalAgent:
    """A new robot ``name`` for a session on ``scenario`` (``seed``: its own randomness)."""
    factory, _ = _registry()[check_robot(name)]
    return factory(scenario, int(seed))
