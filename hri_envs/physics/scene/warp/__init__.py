"""The physics on MuJoCo Warp: many worlds at once (``backend="mjwarp"``, the ``mjwarp`` extra).

What both families' Warp backends (:mod:`hri_envs.physics.panda.warp`,
:mod:`hri_envs.physics.carry.warp`) share:

=================  ==============================================================
module             contents
=================  ==============================================================
``device``         importing Warp, MuJoCo Warp and mink-warp; the kernel cache
``batchmath``      pose arithmetic over a leading axis of worlds
``model``          :class:`WarpModel`: N worlds of a compiled scene, host access
``control``        the compiled laws over the worlds: controller, wrist sensor,
                   seats; DAVI
``ik``             :class:`BatchIK`: the IK reference, one mink-warp step for all
``handout``        worlds a vector env built, handed to the single envs it builds
``vector_base``    :class:`WorldsVectorEnv`: what the two vector envs share
=================  ==============================================================

Nothing here imports Warp until a world is built; a missing extra is a
:class:`~hri_envs.errors.MissingExtraError` with the install command. docs/physics.md,
"Many worlds on MuJoCo Warp", says how it relates to the C backend and how to run it on a GPU.
"""
