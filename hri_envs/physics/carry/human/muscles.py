"""The muscle-driven whole arm: MyoSuite's arm model (``myoarm_r`` of the ``myo-sim``
package, Apache-2.0, the "arm" extra) in the carrying scene.

:func:`build` loads ``myoarm_r`` with ``myo_sim.load_spec`` and puts it into the scene with
``MjSpec.attach`` on the torso carrier of :func:`~hri_envs.physics.carry.human.whole_arm.add_torso`
(turned so that the model faces the robot), and adds the palm, finger pad and handle of
:func:`~hri_envs.physics.carry.human.whole_arm.add_grip` on its third metacarpal. Changes to the
model:
its floor is removed; its finger joints are removed (the fingers are rigid: the finger pad
grips, the finger muscles still act across the wrist); none of its geoms collide; its
bodies carry their own weight (``gravcomp``), as the torque-driven arm's do.

The arm's independent coordinates are its 7 joints ``elv_angle``, ``shoulder_elv``,
``shoulder_rot``, ``elbow_flexion``, ``pro_sup``, ``deviation`` and ``flexion``; the
shoulder girdle's joints follow them through the model's polynomial joint equalities
(:class:`MuscleCoupling`). :class:`MuscleDrive` turns the joint torques the human's
controller asks for into muscle excitations each control period by a small bounded
least-squares problem::

    min_a ‖A a + b - τ‖² + λ‖a‖²   subject to 0 <= a <= 1,
    A = Cᵀ Mᵀ diag(g(l, v)),  b = Cᵀ Mᵀ f_p(l, v)

with M the muscles' moment arms, g their active force per unit activation at the current
length and velocity (MuJoCo's ``mju_muscleGain``), f_p their passive force
(``mju_muscleBias``) and C the coupling (``scipy.optimize.lsq_linear``, method "bvls").
MuJoCo's activation dynamics then turn the excitations into activations (10-40 ms).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable

import mujoco
import numpy as np

from hri_envs.errors import MissingExtraError
from hri_envs.physics.carry.human.arm_control import ArmDrive
from hri_envs.physics.carry.human.whole_arm import (
    Coupling,
    WholeArm,
    add_grip,
    add_torso,
    grip_quat_world,
)
from hri_envs.physics.scene.build import Scene, build_scene
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.task.geometry import Scenario

__all__ = ["MUSCLE_JOINTS", "MUSCLE_POSTURE", "MuscleCoupling", "MuscleDrive", "build"]

_PREFIX = "myo_"
#: The muscle model's independent joints (from the shoulder to the wrist).
MUSCLE_JOINTS: tuple[str, ...] = tuple(_PREFIX + n for n in (
    "elv_angle_r", "shoulder_elv_r", "shoulder_rot_r", "elbow_flexion_r", "pro_sup_r",
    "deviation_r", "flexion_r"))
#: Its comfortable posture [rad]: the arm raised ahead, the elbow bent.
MUSCLE_POSTURE = np.array([1.3, 0.6, 0.0, 1.4, 0.0, 0.0, 0.0])
_HAND_BODY = "thirdmc_r"
_GRIP_IN_HAND = np.array([0.0, -0.035, -0.02])  # [m] the palm, off the third metacarpal
_REGULARIZATION = 1e-4  # λ of the activation problem


#: What MuJoCo says each time myo-sim composes ``myoarm_r`` (it attaches the arm to its
#: scaffold without a prefix; we attach the result with :data:`_PREFIX`, so it does not
#: apply): dropped, not printed nor written to ``MUJOCO_LOG.TXT`` (:func:`_quiet_load`).
_EMPTY_PREFIX_WARNING = "Attaching a spec with an empty prefix"


def _quiet_load(name: str) -> mujoco.MjSpec:
    """``myo_sim.load_spec(name)`` without MuJoCo's empty-prefix warning.

    MuJoCo's default warning handler prints to the terminal and appends to
    ``MUJOCO_LOG.TXT`` in the current folder; for the duration of the load a handler of our
    own drops that one warning and passes any other on (to the handler installed before,
    else as a Python warning).
    """
    import myo_sim  # noqa: PLC0415

    previous = mujoco.get_mju_user_warning()

    def handler(message: str) -> None:
        if message.startswith(_EMPTY_PREFIX_WARNING):
            return
        if previous is not None:
            previous(message)
        else:
            warnings.warn(f"MuJoCo: {message}", RuntimeWarning, stacklevel=2)

    mujoco.set_mju_user_warning(handler)
    try:
        return myo_sim.load_spec(name)
    finally:
        mujoco.set_mju_user_warning(previous)


def _myo_spec() -> mujoco.MjSpec:
    """``myoarm_r`` without its floor and finger joints, nothing colliding, self-carried."""
    MissingExtraError.require(["myo_sim", "scipy"], "the muscle-driven arm (drive='muscle')")
    myo = _quiet_load("myoarm_r")
    floor = myo.geom("floor")
    if floor is not None:
        myo.delete(floor)
    for joint in list(myo.joints):
        if myo_sim_finger(joint.name):
            myo.delete(joint)
    for geom in myo.geoms:
        geom.contype, geom.conaffinity = 0, 0
    for body in myo.bodies:
        body.gravcomp = 1.0
    return myo


def myo_sim_finger(name: str) -> bool:
    """Whether a ``myoarm_r`` joint moves a finger or the thumb (below the wrist)."""
    return any(k in name for k in ("cmc_", "mp_", "ip_", "mcp", "pm", "md"))


def _attach(spec: mujoco.MjSpec, grip_pos: np.ndarray, grip_quat: np.ndarray,
            design: PhysicsDesign, rest_quat: np.ndarray, with_grip: bool) -> None:
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    torso = add_torso(spec, visuals=False)
    # MyoSuite's model faces -y with its pelvis at z = 1 m; the torso frame looks along +x.
    c = math.cos(math.pi / 4)
    frame = torso.add_frame(pos=[0.0, 0.0, -1.0], quat=[c, 0.0, 0.0, c])
    spec.attach(_myo_spec(), prefix=_PREFIX, frame=frame)
    if with_grip:
        add_grip(spec, spec.body(_PREFIX + _HAND_BODY), grip_pos, grip_quat, design,
                 rest_quat)


class MuscleCoupling(Coupling):
    """The shoulder girdle's joints as polynomials of the independent joints (the model's
    joint equalities ``q1 - q1₀ = Σ c_k (q2 - q2₀)^k``).

    Args:
        model: The compiled scene.
        independent_joints: (n,) joint ids of the independent coordinates.
    """

    def __init__(self, model: mujoco.MjModel, independent_joints: np.ndarray) -> None:
        eqs = [e for e in range(model.neq) if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT
               and int(model.eq_obj2id[e]) in set(independent_joints.tolist())]
        dep = [int(model.eq_obj1id[e]) for e in eqs]
        joints = [*independent_joints.tolist(), *dep]
        super().__init__(model.jnt_dofadr[joints], np.arange(len(independent_joints)))
        self.model = model
        self._dep_qpos = model.jnt_qposadr[dep]
        self._dep_q0 = model.qpos0[self._dep_qpos]
        col = {j: i for i, j in enumerate(independent_joints.tolist())}
        self._ind_col = np.array([col[int(model.eq_obj2id[e])] for e in eqs], dtype=int)
        self._ind_qpos = model.jnt_qposadr[[int(model.eq_obj2id[e]) for e in eqs]]
        self._ind_q0 = model.qpos0[self._ind_qpos]
        self._coef = model.eq_data[eqs, :5].copy()  # (d, 5)
        self._rows = np.arange(len(independent_joints), len(joints))
        self.matrix = np.zeros((len(joints), len(independent_joints)))
        self.matrix[np.arange(len(independent_joints)), np.arange(len(independent_joints))] = 1

    def update(self, data: mujoco.MjData) -> np.ndarray:
        """The coupling at ``data``'s configuration: 1 on the independent joints, the
        polynomials' derivatives on the dependent ones.
        """
        x = data.qpos[self._ind_qpos] - self._ind_q0
        c = self._coef
        d = c[:, 1] + x * (2 * c[:, 2] + x * (3 * c[:, 3] + x * 4 * c[:, 4]))
        self.matrix[self._rows, self._ind_col] = d
        return self.matrix

    def apply(self, data: mujoco.MjData) -> None:
        """Set the dependent joints on their polynomials."""
        x = data.qpos[self._ind_qpos] - self._ind_q0
        c = self._coef
        data.qpos[self._dep_qpos] = self._dep_q0 + c[:, 0] + x * (
            c[:, 1] + x * (c[:, 2] + x * (c[:, 3] + x * c[:, 4])))


class MuscleDrive(ArmDrive):
    """Muscle excitations for the joint torques asked for (bounded least squares).

    Args:
        model: The compiled scene.
        coupling: The arm's coupling.

    Attributes:
        activation: (u,) the last excitations sent, in [0, 1].
    """

    def __init__(self, model: mujoco.MjModel, coupling: MuscleCoupling) -> None:
        from scipy.optimize import lsq_linear  # noqa: PLC0415

        self._lsq = lsq_linear
        self.model, self.coupling = model, coupling
        self.muscles = np.flatnonzero(model.actuator_dyntype == mujoco.mjtDyn.mjDYN_MUSCLE)
        n_u = len(self.muscles)
        self._force0 = model.actuator_gainprm[self.muscles, 2].copy()
        self._moment = np.zeros((model.nu, model.nv))
        self.activation = np.zeros(n_u)
        n = len(coupling.independent)
        self.lo, self.hi = np.full(n, -np.inf), np.full(n, np.inf)
        self._reg = math.sqrt(_REGULARIZATION) * np.eye(n_u)
        self._zeros = np.zeros(n_u)

    def set_strength(self, scale: float) -> None:
        """Scale the muscles' peak isometric forces."""
        m = self.model
        m.actuator_gainprm[self.muscles, 2] = scale * self._force0
        m.actuator_biasprm[self.muscles, 2] = scale * self._force0

    def apply(self, data: mujoco.MjData, tau: np.ndarray) -> np.ndarray:
        """Excitations for the (n,) torques; the torques they make at full activation."""
        m = self.model
        mujoco.mju_sparse2dense(self._moment, data.actuator_moment, data.moment_rownnz,
                                data.moment_rowadr, data.moment_colind)
        gain = np.empty(len(self.muscles))
        bias = np.empty(len(self.muscles))
        for k, i in enumerate(self.muscles):
            length, vel = data.actuator_length[i], data.actuator_velocity[i]
            rng, acc0 = m.actuator_lengthrange[i], m.actuator_acc0[i]
            gain[k] = mujoco.mju_muscleGain(length, vel, rng, acc0, m.actuator_gainprm[i, :9])
            bias[k] = mujoco.mju_muscleBias(length, rng, acc0, m.actuator_biasprm[i, :9])
        c = self.coupling.update(data)
        arms = self._moment[np.ix_(self.muscles, self.coupling.dofs)].dot(c)  # (u, n)
        a_mat = arms.T * gain  # (n, u)
        b = arms.T.dot(bias)
        res = self._lsq(np.vstack([a_mat, self._reg]), np.concatenate([tau - b, self._zeros]),
                        bounds=(0.0, 1.0), method="bvls")
        self.activation = res.x
        data.ctrl[self.muscles] = res.x
        return a_mat.dot(res.x) + b


def build(scenario: Scenario, design: PhysicsDesign, rest_quat: np.ndarray
          ) -> tuple[Scene, WholeArm, MuscleDrive, MuscleCoupling, np.ndarray]:
    """The scene with the muscle-driven arm; its arm indices, drive, coupling and posture.

    The grip frame's orientation on the hand is found on a first compiled model: in the
    comfortable posture it is the rest grip (:func:`~hri_envs.physics.carry.human.whole_arm.
    grip_quat_world`, turned into the torso's frame).

    Raises:
        MissingExtraError: myo-sim (or scipy) is not installed.
    """
    def builder(grip_pos: np.ndarray, grip_quat: np.ndarray,
                with_grip: bool) -> Callable[[mujoco.MjSpec], None]:
        return lambda spec: _attach(spec, grip_pos, grip_quat, design, rest_quat, with_grip)

    first = build_scene(scenario, design, builder(_GRIP_IN_HAND, np.array([1.0, 0, 0, 0]),
                                                  False))
    m = first.model
    data = mujoco.MjData(m)
    ids = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in MUSCLE_JOINTS])
    coupling = MuscleCoupling(m, ids)
    data.qpos[m.jnt_qposadr[ids]] = MUSCLE_POSTURE
    coupling.apply(data)
    mujoco.mj_kinematics(m, data)
    hand = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, _PREFIX + _HAND_BODY)
    # The torso at the origin faces -x: the rest grip in the world is the target.
    want = np.empty(9)
    mujoco.mju_quat2Mat(want, grip_quat_world())
    rel = data.xmat[hand].reshape(3, 3).T.dot(want.reshape(3, 3))
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, rel.ravel())
    scene = build_scene(scenario, design, builder(_GRIP_IN_HAND, quat, True))
    m = scene.model
    ids = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in MUSCLE_JOINTS])
    coupling = MuscleCoupling(m, ids)
    arm = WholeArm(m, MUSCLE_JOINTS, coupling)
    # The comfortable hand: where the grip is in the comfortable posture, in the torso frame
    # (the torso at the origin faces -x: torso x = -world x, y = -world y).
    grip = data.xpos[hand] + data.xmat[hand].reshape(3, 3).dot(_GRIP_IN_HAND)
    arm.hand_in_torso = np.array([-grip[0], -grip[1], grip[2] - 1.0])
    return scene, arm, MuscleDrive(m, coupling), coupling, MUSCLE_POSTURE.copy()
