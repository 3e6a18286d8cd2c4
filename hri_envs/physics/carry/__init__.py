"""The continuous carry envs: the robot's grip targets at 25 Hz and a whole human arm.

``hri_envs/HangerPandaContinuous-v0/v1`` and ``WheelPandaContinuous-v0/v1``: the env
(``env``: :class:`~hri_envs.physics.carry.env.CarryEnv`, its arguments checked in
``options``) and its PettingZoo form (``parallel``), the simulation of one step (``sim``:
:class:`~hri_envs.physics.carry.sim.CarrySim`, with ``types``, ``simulation``, ``faults``;
the end-of-step rules, faults, strain and placement, written once over worlds in ``rules``),
its five control periods compiled in one call (``stages``, ``periods``, MuJoCo's C functions
in ``mjc``) from the laws written once over a leading axis of worlds (the scene's,
:mod:`hri_envs.physics.scene.laws`; the human's in ``human.laws``), the interaction measures
(``interaction``), the rewards and figures (``reward``) and what a robot may know
(``robot_view``). ``human``: the human (the whole arm, its body and drives, the intention
conveyed by force, families, frozen populations). ``warp``: N worlds of these envs on MuJoCo Warp.

May import :mod:`~hri_envs.physics.scene`, :mod:`hri_envs.envs`, :mod:`hri_envs.humans`,
:mod:`hri_envs.task`; never :mod:`~hri_envs.physics.panda`.
"""

from typing import TYPE_CHECKING

from hri_envs.moved import old_names

if not TYPE_CHECKING:  # for Python only: a type checker sees the package's own names
    #: The public names of the module ``hri_envs.physics.carry``, before it became this package,
    #: still found here for one release (CHANGELOG.md, "Deprecated").
    __getattr__ = old_names(__name__, "hri_envs.physics.carry.sim",
                            ("DRIVES", "CarrySim", "CarryStep",
                             "RobotCommand", "default_grip_force", "grip_reference"))
