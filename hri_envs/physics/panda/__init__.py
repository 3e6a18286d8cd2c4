"""The discrete Panda backend of the v0 ids: the task graph's steps on the simulated Panda.

``gymnasium.make("hri_envs/HangerPanda-v0")`` and ``backend="mujoco"`` of the graph envs and
of ``hri-bench study``: one abstract step of both agents becomes a grasp or let-go and a
motion until the object settles (``sim``: :class:`~hri_envs.physics.panda.sim.PandaSim`;
``steps``: the step's plan, result and faults; ``grasp``: the robot's grasp and weld);
the human is a hand on six joints (``human_arm``) whose reach is decided in ``human``;
``options`` are the ``physics={...}`` options and presets; ``episode`` is the backend inside
the envs, ``batch`` the benchmark's, ``speed`` its real-time factor. ``warp``: the same
steps for N worlds on MuJoCo Warp.

May import :mod:`~hri_envs.physics.scene`, :mod:`hri_envs.envs` (the episode it is a backend
of), :mod:`hri_envs.task`, :mod:`hri_envs.humans`; never :mod:`~hri_envs.physics.carry`.
"""
