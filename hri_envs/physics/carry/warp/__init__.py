"""The continuous carry envs on MuJoCo Warp: N worlds stepped together.

``worlds`` (:class:`~hri_envs.physics.carry.warp.worlds.WarpCarryWorlds`: N worlds of the
continuous scene, each period running the C backend's compiled laws,
:mod:`hri_envs.physics.scene.laws`, over the worlds that step), ``human`` (the human's whole
arm per world: its indices, gains and hand impedance), ``sim`` (one world as a continuous
env's simulation, ``backend="mjwarp"``) and ``vector``
(:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`).

May import :mod:`~hri_envs.physics.carry`, :mod:`~hri_envs.physics.scene` and its ``warp``.
"""
