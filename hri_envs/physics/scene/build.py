"""Build the MuJoCo scene of a scenario in code (``MjSpec``): supports, object, Panda.

The scene has, in this order of degrees of freedom: the robot (for the wheel three
prismatic base joints, then) seven arm joints and two fingers, and the object's free
joint, then the human's arm (:mod:`hri_envs.physics.panda.human_arm`: six actuated joints and
the thumb).
Supports are mocap bodies, so the wheel's stands move to each episode's layout without
recompiling. Contacts are on, and only between the intended pairs (the
``contype``/``conaffinity`` bits below): the object's collision geometry and the floor, the
object's collision geometry and the supports' (hook, peg and rail of the hanger; plates,
posts and rack peg of the wheel), the Panda's finger pads and the object's grip
geometry, and the human's thumb and the object's instrumented handle (bit
:data:`~hri_envs.physics.panda.human_arm.HAND_CONTACT_BIT`). The supports still hold a resting
object through seat force laws (:mod:`hri_envs.physics.scene.seats`; their geometry only stops an
object moved through them),
the robot through a weld constraint made once both fingers press on the grip geometry, the
human's hand through a weld constraint while the human holds. The arm and the base are
driven by joint torques (``motor`` actuators with the Panda's torque limits); the fingers
by position servos.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from hri_envs.physics.scene.assets import PANDA_ARM_JOINTS, PANDA_FINGER_JOINTS, panda_xml
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.shapes import DARK, add_visual
from hri_envs.task.geometry import Scenario

__all__ = ["BASE_JOINTS", "FINGER_HOLD_STIFFENING", "FINGER_ON_GRIP_M", "FINGER_OPEN_M", "Scene",
           "build_robot_model", "build_scene", "robot_joints"]

#: [m] The finger joint position of the Panda's open hand (its maximum).
FINGER_OPEN_M = 0.04
#: [m] The finger joint position where the closing fingers stop on the grip block at the
#: nominal grip (2.18-2.19 cm measured after grasps on both scenes): held there while welded.
FINGER_ON_GRIP_M = 0.0219
#: [-] The finger servos' stiffness is multiplied by this while the robot's weld holds.
FINGER_HOLD_STIFFENING = 10.0
#: Prismatic joints of the wheel's mobile base (x, y on the floor, z lift).
BASE_JOINTS: tuple[str, ...] = ("base_x", "base_y", "base_lift")
_TORQUE_LIMITS = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
_BASE_FORCE_LIMITS = (1500.0, 1500.0, 3000.0)
_GRIP_SITE = "grip"
_WRIST_SITE = "wrist_ft"
# contype/conaffinity bits. MuJoCo collides two geoms if either's contype shares a bit with
# the other's conaffinity; only the object's geoms have a conaffinity, so the pairs are
# object-floor, object-support and (grip geometry only) fingers-object.
_FLOOR_BIT, _OBJECT_BIT, _SUPPORT_BIT, _FINGER_BIT, _GRIP_BIT = 1, 2, 4, 8, 16
#: Half sizes [m] of the object's grip geometry in the grip frame (x: across the finger
#: pads, y: the fingers' closing axis, z: the approach axis). The fingers, commanded to
#: ``grip_finger_pos_m`` (1.2 cm), meet it at 2 cm and press on it with ≈ 2 N each.
GRIP_HALF_SIZE: tuple[float, float, float] = (0.012, 0.02, 0.012)
_CONTACT = {"condim": 3, "friction": [0.6, 0.005, 0.0001], "margin": 0.001,
            "solref": [0.01, 1.0]}


def robot_joints(design: PhysicsDesign) -> tuple[str, ...]:
    """The robot's controlled joints a design's scene has, in order: the mobile base's
    (:data:`BASE_JOINTS`) if it has one, then the arm's 7.
    """
    return (BASE_JOINTS if design.mobile_base else ()) + PANDA_ARM_JOINTS


def _grip_geometry(obj: mujoco.MjsBody, design: PhysicsDesign) -> mujoco.MjsGeom:
    """The object's grip (a handle block at the robot's grip frame): the fingers touch only it."""
    return obj.add_geom(name="object_grip_geom", type=mujoco.mjtGeom.mjGEOM_BOX,
                        pos=design.grip_pos, quat=design.grip_quat, size=list(GRIP_HALF_SIZE),
                        contype=_GRIP_BIT, conaffinity=_FINGER_BIT, mass=0.0,
                        rgba=(0.25, 0.25, 0.28, 1.0), condim=4,
                        friction=[1.0, 0.005, 0.0001], margin=0.001)


def _finger_collision(spec: mujoco.MjSpec) -> None:
    """Turn on the Panda's finger-pad collision geoms (capsules and box), against the grip."""
    for name in ("panda0_leftfinger", "panda0_rightfinger"):
        for geom in spec.body(name).geoms:
            if geom.type != mujoco.mjtGeom.mjGEOM_MESH:
                geom.contype, geom.conaffinity = _FINGER_BIT, 0


def _robot_spec(design: PhysicsDesign) -> mujoco.MjSpec:
    spec = mujoco.MjSpec.from_string(panda_xml())
    spec.option.timestep = 0.002
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    for geom in spec.geoms:
        geom.contype, geom.conaffinity = 0, 0
    for i, name in enumerate(PANDA_ARM_JOINTS):
        joint = spec.joint(name)
        joint.damping = [0.5, 0.0, 0.0]
        joint.armature = 0.1 if i < 4 else 0.05
        joint.frictionloss = 0.0
    for name in PANDA_FINGER_JOINTS:
        spec.joint(name).damping = [5.0, 0.0, 0.0]
        spec.joint(name).armature = 0.01
    spec.body("panda0_link7").add_site(
        name=_GRIP_SITE, pos=[0.0, 0.0, 0.21],
        quat=[np.cos(-np.pi / 8), 0.0, 0.0, np.sin(-np.pi / 8)], size=[0.01, 0, 0],
    )
    mount = spec.body("panda_mount")
    mount.pos = design.base_pos
    if design.mobile_base:
        mount.mass, mount.inertia, mount.explicitinertial = 25.0, [2.0, 2.0, 2.0], True
        ranges = ((-8.0, 8.0), (-8.0, 8.0), (-0.55, 1.0))  # [m] from base_pos
        for name, axis, rng in zip(BASE_JOINTS, np.eye(3), ranges, strict=True):
            mount.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis,
                            damping=[50.0, 0.0, 0.0], armature=5.0, range=rng, limited=True)
        add_visual(mount, type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.06, 1.0, 0],
                pos=[0, 0, -1.0], rgba=DARK)
    else:
        add_visual(mount, type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.12, 0.12, design.base_pos[2] / 2],
                pos=[0, 0, -design.base_pos[2] / 2], rgba=DARK)
    for name, limit in zip(PANDA_ARM_JOINTS, _TORQUE_LIMITS, strict=True):
        act = spec.add_actuator(name=name.split(":")[-1], target=name,
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        act.ctrlrange = [-limit, limit]
    if design.mobile_base:
        for name, limit in zip(BASE_JOINTS, _BASE_FORCE_LIMITS, strict=True):
            act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_motor()
            act.ctrlrange = [-limit, limit]
    for name in PANDA_FINGER_JOINTS:
        act = spec.add_actuator(name=name.split(":")[-1], target=name,
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=200.0)
        act.ctrlrange = [0.0, 0.04]
    return spec


def build_robot_model(design: PhysicsDesign) -> mujoco.MjModel:
    """The robot alone (same joint order as in the scene), for inverse kinematics."""
    return _robot_spec(design).compile()


def _support_bodies(spec: mujoco.MjSpec, scenario: Scenario, design: PhysicsDesign
                    ) -> list[str]:
    """A mocap body per support at its seat, with its picture; the bodies' names."""
    names = []
    for sup in scenario.supports:
        body = spec.worldbody.add_body(name=f"support_{sup.name}", mocap=True, pos=sup.position)
        names.append(body.name)
        design.shapes.support_visuals(body, sup, scenario)
    design.shapes.world_visuals(spec, scenario)
    return names


def _support_collision(spec: mujoco.MjSpec, scenario: Scenario, design: PhysicsDesign) -> None:
    """Collision geoms of the supports: the parts of their pictures that the scenario's own
    waypoints and straight-line motions keep clear of (:class:`~hri_envs.physics.scene.shapes.
    SceneShapes`). A resting object is held by its seat (:mod:`hri_envs.physics.scene.seats`) and
    clear of this geometry; an object moved through a support collides with it.
    """
    kw = {"contype": _SUPPORT_BIT, "conaffinity": 0, "group": 3, "rgba": (0, 0, 0, 0),
          "mass": 0.0, **_CONTACT}
    for sup in scenario.supports:
        design.shapes.support_collision(spec.body(f"support_{sup.name}"), sup, scenario, kw)
    design.shapes.world_collision(spec, scenario, kw)


@dataclass(frozen=True)
class Scene:
    """A compiled scene and the indices the backend needs.

    Attributes:
        model: The compiled model.
        design: The physical design it was built from.
        robot_qpos, robot_dofs: (n,) qpos / dof addresses of the controlled robot joints
            (base joints, then arm joints), n = 7 or 10.
        arm_dofs: (7,) the arm joints' positions within ``robot_dofs``.
        finger_qpos: (2,) qpos addresses of the fingers.
        robot_actuators: (n,) actuators of the robot joints (same order), finger_actuators (2,).
        torque_limit: (n,) the robot joints' torque/force limits.
        grip_site: Site id of the hand's grip frame; hand_body the body it is on.
        object_body: Body id of the object; object_qpos (7,), object_dofs (6,) its free joint.
        object_grip_site, object_handle_site: Site ids on the object.
        weld: Equality id of the grasp weld (hand to object).
        support_mocap: (K,) mocap ids of the supports.
        platform_mocap: Mocap id of the mobile base's floor platform (-1 without one).
        wrist_site: Site id of the wrist force/torque sensor (on link 7, at the flange).
        force_sensor, torque_sensor: Sensor ids of its ``force`` and ``torque`` sensors.
        floor_geom: Geom id of the floor.
        grip_geom: Geom id of the object's grip geometry (the only one the fingers touch).
        finger_geoms: (2, n) geom ids of the left and right finger pads' collision geoms.
        support_geoms: Geom ids of the supports' collision geometry (and the hanger's rail).
    """

    model: mujoco.MjModel
    design: PhysicsDesign
    robot_qpos: np.ndarray
    robot_dofs: np.ndarray
    arm_dofs: np.ndarray
    finger_qpos: np.ndarray
    robot_actuators: np.ndarray
    finger_actuators: np.ndarray
    torque_limit: np.ndarray
    grip_site: int
    hand_body: int
    object_body: int
    object_qpos: np.ndarray
    object_dofs: np.ndarray
    object_grip_site: int
    object_handle_site: int
    weld: int
    support_mocap: np.ndarray
    platform_mocap: int
    wrist_site: int
    force_sensor: int
    torque_sensor: int
    floor_geom: int
    grip_geom: int
    finger_geoms: np.ndarray
    support_geoms: np.ndarray


def build_scene(scenario: Scenario, design: PhysicsDesign,
                human: Callable[[mujoco.MjSpec], None]) -> Scene:
    """Compile the scene of ``scenario`` with the physical ``design``.

    Args:
        scenario: The geometry.
        design: The physical design.
        human: Adds the human to the spec (after the object and its collision geometry,
            before the robot's grip geometry): the v0 envs' hand on six joints
            (:func:`~hri_envs.physics.panda.human_arm.add_human_arm`) or the continuous
            envs' whole arm (:mod:`hri_envs.physics.carry.human.whole_arm`).
    """
    spec = _robot_spec(design)
    spec.visual.global_.offwidth, spec.visual.global_.offheight = 640, 480
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.worldbody.add_light(pos=[0.5, -1.0, 4.0], dir=[0.0, 0.2, -1.0], diffuse=[0.6] * 3)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[8, 8, 0.1],
                            rgba=(0.82, 0.8, 0.76, 1.0), contype=_FLOOR_BIT,
                            conaffinity=0)
    # Contacts on, between the pairs listed in the module docstring.
    spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    platform = None
    if design.mobile_base:
        platform = spec.worldbody.add_body(name="platform", mocap=True, pos=[0, 0, 0.1])
        add_visual(platform, type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.3, 0.25, 0.1], rgba=DARK)
    support_names = _support_bodies(spec, scenario, design)

    obj = spec.worldbody.add_body(name="object", pos=scenario.supports[0].position)
    obj.add_freejoint(name="object_free")
    obj.mass, obj.ipos, obj.inertia = design.object_mass, design.object_com, design.object_inertia
    obj.explicitinertial = True
    design.shapes.object_visuals(obj, scenario)
    obj.add_site(name="object_grip", pos=design.grip_pos, quat=design.grip_quat,
                 size=[0.012, 0, 0], rgba=(0.2, 0.4, 0.9, 1.0))
    obj.add_site(name="object_handle", pos=design.handle_pos, size=[0.02, 0, 0],
                 rgba=(0.9, 0.5, 0.1, 1.0))
    weld = spec.add_equality(name="grasp", type=mujoco.mjtEq.mjEQ_WELD,
                             objtype=mujoco.mjtObj.mjOBJ_BODY, name1="object",
                             name2="panda0_link7", active=False)
    weld.solref = [0.01, 1.0]
    # The wrist force/torque sensor: between link 6 and link 7 (the hand's subtree: link 7,
    # hand, fingers and, while welded, the object), in the frame of the flange site.
    spec.body("panda0_link7").add_site(name=_WRIST_SITE, pos=[0.0, 0.0, 0.107],
                                       size=[0.005, 0, 0], group=4)
    for name, kind in (("wrist_force", mujoco.mjtSensor.mjSENS_FORCE),
                       ("wrist_torque", mujoco.mjtSensor.mjSENS_TORQUE)):
        spec.add_sensor(name=name, type=kind, objtype=mujoco.mjtObj.mjOBJ_SITE,
                        objname=_WRIST_SITE)
    design.shapes.object_collision(obj, scenario, {
        "contype": _OBJECT_BIT, "conaffinity": _FLOOR_BIT | _SUPPORT_BIT, "group": 3,
        "rgba": (0, 0, 0, 0), "mass": 0.0, **_CONTACT})
    human(spec)
    _grip_geometry(obj, design)
    _finger_collision(spec)
    _support_collision(spec, scenario, design)
    model = spec.compile()

    def jid(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)

    def aid(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, name)

    joints = robot_joints(design)
    ids = [jid(n) for n in joints]
    acts = [aid(n.split(":")[-1]) for n in joints]
    limits = (_BASE_FORCE_LIMITS if design.mobile_base else ()) + _TORQUE_LIMITS
    free = jid("object_free")
    obj_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object")
    n_base = 3 if design.mobile_base else 0
    return Scene(
        model=model,
        design=design,
        robot_qpos=np.array([model.jnt_qposadr[i] for i in ids]),
        robot_dofs=np.array([model.jnt_dofadr[i] for i in ids]),
        arm_dofs=np.arange(n_base, n_base + 7),
        finger_qpos=np.array([model.jnt_qposadr[jid(n)] for n in PANDA_FINGER_JOINTS]),
        robot_actuators=np.array(acts),
        finger_actuators=np.array([aid(n.split(":")[-1]) for n in PANDA_FINGER_JOINTS]),
        torque_limit=np.array(limits),
        grip_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, _GRIP_SITE),
        hand_body=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "panda0_link7"),
        object_body=obj_id,
        object_qpos=np.arange(model.jnt_qposadr[free], model.jnt_qposadr[free] + 7),
        object_dofs=np.arange(model.jnt_dofadr[free], model.jnt_dofadr[free] + 6),
        object_grip_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "object_grip"),
        object_handle_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "object_handle"),
        weld=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, "grasp"),
        support_mocap=np.array([
            model.body_mocapid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)]
            for n in support_names]),
        platform_mocap=-1 if platform is None else int(
            model.body_mocapid[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "platform")]),
        wrist_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, _WRIST_SITE),
        force_sensor=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, "wrist_force"),
        torque_sensor=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, "wrist_torque"),
        floor_geom=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor"),
        grip_geom=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "object_grip_geom"),
        finger_geoms=np.array([
            [g for g in range(model.ngeom) if model.geom_bodyid[g] == finger
             and model.geom_contype[g] == _FINGER_BIT]
            for finger in (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n)
                           for n in ("panda0_leftfinger", "panda0_rightfinger"))]),
        support_geoms=np.flatnonzero(model.geom_contype == _SUPPORT_BIT),
    )
