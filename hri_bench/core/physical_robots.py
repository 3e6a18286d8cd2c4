"""The robots of the continuous physical envs a person may face (people in the loop, replays).

The robots are :data:`baselines.physical.PHYSICAL_AGENTS` (each entry makes the agent for
one run, ``entry(graph, seed)``, and says whether it is privileged). A person cannot face
a privileged robot (a reference that reads the simulated human's route, which a person
does not have): :func:`check_robot` refuses them. The registry is imported when asked: it
imports the physics (the ``mujoco`` extra), which the CLI runs without.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from hri_envs.errors import ConfigError

if TYPE_CHECKING:
    from agents.physical import PhysicalAgent
    from hri_envs.task.graph import TaskGraph

__all__ = ["DEFAULT_ROBOT", "check_robot", "default_robot", "make_robot", "robot_names"]

#: The robot a person faces unless told otherwise: the best shipped robot that feels the
#: human (docs/physical-benchmark.md, "Results").
DEFAULT_ROBOT = "variable-admittance"


def robot_names(*, privileged: bool = False) -> tuple[str, ...]:
    """The registered robots' names (the privileged references too if asked)."""
    from baselines.physical import PHYSICAL_AGENTS  # noqa: PLC0415

    return tuple(n for n, e in PHYSICAL_AGENTS.items() if privileged or not e.privileged)


def default_robot() -> str:
    """The robot a person faces unless told otherwise (:data:`DEFAULT_ROBOT`)."""
    return DEFAULT_ROBOT


def check_robot(name: Any, field: str = "agent") -> str:
    """``name`` if it is a registered robot a person may face.

    Raises:
        ConfigError: Unknown, or a privileged reference (``field``), listing the allowed.
    """
    allowed = robot_names()
    if isinstance(name, str) and name in allowed:
        return name
    why = ("is a reference that reads the simulated human's route and cannot face a person"
           if isinstance(name, str) and name in robot_names(privileged=True)
           else "is not a physical robot")
    raise ConfigError(f"robot {name!r} {why}; allowed: {', '.join(allowed)}", field=field)


def make_robot(name: str, graph: TaskGraph, seed: int = 0) -> PhysicalAgent:
    """A new robot ``name`` for a session on ``graph``'s scenario (``seed``: its own
    randomness).
    """
    from baselines.physical import make_physical_agent  # noqa: PLC0415

    return make_physical_agent(check_robot(name), graph, int(seed))
