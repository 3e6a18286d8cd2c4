"""Gymnasium ids of the suite, registered on ``import hri_envs``.

One flat list of versioned ids with string entry points (nothing is imported until an env
is made). ``vector_entry_point`` serves
``gymnasium.make_vec(id, num_envs, vectorization_mode="vector_entry_point")`` with the
numpy-batched :class:`~hri_envs.envs.vector.RobotVectorEnv`. The envs truncate episodes
themselves (``max_cycles``), so no ``max_episode_steps`` is set.
"""

from __future__ import annotations

import gymnasium

__all__ = ["register_envs"]

_ROBOT_ENV = "hri_envs.envs.robot:RobotEnv"
_ROBOT_VECTOR_ENV = "hri_envs.envs.vector:RobotVectorEnv"

_SPECS: tuple[dict[str, object], ...] = (
    # Robot vs a scripted human on the abstract transition graph.
    {"id": "hri_envs/Hanger-v0", "entry_point": _ROBOT_ENV,
     "vector_entry_point": _ROBOT_VECTOR_ENV, "kwargs": {"scenario": "hanger"}},
    {"id": "hri_envs/Wheel-v0", "entry_point": _ROBOT_ENV,
     "vector_entry_point": _ROBOT_VECTOR_ENV, "kwargs": {"scenario": "wheel"}},
    # The same tasks on a simulated Franka Emika Panda (MuJoCo, mink IK, compliant control);
    # needs the "mujoco" extra. See hri_envs.physics.
    {"id": "hri_envs/HangerPanda-v0", "entry_point": _ROBOT_ENV,
     "kwargs": {"scenario": "hanger", "backend": "mujoco"}},
    {"id": "hri_envs/WheelPanda-v0", "entry_point": _ROBOT_ENV,
     "kwargs": {"scenario": "wheel", "backend": "mujoco"}},
)


def register_envs() -> None:
    """Register every id above with Gymnasium (idempotent)."""
    for spec in _SPECS:
        if spec["id"] not in gymnasium.registry:
            gymnasium.register(**spec)  # type: ignore[arg-type]
