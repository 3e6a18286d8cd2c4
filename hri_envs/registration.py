"""Gymnasium ids of the suite, registered on ``import hri_envs``.

Versioned ids with string entry points (nothing is imported until an env is made), read
from the scenario registry (:mod:`hri_envs.task.scenarios`). ``vector_entry_point`` serves
``gymnasium.make_vec(id, num_envs, vectorization_mode="vector_entry_point")`` with the
numpy-batched :class:`~hri_envs.envs.vector.RobotVectorEnv` on the graph ids and with
:class:`~hri_envs.physics.panda.warp.vector.PandaVectorEnv` (N worlds on MuJoCo Warp, the
"mjwarp" extra) on the Panda ids, and with
:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv` on the continuous ids. The
envs truncate episodes
themselves (``max_cycles``), so no ``max_episode_steps`` is set.
"""

from __future__ import annotations

import gymnasium

from hri_envs.task.scenarios import SCENARIOS

__all__ = ["continuous_id", "register_envs"]

_ROBOT_ENV = "hri_envs.envs.robot:RobotEnv"
#: The Panda ids' env: a RobotEnv that refuses a backend other than a physics one.
_PANDA_ENV = "hri_envs.envs.robot:panda_env"
_ROBOT_VECTOR_ENV = "hri_envs.envs.vector:RobotVectorEnv"
#: The Panda ids' vector env: N worlds on MuJoCo Warp (the "mjwarp" extra).
_PANDA_VECTOR_ENV = "hri_envs.physics.panda.warp.vector:PandaVectorEnv"
_CONTINUOUS_ENV = "hri_envs.physics.carry.env:CarryEnv"
#: The continuous ids' vector env: N worlds on MuJoCo Warp (the "mjwarp" extra).
_CONTINUOUS_VECTOR_ENV = "hri_envs.physics.carry.env:vector_env"



def _specs() -> list[dict[str, object]]:
    """One robot env per scenario on the graph (with the numpy vector form), one on the
    simulated Franka Emika Panda (MuJoCo, mink IK, compliant control; needs the "mujoco"
    extra, see hri_envs.physics) and one continuous-control env on the Panda with the whole
    human arm. Ids come from the scenario registry.
    """
    out: list[dict[str, object]] = []
    for spec in SCENARIOS.values():
        if spec.gym_id is not None:
            out.append({"id": spec.gym_id, "entry_point": _ROBOT_ENV,
                        "vector_entry_point": _ROBOT_VECTOR_ENV,
                        "kwargs": {"scenario": spec.name}})
        if spec.panda_id is not None:
            out.append({"id": spec.panda_id, "entry_point": _PANDA_ENV,
                        "vector_entry_point": _PANDA_VECTOR_ENV,
                        "kwargs": {"scenario": spec.name, "backend": "mujoco"}})
        if spec.continuous_id is not None:  # continuous control with the whole human arm
            out.append({"id": spec.continuous_id, "entry_point": _CONTINUOUS_ENV,
                        "vector_entry_point": _CONTINUOUS_VECTOR_ENV,
                        "kwargs": {"scenario": spec.name}})
            # v1: the placing reward, the intention hidden from info (CarryEnv's history).
            out.append({"id": continuous_id(spec.continuous_id, 1),
                        "entry_point": _CONTINUOUS_ENV,
                        "vector_entry_point": _CONTINUOUS_VECTOR_ENV,
                        "kwargs": {"scenario": spec.name, "version": 1}})
    return out


def continuous_id(v0_id: str, version: int) -> str:
    """The id of ``version`` of a continuous env whose v0 id is ``v0_id``
    (``hri_envs/HangerPandaContinuous-v0`` → ``...-v1``).
    """
    base, _, _ = v0_id.rpartition("-v")
    return f"{base}-v{version}"


def register_envs() -> None:
    """Register every id of :data:`~hri_envs.task.scenarios.SCENARIOS` (idempotent; call it
    again after registering a scenario of your own).
    """
    for spec in _specs():
        if spec["id"] not in gymnasium.registry:
            gymnasium.register(**spec)  # type: ignore[arg-type]
