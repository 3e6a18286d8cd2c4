"""The physics: the cooperation tasks on a simulated Franka Emika Panda (MuJoCo).

Three packages, one per system; each says in its opening docstring what it holds and what it
may import (import-linter keeps it so: pyproject.toml, "Physics: ..."):

=================  ==========================================================================
package            contents
=================  ==========================================================================
``scene``          the shared scene and its numbers: the Panda model, the supports and the
                   object (``build``, ``shapes``, ``design``), poses (``kinematics``), the
                   IK reference (``ik``), the impedance controller (``controller``), the wrist
                   sensor (``sensing``), the seats (``seats``), contacts, the observer of
                   abstract states, cameras and rendering; the control period's laws
                   compiled over a world axis (``laws``)
``panda``          the discrete Panda backend of the v0 ids (``HangerPanda-v0``,
                   ``backend="mujoco"``): :class:`~hri_envs.physics.panda.sim.PandaSim`, one
                   abstract step of both agents; the hand on six joints; ``physics={...}``
                   options; the env's episode and the benchmark's batch
``carry``          the continuous carry envs (``*PandaContinuous-v0/v1``): the env and its
                   PettingZoo form, :class:`~hri_envs.physics.carry.sim.CarrySim` at 25 Hz,
                   its five control periods in one compiled call, rewards; its human
                   (``carry.human``): the whole arm, its body, intention, families and
                   frozen populations
=================  ==========================================================================

The MuJoCo Warp backend of each (many worlds at once, ``backend="mjwarp"``, the ``mjwarp``
extra) is its ``warp`` sub-package: ``scene.warp`` (Warp itself, a scene's N worlds, the
batched IK), ``panda.warp``, ``carry.warp``. The two families stand on the scene, never on
each other; a Warp package stands on the C modules beside it, never under them.

Importing this package selects MuJoCo's headless OpenGL backend (``MUJOCO_GL``) unless it
is set already; do so before anything imports ``mujoco`` to render. Without the "mujoco"
extra it raises :class:`~hri_envs.errors.MissingExtraError`, whose message is the one line
that says what to install (every Panda and continuous id, backend and command that
simulates the physics imports this package first). Module names from before the physics
was split into these packages still import for one release, with a ``DeprecationWarning``
(CHANGELOG.md, "Deprecated").
"""

from hri_envs.errors import MissingExtraError

MissingExtraError.require(["mujoco", "mink", "gymnasium_robotics"],
                          "the physics (the Panda and continuous envs, backend='mujoco')")

from hri_envs.physics.scene.rendering import select_gl_backend  # noqa: E402

select_gl_backend()

from hri_envs.physics.panda.sim import PandaSim, StepResult  # noqa: E402
from hri_envs.physics.scene.design import PhysicsDesign, design_for  # noqa: E402
from hri_envs.physics.scene.ik import IKFailure  # noqa: E402
from hri_envs.physics.scene.rendering import SceneRenderer, write_video  # noqa: E402

__all__ = [
    "IKFailure",
    "PandaSim",
    "PhysicsDesign",
    "SceneRenderer",
    "StepResult",
    "design_for",
    "select_gl_backend",
    "write_video",
]
