"""The shared scene and its numbers: what both env families simulate.

The Panda's model (``assets``), the scene built in code (``build``: supports, object, robot,
the wrist sensor; the robot's fixed numbers such as its fingers' positions), the shapes of
the object and the supports (``shapes``), every scenario's physical design (``design``),
poses and straight-line trajectories (``kinematics``), the mink IK reference (``ik``), the
Cartesian impedance controller and DAVI (``controller``), the wrist force/torque sensor and
its model (``sensing``), supports as seats (``seats``), contacts (``contacts``), the closest
abstract state and the human's inferred action (``observer``), cameras (``camera``) and
headless rendering (``rendering``); the control period's laws compiled over a leading axis of
worlds, which the C backends run with one world and MuJoCo Warp with N (``laws``: the wrist
sensor, the seats, the robot's impedance controller, the handle's wrench; their arithmetic
in ``lawmath``; the compiled code's cache in ``jit``). ``warp``: the same scene's N worlds
on MuJoCo Warp.

May import :mod:`hri_envs.task`, :mod:`hri_envs.errors` and :mod:`hri_envs.checks`; never the
env families (:mod:`~hri_envs.physics.panda`, :mod:`~hri_envs.physics.carry`) or a Warp
package.
"""

from typing import TYPE_CHECKING

from hri_envs.moved import old_names

if not TYPE_CHECKING:  # for Python only: a type checker sees the package's own names
    #: The public names of the module ``hri_envs.physics.scene``, before it became this package,
    #: still found here for one release (CHANGELOG.md, "Deprecated").
    __getattr__ = old_names(__name__, "hri_envs.physics.scene.build",
                            ("BASE_JOINTS", "Scene", "build_robot_model", "build_scene"))
