"""The physics backend: the cooperation tasks on a simulated Franka Emika Panda (MuJoCo).

=================  ==============================================================
module             contents
=================  ==============================================================
``assets``         the Panda MJCF and meshes from the gymnasium-robotics wheel
``design``         per-scenario physical design: robot placement, grasp, gains
``scene``          the scene built in code (``MjSpec``): supports, object, Panda
``kinematics``     poses, quaternions, straight-line minimum-jerk trajectories
``ik``             mink (daqp) differential IK for the reference configurations
``controller``     Cartesian impedance + null space + DAVI (disagreement-aware)
``sensing``        the wrist force/torque sensor: compensation, noise, bias, delay
``contacts``       reading contacts: floor touches, finger forces on the grip
``options``        ``physics={...}`` options, presets and per-episode randomisation
``human``          the simulated human's saturating spring-damper on the handle
``seats``          supports as unilateral seats (hook, peg, plate)
``shapes``         the object's and the supports' geometry per scenario design
``observer``       closest abstract state, human-action inference
``sim``            :class:`PandaSim`: one abstract step of both agents
``episode``        the backend inside the envs (``backend="mujoco"``)
``batch``          :class:`PhysicsBatch`, the backend of ``hri-bench study --backend mujoco``
``speed``          real-time factor and wall time per abstract step
``rendering``      headless ``rgb_array`` (EGL, OSMesa fallback), labels, videos
``camera``         the pictures' camera fitted to the scene; projecting points into them
``mjwarp``         the same physics, many worlds at once on MuJoCo Warp (``"mjwarp"``)
``whole_arm``      the continuous envs' human: a whole arm on a torso, friction grip
``muscles``        the same arm muscle-driven: MyoSuite's ``myoarm_r`` (``arm`` extra)
``arm_control``    the arm's hand impedance and its torque drive
``intention``      the human's route, minimum-jerk reference and yielding; parameters
``body``           the human's body size: de Leva's segments, ANSUR II statures, strength
``families``       families of physical humans (ranges of their parameters, sources)
``probe``          a physical human's behavioural signature and distance
``population``     frozen physical populations: train, validation, test per scenario
``population_build``  how they were drawn, distinct by behaviour
``carry``          :class:`CarrySim`: robot, whole arm and object stepped at 25 Hz
``human_laws``     the human's control-period laws, compiled, over a world axis
``laws``           sensor, seats, robot controller, handle: the same, compiled
``lawmath``        compiled pose arithmetic on plain floats (MuJoCo's formulas)
``carry_stages``   a step's five control periods in one compiled call (C backend)
``carry_periods``  the compiled stages bound to a :class:`CarrySim`
``mjc``            MuJoCo's C functions for compiled code (``mj_step1``, ...)
``jit``            the compiled kernels' decorator and cache (numba)
``continuous``     the continuous-control Gymnasium env (``*PandaContinuous-v0``)
``continuous_parallel``  its PettingZoo parallel form (the human seat as an agent)
=================  ==============================================================

Importing this package selects MuJoCo's headless OpenGL backend (``MUJOCO_GL``) unless it
is set already; do so before anything imports ``mujoco`` to render. Without the "mujoco"
extra it raises :class:`~hri_envs.errors.MissingExtraError`, whose message is the one line
that says what to install (every Panda and continuous id, backend and command that
simulates the physics imports this package first).
"""

from hri_envs.errors import MissingExtraError

MissingExtraError.require(["mujoco", "mink", "gymnasium_robotics"],
                          "the physics (the Panda and continuous envs, backend='mujoco')")

from hri_envs.physics.scene.rendering import select_gl_backend  # noqa: E402

select_gl_backend()

from hri_envs.physics.scene.design import PhysicsDesign, design_for  # noqa: E402
from hri_envs.physics.scene.ik import IKFailure  # noqa: E402
from hri_envs.physics.scene.rendering import SceneRenderer, write_video  # noqa: E402
from hri_envs.physics.panda.sim import PandaSim, StepResult  # noqa: E402

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
