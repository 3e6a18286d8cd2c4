"""The physics on MuJoCo Warp: many worlds at once (``backend="mjwarp"``, the ``mjwarp`` extra).

=================  ==============================================================
module             contents
=================  ==============================================================
``device``         importing Warp, MuJoCo Warp and mink-warp; the kernel cache
``batchmath``      pose arithmetic over a leading axis of worlds
``worlds``         :class:`WarpWorlds`: N worlds of the Panda scene in lockstep
``episode``        the backend inside the envs (``backend="mjwarp"``)
``batch``          the backend of ``hri-bench study --backend mjwarp``
``vector``         :class:`PandaVectorEnv`, ``gymnasium.make_vec(..., "vector_entry_point")``
``speed``          world-steps per second and real-time factor
=================  ==============================================================

Nothing here imports Warp until a world is built; a missing extra is a
:class:`~hri_envs.errors.MissingExtraError` with the install command. docs/physics.md,
"Many worlds on MuJoCo Warp", says how it relates to the C backend and how to run it on a GPU.
"""
