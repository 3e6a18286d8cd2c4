"""The physics on MuJoCo Warp: many worlds at once (``backend="mjwarp"``, the ``mjwarp`` extra).

=================  ==============================================================
module             contents
=================  ==============================================================
``device``         importing Warp, MuJoCo Warp and mink-warp; the kernel cache
``batchmath``      pose arithmetic over a leading axis of worlds
``model``          :class:`WarpModel`: N worlds of a compiled scene, host access
``control``        the compiled laws over the worlds: controller, wrist sensor,
                   seats; DAVI
``ik``             :class:`BatchIK`: the IK reference, one mink-warp step for all
``build``          the v0 Panda scene's worlds: per-world arrays, resets, switches
``events``         a world's abstract step: its start, phases and end
``period``         the v0 scene's control period, vectorised over the worlds
``worlds``         :class:`WarpWorlds`: N worlds of the Panda scene in lockstep
``episode``        the backend inside the v0 envs (``backend="mjwarp"``)
``batch``          the backend of ``hri-bench study --backend mjwarp``
``vector_base``    :class:`WorldsVectorEnv`: what the two vector envs share
``vector``         :class:`PandaVectorEnv`, ``gymnasium.make_vec(..., "vector_entry_point")``
``speed``          world-steps per second and real-time factor
``carry_human``    the continuous envs' whole arm per world: indices, hand impedance
``carry``          :class:`WarpCarryWorlds`: N worlds of the continuous envs' scene
``carry_sim``      the backend inside the continuous envs (one world)
``carry_vector``   :class:`CarryVectorEnv`: N continuous envs stepped together
=================  ==============================================================

Nothing here imports Warp until a world is built; a missing extra is a
:class:`~hri_envs.errors.MissingExtraError` with the install command. docs/physics.md,
"Many worlds on MuJoCo Warp", says how it relates to the C backend and how to run it on a GPU.
"""
