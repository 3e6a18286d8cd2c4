"""The human as a whole arm on a torso, holding the object's handle by friction.

The continuous envs (:mod:`hri_envs.physics.carry.env`) put a whole human arm into the
scene instead of the v0 envs' hand on six joints (:mod:`hri_envs.physics.panda.human_arm`, which
stays as it is for the v0 ids). :func:`add_whole_arm` adds it to a scene's ``MjSpec``:

* a **torso** on three slide joints (x, y on the floor, z: standing up or crouching) and a
  hinge about the vertical (turning), moved by stiff position servos (the legs): the human
  walks, crouches and turns so that the hand's reference stays within comfortable reach
  (:meth:`WholeArm.torso_target`);
* a **right arm** with anatomical segment lengths and masses (de Leva 1996, an adult male of
  75 kg): upper arm on a three-hinge shoulder (flexion, abduction, rotation), forearm on the
  elbow (flexion) and on its own axis (pronation-supination), hand on a two-hinge wrist
  (flexion-extension, radial-ulnar deviation): 7 joints, each driven by a joint torque motor
  whose range is an adult's strength (:data:`TORQUE_LIMITS`, sources in docs/physics.md);
  the arm carries its own weight (``gravcomp``), so the strength limits bound the force the
  human puts on the object, not the force that holds up their arm;
* a **hand** that grips the object's handle (a bar on the object, ``human_handle``) between
  its palm and a finger pad on a slide joint, whose position servo saturates at the human's
  grip force. The hand holds the handle through MuJoCo's friction contacts (elliptic cones,
  ``condim`` 4), not a weld: a grip weaker than the load slips, and the continuous envs
  report it (fault ``slipped``).

The muscle-driven variant (:mod:`hri_envs.physics.carry.human.muscles`) replaces the arm by
MyoSuite's
arm model and keeps the torso, the palm, the pad and the handle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import quat_conj, quat_mul

__all__ = ["ARM_JOINTS", "HANDLE_CONTACT_BIT", "SEGMENTS", "TORQUE_LIMITS", "TORSO_JOINTS",
           "Coupling", "WholeArm", "add_grip", "add_torso", "add_whole_arm", "grip_quat_world"]

#: The torso's joints: slides (walking, crouching) and a hinge (turning about the vertical).
TORSO_JOINTS: tuple[str, ...] = ("human_torso_x", "human_torso_y", "human_torso_z",
                                 "human_torso_yaw")
#: The arm's joints, from the shoulder to the hand.
ARM_JOINTS: tuple[str, ...] = ("human_shoulder_flexion", "human_shoulder_abduction",
                               "human_shoulder_rotation", "human_elbow_flexion",
                               "human_pronation", "human_wrist_flexion",
                               "human_wrist_deviation")
#: Adult joint torque limits [N m] as (negative direction, positive direction) per joint of
#: :data:`ARM_JOINTS`, for a strength scale of 1 (docs/physics.md, "Whole arm", gives the
#: sources): shoulder 48 N m about each axis (peak isokinetic, men's strongest group),
#: elbow flexion 58.5 / extension 50.3 N m (78 % and 67 % of a 75 kg body mass in N m),
#: pronation 13.1 / supination 16.2 N m, wrist flexion 12.2 / extension 7.1 N m, radial
#: 11.0 / ulnar deviation 9.5 N m.
TORQUE_LIMITS: dict[str, tuple[float, float]] = {
    "human_shoulder_flexion": (48.0, 48.0),
    "human_shoulder_abduction": (48.0, 48.0),
    "human_shoulder_rotation": (48.0, 48.0),
    "human_elbow_flexion": (50.3, 58.5),  # extension, flexion
    "human_pronation": (16.2, 13.1),  # supination, pronation
    "human_wrist_flexion": (7.1, 12.2),  # extension, flexion
    "human_wrist_deviation": (9.5, 11.0),  # ulnar, radial
}


@dataclass(frozen=True)
class Segment:
    """An arm segment: length [m] along it, mass [kg], radius [m] of its picture."""

    length: float
    mass: float
    radius: float


#: Segment lengths and masses of a 75 kg adult male (de Leva 1996: upper arm 28.17 cm,
#: 2.71 % body mass; forearm 26.89 cm, 1.62 %; hand 8.62 cm to the grip, 0.61 %).
SEGMENTS: dict[str, Segment] = {
    "upper_arm": Segment(0.2817, 0.0271 * 75.0, 0.045),
    "forearm": Segment(0.2689, 0.0162 * 75.0, 0.035),
    "hand": Segment(0.0862, 0.0061 * 75.0, 0.03),
}
#: The ``contype`` bit of the palm and the finger pad; the handle has it as ``conaffinity``
#: and nothing else does (the scene's other bits are 1-32).
HANDLE_CONTACT_BIT = 64
_SKIN = (0.87, 0.67, 0.55, 1.0)
_SHIRT = (0.25, 0.35, 0.55, 1.0)
_SHOULDER_IN_TORSO = (0.0, -0.19, 0.45)  # [m] right shoulder, torso frame (x ahead, y left)
_TORSO_HEIGHT_M = 1.0  # [m] the torso frame's height (the hip) when standing
_TORSO_MASS_KG = 40.0
_TORSO_RANGE_Z = (-0.75, 0.45)  # [m] crouching down to reaching up (see docs/physics.md)
_TORSO_KP, _TORSO_KV, _TORSO_FORCE_N = 20000.0, 2000.0, 3000.0  # the legs' servos
#: The handle: a bar of this half size [m] in its own frame (x: along the bar, z: from the
#: palm towards the finger pad), where the hand grips.
HANDLE_HALF = (0.05, 0.03, 0.012)
_PALM_HALF = (0.045, 0.045, 0.008)
_PAD_HALF = (0.045, 0.035, 0.006)
_PAD_OPEN_M = 0.03  # [m] the open finger pad lies this far below the bar
_PAD_PAST_M = 0.01  # [m] the closing pad aims this far into the bar: its servo saturates
_PAD_KP = 5000.0  # [N/m] so that its force is the grip force (it saturates)
_PAD_MASS_KG = 0.05
_GRIP_FRICTION = (1.0, 0.05, 0.001)  # skin on a handle: sliding, torsional, rolling
_GRIP_SOLREF = (0.004, 1.0)
_JOINT_DAMPING = 0.5  # [N m s/rad] passive damping of the arm's joints
_JOINT_ARMATURE = 0.02  # [kg m²] (numerical robustness at the 2 ms step too)
#: Joint ranges [rad] of ARM_JOINTS (anatomical, loosely).
_RANGES = ((-1.0, 3.0), (-1.0, 2.5), (-1.5, 1.5), (0.0, 2.5), (-1.6, 1.6), (-1.2, 1.2),
           (-0.5, 0.5))
#: A comfortable posture [rad] (the null-space reference): arm forward, elbow bent.
COMFORT_POSTURE = np.array([0.5, 0.3, 0.0, 1.3, 0.0, 0.0, 0.0])


def grip_quat_world() -> np.ndarray:
    """The hand's grip frame in the world when the object is at its rest orientation.

    The human faces -x (towards the robot); their palm is on top of the bar, which runs
    along the world's y axis: grip x = +y, z = down (from the palm to the fingers).
    """
    x, z = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, -1.0])
    mat = np.column_stack([x, np.cross(z, x), z])
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    return q


def handle_quat_in_object(rest_quat: np.ndarray) -> np.ndarray:
    """The handle's orientation in the object frame (the grip frame at rest, undone)."""
    return quat_mul(quat_conj(np.asarray(rest_quat, float)), grip_quat_world())


def add_torso(spec: mujoco.MjSpec, visuals: bool = True) -> mujoco.MjsBody:
    """The human's torso on its slides and hinge with their servos; returns the torso body
    (frame: x ahead, y left, z up; it faces -x in the world). ``visuals``: draw a body.
    """
    torso = spec.worldbody.add_body(name="human_torso", pos=[0.0, 0.0, _TORSO_HEIGHT_M],
                                    quat=[0.0, 0.0, 0.0, 1.0], gravcomp=1.0)
    torso.mass, torso.inertia, torso.explicitinertial = _TORSO_MASS_KG, [2.0, 2.0, 1.0], True
    # The torso frame is turned by 180° about z: its x and y slides have axes -x and -y to
    # move along the world's +x and +y.
    axes = ((-1, 0, 0), (0, -1, 0), (0, 0, 1), (0, 0, 1))
    ranges = ((-8.0, 8.0), (-8.0, 8.0), _TORSO_RANGE_Z, (-math.pi, math.pi))
    for i, (name, axis, rng) in enumerate(zip(TORSO_JOINTS, axes, ranges, strict=True)):
        hinge = i == 3
        torso.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE if hinge
                        else mujoco.mjtJoint.mjJNT_SLIDE, axis=list(axis), range=list(rng),
                        limited=True, armature=1.0)
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        kp, kv, limit = ((_TORSO_KP / 10, _TORSO_KV / 10, _TORSO_FORCE_N / 10) if hinge
                         else (_TORSO_KP, _TORSO_KV, _TORSO_FORCE_N))
        act.set_to_position(kp=kp, kv=kv)
        act.forcelimited = True
        act.forcerange = [-limit, limit]
    if not visuals:
        return torso
    cap = mujoco.mjtGeom.mjGEOM_CAPSULE
    _visual(torso, type=cap, fromto=[0, 0.1, 0.05, 0, -0.1, 0.05], size=[0.12, 0, 0],
            rgba=_SHIRT)
    _visual(torso, type=cap, fromto=[0, 0, 0.1, 0, 0, 0.4], size=[0.15, 0, 0], rgba=_SHIRT)
    _visual(torso, type=cap, fromto=[0, 0.17, 0.45, 0, -0.17, 0.45], size=[0.06, 0, 0],
            rgba=_SHIRT)
    _visual(torso, type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=[0, 0, 0.68], size=[0.11, 0, 0],
            rgba=_SKIN)
    for side in (0.1, -0.1):  # legs
        _visual(torso, type=cap, fromto=[0, side, 0.0, 0, side, -0.9], size=[0.07, 0, 0],
                rgba=(0.2, 0.2, 0.25, 1.0))
    return torso


def add_grip(spec: mujoco.MjSpec, hand: mujoco.MjsBody, grip_pos: np.ndarray,
             grip_quat: np.ndarray, design: PhysicsDesign, rest_quat: np.ndarray) -> None:
    """The palm, the finger pad on its slide (with its servo), the grip site on ``hand``
    (at ``grip_pos``, ``grip_quat`` in the hand's frame) and the handle on the object.
    """
    box = mujoco.mjtGeom.mjGEOM_BOX
    frame = hand.add_body(name="human_grip_frame", pos=list(grip_pos), quat=list(grip_quat),
                          gravcomp=1.0)
    frame.add_site(name="human_grip", size=[0.01, 0, 0], group=4)
    kw = {"condim": 4, "friction": list(_GRIP_FRICTION), "solref": list(_GRIP_SOLREF),
          "contype": HANDLE_CONTACT_BIT, "conaffinity": 0, "margin": 0.001}
    frame.add_geom(name="human_palm", type=box, size=list(_PALM_HALF),
                   pos=[0.0, 0.0, -(HANDLE_HALF[2] + _PALM_HALF[2])], rgba=_SKIN, mass=0.0,
                   **kw)
    pad = frame.add_body(name="human_finger_pad", pos=[0.0, 0.0, HANDLE_HALF[2] + _PAD_HALF[2]],
                         gravcomp=1.0)
    pad.mass, pad.inertia, pad.explicitinertial = _PAD_MASS_KG, [1e-5] * 3, True
    pad.add_joint(name="human_fingers", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, -1],
                  range=[-_PAD_OPEN_M, _PAD_PAST_M], limited=True, damping=5.0)
    pad.add_geom(name="human_finger_pad", type=box, size=list(_PAD_HALF), rgba=_SKIN,
                 mass=0.0, **kw)
    act = spec.add_actuator(name="human_fingers", target="human_fingers",
                            trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.set_to_position(kp=_PAD_KP, kv=20.0)
    act.forcelimited = True
    act.forcerange = [-design.human_grip_force, design.human_grip_force]
    handle = spec.body("object").add_body(name="human_handle", pos=list(design.handle_pos),
                                          quat=list(handle_quat_in_object(rest_quat)))
    handle.add_geom(name="human_handle", type=box, size=list(HANDLE_HALF), mass=0.0,
                    contype=0, conaffinity=HANDLE_CONTACT_BIT, condim=4,
                    friction=list(_GRIP_FRICTION), solref=list(_GRIP_SOLREF),
                    rgba=(0.35, 0.3, 0.25, 1.0))
    handle.add_site(name="human_handle", size=[0.005, 0, 0], group=4)
    # What the hand puts on the object: the handle is a massless child of the object, so
    # these sensors (the object's wrench on the handle) read minus the hand's wrench.
    for name, kind in (("human_handle_force", mujoco.mjtSensor.mjSENS_FORCE),
                       ("human_handle_torque", mujoco.mjtSensor.mjSENS_TORQUE)):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname="human_handle")


def _visual(body: mujoco.MjsBody, **kwargs: object) -> None:
    body.add_geom(contype=0, conaffinity=0, mass=0.0, **kwargs)


def _hinge(body: mujoco.MjsBody, name: str, axis: tuple[float, float, float],
           rng: tuple[float, float]) -> None:
    body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(axis),
                   range=list(rng), limited=True, damping=_JOINT_DAMPING,
                   armature=_JOINT_ARMATURE)


def segment_inertia(seg: Segment) -> list[float]:
    """A solid cylinder's principal inertia about its centre (axis z)."""
    m, r, length = seg.mass, seg.radius, seg.length
    across = m * (3 * r * r + length * length) / 12.0
    return [across, across, 0.5 * m * r * r]


def add_whole_arm(spec: mujoco.MjSpec, design: PhysicsDesign, rest_quat: np.ndarray) -> None:
    """Add the torso, the torque-driven right arm, the hand's grip and the handle.

    Also switches the model to elliptic friction cones with ``impratio`` 10 (friction
    constraints ten times harder than normal ones: a gripped handle creeps far less).
    """
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    torso = add_torso(spec)
    cap = mujoco.mjtGeom.mjGEOM_CAPSULE
    upper, fore, hand_seg = SEGMENTS["upper_arm"], SEGMENTS["forearm"], SEGMENTS["hand"]
    arm = torso.add_body(name="human_upper_arm", pos=list(_SHOULDER_IN_TORSO), gravcomp=1.0)
    arm.mass, arm.ipos, arm.explicitinertial = upper.mass, [0, 0, -upper.length / 2], True
    arm.inertia = segment_inertia(upper)
    for name, axis, rng in zip(ARM_JOINTS[:3], ((0, -1, 0), (-1, 0, 0), (0, 0, 1)),
                               _RANGES[:3], strict=True):
        _hinge(arm, name, axis, rng)
    _visual(arm, type=cap, fromto=[0, 0, 0, 0, 0, -upper.length], size=[upper.radius, 0, 0],
            rgba=_SHIRT)
    forearm = arm.add_body(name="human_forearm", pos=[0, 0, -upper.length], gravcomp=1.0)
    forearm.mass, forearm.ipos = fore.mass, [0, 0, -fore.length / 2]
    forearm.inertia, forearm.explicitinertial = segment_inertia(fore), True
    _hinge(forearm, ARM_JOINTS[3], (0, -1, 0), _RANGES[3])
    _hinge(forearm, ARM_JOINTS[4], (0, 0, 1), _RANGES[4])
    _visual(forearm, type=cap, fromto=[0, 0, 0, 0, 0, -fore.length], size=[fore.radius, 0, 0],
            rgba=_SKIN)
    hand = forearm.add_body(name="human_hand", pos=[0, 0, -fore.length], gravcomp=1.0)
    hand.mass, hand.ipos = hand_seg.mass, [0, 0, -hand_seg.length / 2]
    hand.inertia, hand.explicitinertial = segment_inertia(hand_seg), True
    _hinge(hand, ARM_JOINTS[5], (0, -1, 0), _RANGES[5])
    _hinge(hand, ARM_JOINTS[6], (1, 0, 0), _RANGES[6])
    for name, limit in zip(ARM_JOINTS, TORQUE_LIMITS.values(), strict=True):
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        act.ctrllimited = True
        act.ctrlrange = [-limit[0], limit[1]]
    # At zero angles the arm hangs down (-z) and the hand's frame is the torso's; the grip
    # frame is set so that the comfortable posture puts it near its rest orientation.
    add_grip(spec, hand, np.array([0.0, 0.0, -hand_seg.length]), _hand_grip_quat(), design,
             rest_quat)


def _hand_grip_quat() -> np.ndarray:
    """The grip frame in the hand's frame: with the forearm pointing ahead (elbow at 90°),
    the grip frame is the rest grip (:func:`grip_quat_world`, in the torso frame, which
    faces -x: grip x = the torso's -y, z = down).
    """
    c = math.cos(math.pi / 4)
    elbow = np.array([c, 0.0, -c, 0.0])  # the hand frame: 90° about -y
    x, z = np.array([0.0, -1.0, 0.0]), np.array([0.0, 0.0, -1.0])
    mat = np.column_stack([x, np.cross(z, x), z])
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    return quat_mul(quat_conj(elbow), q)


class Coupling:
    """The arm's independent coordinates and the dofs that follow them.

    Args:
        dofs: (m,) dof addresses of every arm joint that moves with the independent ones
            (for an arm without couplings: the independent joints themselves).
        independent: (n,) the independent joints' positions within ``dofs``.
    """

    def __init__(self, dofs: np.ndarray, independent: np.ndarray) -> None:
        self.dofs, self.independent = np.asarray(dofs), np.asarray(independent)
        self.matrix = np.eye(len(self.dofs))[:, self.independent]

    def update(self, data: mujoco.MjData) -> np.ndarray:
        """(m, n) ∂q_dofs / ∂q_independent at ``data``'s configuration."""
        return self.matrix

    def apply(self, data: mujoco.MjData) -> None:
        """Set the dependent joints from the independent ones (none here)."""


class WholeArm:
    """Indices and helpers of the whole arm in a compiled scene.

    Args:
        model: The compiled scene with :func:`add_whole_arm` (or the muscle variant's) parts.
        arm_joints: Names of the arm's driven joints (the torque-driven arm's
            :data:`ARM_JOINTS`, or the muscle model's independent joints).

    Attributes:
        torso_qpos, torso_actuators: (4,) the torso joints' qpos addresses and servos.
        arm_qpos, arm_dofs: (n,) the arm joints' qpos and dof addresses.
        grip_site, handle_site: Site ids of the hand's grip frame and the handle's.
        handle_geom: Geom id of the handle; hand_geoms: (2,) palm and finger pad.
        fingers: Actuator id of the finger pad's servo; fingers_qpos its qpos address.
    """

    def __init__(self, model: mujoco.MjModel, arm_joints: tuple[str, ...],
                 coupling: Coupling | None = None) -> None:
        def jid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)

        def aid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)

        self.model = model
        self.torso_qpos = np.array([model.jnt_qposadr[jid(n)] for n in TORSO_JOINTS])
        self.torso_dofs = np.array([model.jnt_dofadr[jid(n)] for n in TORSO_JOINTS])
        self.torso_actuators = np.array([aid(n) for n in TORSO_JOINTS])
        self.arm_joints = np.array([jid(n) for n in arm_joints])
        self.arm_qpos = model.jnt_qposadr[self.arm_joints]
        self.arm_dofs = model.jnt_dofadr[self.arm_joints]
        self.grip_site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "human_grip")
        self.handle_site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "human_handle")
        self.handle_geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "human_handle")
        self.hand_geoms = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n)
                                    for n in ("human_palm", "human_finger_pad")])
        self.fingers = aid("human_fingers")
        self.fingers_qpos = int(model.jnt_qposadr[jid("human_fingers")])
        self.fingers_dof = int(model.jnt_dofadr[jid("human_fingers")])
        self.grip_body = int(model.site_bodyid[self.grip_site])
        self.shoulder_in_torso = np.array(_SHOULDER_IN_TORSO)
        #: [m] the torso frame's height (the hip) when standing (the body's size,
        #: :class:`~hri_envs.physics.carry.human.body.ArmBody`).
        self.torso_height_m = _TORSO_HEIGHT_M
        #: (3,) where the hand is comfortable, in the torso frame [m]: 0.3 m ahead of the
        #: shoulder, 0.15 m inwards and 0.35 m below it.
        self.hand_in_torso = self.shoulder_in_torso + np.array([0.3, 0.15, -0.35])
        self.coupling = (coupling if coupling is not None
                         else Coupling(self.arm_dofs, np.arange(len(self.arm_dofs))))

    def set_grip_force(self, force_n: float) -> None:
        """The most force [N] the finger pad squeezes the handle with."""
        self.model.actuator_forcerange[self.fingers] = (-force_n, force_n)

    def close(self, data: mujoco.MjData, closed: bool) -> None:
        """Squeeze the handle (the pad's servo aims into the bar) or open the hand."""
        data.ctrl[self.fingers] = _PAD_PAST_M if closed else -_PAD_OPEN_M

    def torso_target(self, hand_pos: np.ndarray, yaw: float) -> np.ndarray:
        """(4,) the torso's joint positions that put the hand at ``hand_pos`` [m] in
        comfortable reach (:attr:`hand_in_torso`) with the body turned by ``yaw`` [rad] from
        facing -x.
        """
        c, s = math.cos(yaw), math.sin(yaw)
        ox, oy, dz = self.hand_in_torso
        # The torso frame (x ahead, y left) faces -x at yaw 0: turned by yaw + 180° about z.
        torso = hand_pos - np.array([-(c * ox - s * oy), -(s * ox + c * oy), dz])
        return np.array([torso[0], torso[1], torso[2] - self.torso_height_m, yaw])

    @staticmethod
    def yaw_of(quat: np.ndarray, rest_quat: np.ndarray) -> float:
        """How far [rad] the human turns to hold the object at ``quat``: the yaw of the
        handle's bar (world y at ``rest_quat``) about the vertical (0 when the bar stands
        upright).
        """
        rel = quat_mul(np.asarray(quat, float), quat_conj(np.asarray(rest_quat, float)))
        b = np.empty(3)
        mujoco.mju_rotVecQuat(b, np.array([0.0, 1.0, 0.0]), rel)
        if b[0] * b[0] + b[1] * b[1] < 0.09:
            return 0.0
        return math.atan2(-b[0], b[1])

    def solve_ik(self, data: mujoco.MjData, pos: np.ndarray, quat: np.ndarray,
                 posture: np.ndarray, iterations: int = 200, lever_m: float = 0.2) -> float:
        """Put the grip frame at (``pos``, ``quat``) by damped least squares on the arm's
        joints (kinematics only; the torso stays where ``data`` has it); the final error
        [m] + ``lever_m`` x [rad]. ``posture`` (n,) is the start and the null-space target.
        """
        from hri_envs.physics.scene.kinematics import rotation_error  # noqa: PLC0415

        m, qa, dofs = self.model, self.arm_qpos, self.arm_dofs
        self.coupling.apply(data)
        lo, hi = m.jnt_range[self.arm_joints, 0], m.jnt_range[self.arm_joints, 1]
        data.qpos[qa] = posture
        self.coupling.apply(data)
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        cur = np.empty(4)
        err = math.inf
        for _ in range(iterations):
            mujoco.mj_kinematics(m, data)
            mujoco.mj_comPos(m, data)
            mujoco.mju_mat2Quat(cur, data.site_xmat[self.grip_site])
            e = np.concatenate([pos - data.site_xpos[self.grip_site],
                                rotation_error(quat, cur)])
            err = float(np.linalg.norm(e[:3]) + lever_m * np.linalg.norm(e[3:]))
            if err < 1e-4:
                break
            mujoco.mj_jacSite(m, data, jacp, jacr, self.grip_site)
            c = self.coupling.update(data)
            jac = np.vstack([jacp[:, self.coupling.dofs], jacr[:, self.coupling.dofs]]).dot(c)
            w = np.array([1, 1, 1, lever_m, lever_m, lever_m])
            jw = jac * w[:, None]
            dq = jw.T @ np.linalg.solve(jw @ jw.T + 1e-3 * np.eye(6), e * w)
            null = np.eye(len(dofs)) - np.linalg.pinv(jw) @ jw
            dq += 0.1 * null @ (posture - data.qpos[qa])
            data.qpos[qa] = np.clip(data.qpos[qa] + np.clip(dq, -0.2, 0.2), lo, hi)
            self.coupling.apply(data)
        return err
