"""The discrete Panda backend on MuJoCo Warp: N worlds of the v0 scene in lockstep.

=================  ==============================================================
module             contents
=================  ==============================================================
``build``          the v0 Panda scene's worlds: per-world arrays, resets, switches
``events``         a world's abstract step: its start, phases and end
``period``         the v0 scene's control period, vectorised over the worlds
``worlds``         :class:`~hri_envs.physics.panda.warp.worlds.WarpWorlds`: N worlds
``episode``        the backend inside the v0 envs (``backend="mjwarp"``)
``batch``          the backend of ``hri-bench study --backend mjwarp``
``vector``         :class:`~hri_envs.physics.panda.warp.vector.PandaVectorEnv`
``speed``          world-steps per second and real-time factor
=================  ==============================================================

May import :mod:`~hri_envs.physics.panda`, :mod:`~hri_envs.physics.scene` and its ``warp``.
"""
