"""The human's embodied arm: a hand on six actuated joints that holds the object by a weld.

In the scene (:func:`add_human_arm`) the human is a forearm and a hand (capsules and a
box, skin-coloured) on a chain of three world-aligned slide joints (x, y, z: the reach of
the arm, and for the wheel the walking human) and three hinges (yaw z, pitch y, roll x:
the wrist). The joints' ranges are the human's workspace (``PhysicsDesign.human_reach_lo``
and ``human_reach_hi``; the wrist turns at most ``_WRIST_RANGE_RAD``): the hand cannot leave
it. Each joint has a MuJoCo *position actuator*: stiffness ``kp``, damping ``kv`` and a
``forcerange`` that is the human's strength, so the human's impedance and its saturation
run in MuJoCo's C code at every physics step. The arm compensates its own weight
(``gravcomp``), as a person holds up their arm. While the human holds the object a weld
equality (``human_grasp``) joins the hand to the object's handle; letting go turns it off.
The hand's thumb, a pad on a slide joint under the handle, squeezes the handle while the
human holds (its position actuator saturates at the human's grip force) and opens when they
let go (its pad collides only while the human holds). The object's handle is instrumented:
a ball on a jointless child body of the object (``handle``), which only the thumb touches,
inside a MuJoCo ``touch`` sensor's site (``handle_touch``; a touch sensor counts the contacts
of its site's body only, so the object's own collision geometry next to the handle does
not count). That sensor, not the grasp bit, tells the robot whether the human holds
(:class:`HandleSensor`).

At run time (:class:`HumanArm`) the human's reference (:class:`~hri_envs.physics.panda.human.
SimulatedHuman`) sets the actuators' ``ctrl``: the hand's joint coordinates for the
reference pose of the object, plus damping / stiffness times the reference's velocity (so
the actuators' force is ``kp (q_ref - q) + kv (q̇_ref - q̇)``, the human's spring-damper
towards a moving reference), plus the noise as an offset of noise / stiffness. While the
human follows, the actuators keep only a small damping (``human_follow_damping``); the
hand's inertia and that damping are what a following human transmits. A hand that does not
hold the object stays at the handle (reaching gains, tracking the handle).
"""

from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import TrajectorySample, cross3, quat_conj, quat_to_mat

__all__ = ["HANDLE_TOUCH_SENSOR", "HAND_CONTACT_BIT", "HandleSensor", "HUMAN_JOINTS", "HumanArm",
           "add_human_arm"]

#: The arm's joints, from the world to the hand.
HUMAN_JOINTS: tuple[str, ...] = ("human_x", "human_y", "human_z", "human_yaw", "human_pitch",
                                 "human_roll")
_SKIN = (0.87, 0.67, 0.55, 1.0)
_SLEEVE = (0.25, 0.35, 0.55, 1.0)
_WRIST_RANGE_RAD = 2.0  # [rad] each wrist hinge turns at most this far from its zero
_HAND_MASS_KG = 0.1  # the hand body's own mass; the forearm body carries human_mass
_HAND_INERTIA = (2e-4, 2e-4, 2e-4)  # [kg m²] of the hand body
_HINGE_ARMATURE = 5e-3  # [kg m²] reflected inertia of the wrist (numerical robustness too)
_FOREARM_M = 0.3  # [m] length of the forearm capsule, towards the human (+x, 30° down)
_FOREARM_TILT_RAD = np.deg2rad(30.0)
#: The ``contype`` bit of the thumb pad; the handle ball has it as ``conaffinity`` and
#: nothing else does, so the thumb touches only the handle (the scene's other bits are 1-16).
HAND_CONTACT_BIT = 32
#: Name of the handle's touch sensor.
HANDLE_TOUCH_SENSOR = "handle_touch"
_HANDLE_BALL_M = 0.01  # [m] radius of the instrumented handle ball at the handle point
_TOUCH_SITE_M = 0.014  # [m] radius of the touch sensor's site round it
_THUMB_HALF = (0.012, 0.01, 0.004)  # [m] the thumb pad, under the handle (hand frame -z)
_THUMB_OPEN_M = 0.025  # [m] the open thumb's pad lies this far below the ball
_THUMB_PAST_M = 0.01  # [m] the closed thumb aims this far into the ball: it saturates
_THUMB_KP = 3000.0  # [N/m] so its force is the grip force (≤ 12 N, the option's maximum)
_THUMB_MASS_KG = 0.05
_THUMB_DAMPING = 4.0  # [N s/m] joint damping (implicit in MuJoCo's Euler integrator)
# Thumb-ball contact: stiff (2 physics steps), so the ball stops the thumb pad at its surface.
_THUMB_SOLREF = (0.004, 1.0)
_THUMB_PRELOAD_M = 0.0001  # [m] a holding thumb is placed this far into the ball at a reset


def _visual(body: mujoco.MjsBody, **kwargs: object) -> None:
    body.add_geom(contype=0, conaffinity=0, mass=0.0, **kwargs)


def add_human_arm(spec: mujoco.MjSpec, design: PhysicsDesign) -> None:
    """Add the human's forearm, hand, six position actuators and the grasp weld to ``spec``.

    The hand's frame is the world frame at zero wrist angles; its joint coordinates are the
    hand's world position [m] and its yaw-pitch-roll [rad] (:meth:`HumanArm.targets`).
    """
    cap, box = mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_BOX
    arm = spec.worldbody.add_body(name="human_arm", gravcomp=1.0)
    arm.mass, arm.inertia, arm.explicitinertial = design.human_mass, [0.01] * 3, True
    lo, hi = design.human_reach_lo, design.human_reach_hi
    for name, axis, low, high in zip(HUMAN_JOINTS[:3], np.eye(3), lo, hi, strict=True):
        arm.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis,
                      range=[low, high], limited=True)
    elbow = _FOREARM_M * np.array([np.cos(_FOREARM_TILT_RAD), 0.0, -np.sin(_FOREARM_TILT_RAD)])
    _visual(arm, type=cap, fromto=[0.04, 0.0, 0.0, *elbow], size=[0.035, 0, 0], rgba=_SKIN)
    _visual(arm, type=cap, fromto=[*(0.6 * elbow), *(1.3 * elbow)], size=[0.045, 0, 0],
            rgba=_SLEEVE)
    hand = arm.add_body(name="human_hand", gravcomp=1.0)
    hand.mass, hand.inertia, hand.explicitinertial = _HAND_MASS_KG, list(_HAND_INERTIA), True
    for name, axis in zip(HUMAN_JOINTS[3:], np.eye(3)[::-1], strict=True):
        hand.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis,
                       range=[-_WRIST_RANGE_RAD, _WRIST_RANGE_RAD], limited=True,
                       armature=_HINGE_ARMATURE)
    _visual(hand, type=box, pos=[0.03, 0.0, 0.0], size=[0.03, 0.045, 0.012], rgba=_SKIN)
    for k in range(4):  # fingers curled round the handle
        y = -0.033 + 0.022 * k
        _visual(hand, type=cap, fromto=[0.0, y, 0.0, -0.012, y, -0.025], size=[0.009, 0, 0],
                rgba=_SKIN)
    _visual(hand, type=cap, fromto=[0.03, 0.045, 0.0, 0.0, 0.05, 0.02], size=[0.01, 0, 0],
            rgba=_SKIN)
    # The thumb: a pad that slides up (hand frame +z) onto the handle ball from below.
    thumb = hand.add_body(name="human_thumb", gravcomp=1.0,
                          pos=[0.0, 0.0, -(_HANDLE_BALL_M + _THUMB_HALF[2])])
    thumb.mass, thumb.inertia, thumb.explicitinertial = _THUMB_MASS_KG, [1e-5] * 3, True
    thumb.add_joint(name="human_thumb", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1],
                    range=[-_THUMB_OPEN_M, _THUMB_PAST_M], limited=True,
                    damping=_THUMB_DAMPING)
    thumb.add_geom(name="human_thumb_pad", type=box, size=list(_THUMB_HALF), rgba=_SKIN,
                   mass=0.0, condim=1, contype=HAND_CONTACT_BIT, conaffinity=0,
                   solref=list(_THUMB_SOLREF))
    handle = spec.body("object").add_body(name="handle", pos=design.handle_pos)
    handle.add_geom(name="handle_ball", type=mujoco.mjtGeom.mjGEOM_SPHERE,
                    size=[_HANDLE_BALL_M, 0, 0], mass=0.0, condim=1, contype=0,
                    conaffinity=HAND_CONTACT_BIT, group=3, rgba=(0, 0, 0, 0),
                    solref=list(_THUMB_SOLREF))
    handle.add_site(name=HANDLE_TOUCH_SENSOR, size=[_TOUCH_SITE_M, 0, 0], group=4)
    spec.add_sensor(name=HANDLE_TOUCH_SENSOR, type=mujoco.mjtSensor.mjSENS_TOUCH,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=HANDLE_TOUCH_SENSOR)
    for name in (*HUMAN_JOINTS, "human_thumb"):
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=1.0, kv=1.0)  # gains, strength: HumanArm.apply
        act.forcelimited = True
        act.forcerange = [-1.0, 1.0]
    spec.add_equality(name="human_grasp", type=mujoco.mjtEq.mjEQ_WELD,
                      objtype=mujoco.mjtObj.mjOBJ_BODY, name1="object", name2="human_hand",
                      active=False).solref = [0.01, 1.0]


class HumanArm:
    """Drives the embodied arm of a compiled scene.

    Args:
        model: The compiled scene with :func:`add_human_arm`'s parts.
        design: The nominal design (handle, the object's reference orientation).
        rest_quat: (4,) the object orientation at which the wrist angles are zero (the
            scenario's first orientation: its other orientations stay far from the wrist's
            gimbal lock).

    Attributes:
        qpos, dofs: (6,) qpos and dof addresses of the arm's joints.
        actuators: (6,) its actuators.
        weld: Equality id of the human's grasp.
        following: The actuators have their following gains (else reaching gains).
        rest_t: (3, 3) the object's rest orientation's transpose (the wrist angles' zero).
        range_lo, range_hi: (6,) the joints' ranges.
        reach_gains: (6,), (6,) the reaching gains (K_p, K_v) of :meth:`apply`'s design.
        follow_damping: (6,) the following gains' damping.
        noise_scale: (6,) the hand's reference noise per unit of the noise's draw.
        lead: (6,) [s] K_v / K_p, the velocity feed-forward as a reference offset.
    """

    def __init__(self, model: mujoco.MjModel, design: PhysicsDesign,
                 rest_quat: np.ndarray) -> None:
        def jid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)

        self.model = model
        joints = [jid(n) for n in HUMAN_JOINTS]
        self.joints = np.array(joints)
        self.qpos = np.array([model.jnt_qposadr[j] for j in joints])
        self.dofs = np.array([model.jnt_dofadr[j] for j in joints])
        self.actuators = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n)
                                   for n in HUMAN_JOINTS])
        self.weld = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, "human_grasp")
        self.thumb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "human_thumb")
        self.thumb_pad = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "human_thumb_pad")
        thumb_joint = jid("human_thumb")
        self.thumb_qpos = int(model.jnt_qposadr[thumb_joint])
        self.thumb_dof = int(model.jnt_dofadr[thumb_joint])
        model.actuator_gainprm[self.thumb, 0] = _THUMB_KP
        model.actuator_biasprm[self.thumb, 1:3] = (-_THUMB_KP, 0.0)
        self.arm_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "human_arm")
        self.hand_body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "human_hand")
        self.handle = np.asarray(design.handle_pos, dtype=float)
        # Hand frame in the object frame: the object's rest orientation undone.
        self.hand_quat_in_object = quat_conj(np.asarray(rest_quat, dtype=float))
        self.rest_t = quat_to_mat(rest_quat).T
        self.range_lo = model.jnt_range[self.joints, 0].copy()
        self.range_hi = model.jnt_range[self.joints, 1].copy()
        self._ctrl = np.zeros(6)
        self._wrench = np.zeros(6)
        self.reach_gains = (np.ones(6), np.ones(6))
        self.follow_damping = np.ones(6)
        self.noise_scale = np.zeros(6)
        self.lead = np.zeros(6)
        self._lever = np.zeros(3)
        self._rot_flat = np.zeros(9)
        self._rot = self._rot_flat.reshape(3, 3)  # a view: mju_quat2Mat fills it
        self.following = False
        m = model.eq_data[self.weld]
        m[:] = 0.0
        m[3:6] = self.handle
        m[6:10] = self.hand_quat_in_object
        m[10] = 1.0  # torquescale

    def apply(self, design: PhysicsDesign) -> None:
        """Use the human of ``design``: stiffness, damping, strength, noise and mass."""
        kp = np.array([design.human_stiffness] * 3 + [design.human_rot_stiffness] * 3)
        kv = np.array([design.human_damping] * 3 + [design.human_rot_damping] * 3)
        limit = np.array([design.human_force] * 3 + [design.human_torque] * 3)
        self.reach_gains = (kp, kv)
        self.follow_damping = np.array([design.human_follow_damping[0]] * 3
                                       + [design.human_follow_damping[1]] * 3)
        self.noise_scale = design.human_noise * np.array(
            [1.0] * 3 + [design.human_noise_torque_lever_m] * 3) / kp
        self.lead = kv / kp  # [s]: the velocity feed-forward as a reference offset
        m = self.model
        m.actuator_forcerange[self.actuators, 0] = -limit
        m.actuator_forcerange[self.actuators, 1] = limit
        m.body_mass[self.arm_body] = design.human_mass
        m.actuator_forcerange[self.thumb] = (-design.human_grip_force, design.human_grip_force)
        self._set_gains(following=False)

    def _set_gains(self, following: bool) -> None:
        m, acts = self.model, self.actuators
        kp, kv = self.reach_gains
        if following:
            kp, kv = np.zeros(6), self.follow_damping
        m.actuator_gainprm[acts, 0] = kp
        m.actuator_biasprm[acts, 1] = -kp
        m.actuator_biasprm[acts, 2] = -kv
        self.following = following

    def targets(self, pos: np.ndarray, quat: np.ndarray, out: np.ndarray) -> np.ndarray:
        """The joint coordinates (6,) that put the hand on the handle of an object at
        (``pos``, ``quat``): the handle's world position [m] and the hand's yaw, pitch,
        roll [rad], written into ``out`` and clipped to the workspace.
        """
        rot = self._rot
        mujoco.mju_quat2Mat(self._rot_flat, np.ascontiguousarray(quat, float))
        lever = self._lever
        rot.dot(self.handle, out=lever)  # the handle from the object's origin
        out[:3] = pos + lever
        r = rot.dot(self.rest_t).tolist()  # the hand's orientation in the world
        # One call for both yaw and roll (numpy's arctan2 and arcsin, as before).
        out[3], out[5] = np.arctan2((r[1][0], r[2][1]), (r[0][0], r[2][2])).tolist()
        out[4] = np.arcsin(min(max(-r[2][0], -1.0), 1.0))
        np.maximum(out, self.range_lo, out=out)  # = np.clip(out, lo, hi)
        return np.minimum(out, self.range_hi, out=out)

    def place(self, data: mujoco.MjData, pos: np.ndarray, quat: np.ndarray,
              holding: bool) -> None:
        """Put the hand at rest on the handle of the object at (``pos``, ``quat``)."""
        q = self.targets(pos, quat, self._ctrl)
        data.qpos[self.qpos] = q
        data.qvel[self.dofs] = 0.0
        data.ctrl[self.actuators] = q
        # Pressing on the ball (the touch sensor reads the grip from the first forward pass)
        # or open.
        data.qpos[self.thumb_qpos] = _THUMB_PRELOAD_M if holding else -_THUMB_OPEN_M
        data.qvel[self.thumb_dof] = 0.0
        self.hold(data, holding)
        self._set_gains(following=False)

    @staticmethod
    def thumb_ctrl(on: bool) -> float:
        """The thumb actuator's target [m]: squeezing the handle (``on``) or open."""
        return _THUMB_PAST_M if on else -_THUMB_OPEN_M

    def hold(self, data: mujoco.MjData, on: bool) -> None:
        """Grasp (weld on, the thumb squeezes the handle) or let go (weld off, thumb open).

        The open thumb does not collide: an object the robot carries alone must not run
        into the idle hand's thumb.
        """
        data.eq_active[self.weld] = int(on)
        data.ctrl[self.thumb] = _THUMB_PAST_M if on else -_THUMB_OPEN_M
        self.model.geom_contype[self.thumb_pad] = HAND_CONTACT_BIT if on else 0

    def drive(self, data: mujoco.MjData, pos: np.ndarray, quat: np.ndarray,
              holding: bool, ref: TrajectorySample | None, noise: np.ndarray) -> None:
        """Set the actuators for the next control period.

        Args:
            data: The simulation state.
            pos: (3,) the object's current position [m] (a hand that does not hold the
                object tracks its handle).
            quat: (4,) its current orientation.
            holding: The human holds the object.
            ref: The object pose and velocity the human wants now; None: follow.
            noise: (6,) the human's unit noise (scaled to human_noise [N], torque x lever).
        """
        following = holding and ref is None
        if following != self.following:
            self._set_gains(following)
        if following:
            return
        if ref is None:  # not holding: the open hand tracks the handle
            data.ctrl[self.actuators] = self.targets(pos, quat, self._ctrl)
            return
        ctrl = self.targets(ref.pos, ref.quat, self._ctrl)
        # The hand's velocity: the handle's (v + ω × r), and ω on the wrist's axes (exact at
        # zero pitch); then ctrl += lead rates + noise scale noise. Plain floats, element by
        # element as numpy would; the wrist's product stays a BLAS call.
        v0, v1, v2 = ref.vel.tolist()
        w0, w1, w2 = ref.angvel.tolist()
        r0, r1, r2 = self._lever.tolist()
        rates = [v0 + w1 * r2 - w2 * r1, v1 + w2 * r0 - w0 * r2, v2 + w0 * r1 - w1 * r0,
                 *data.xaxis[self.joints[3:]].dot(ref.angvel).tolist()]
        ctrl[:] = [c + (k * q + s * n) for c, k, q, s, n in zip(
            ctrl.tolist(), self.lead.tolist(), rates, self.noise_scale.tolist(),
            noise.tolist(), strict=True)]
        data.ctrl[self.actuators] = ctrl

    def wrench(self, data: mujoco.MjData, obj_pos: np.ndarray) -> np.ndarray:
        """(6,) the wrench [N, N m] the human's muscles (the actuators) apply through the
        hand, torque about the object's origin ``obj_pos``; zero when not holding.
        """
        w = self._wrench
        if not data.eq_active[self.weld]:
            w[:] = 0.0
            return w
        f = data.actuator_force[self.actuators]
        axes = data.xaxis[self.joints[3:]]  # (3, 3) world axes of the wrist hinges
        t0, t1, t2 = f[3:].dot(axes).tolist()
        # The slides are world-aligned: their forces are the hand's force. The lever's
        # moment r × f on plain floats, element by element as numpy would.
        force = f[:3].tolist()
        hx, hy, hz = data.xpos[self.hand_body].tolist()
        ox, oy, oz = obj_pos.tolist()
        m0, m1, m2 = cross3((hx - ox, hy - oy, hz - oz), force)
        w[:] = (*force, t0 + m0, t1 + m1, t2 + m2)
        return w


class HandleSensor:
    """The handle's touch sensor: how hard the human's thumb presses on it, and so whether
    the human holds the object.

    Args:
        model: The compiled scene (with :func:`add_human_arm`).
        threshold_n: The reading [N] above which the robot takes the human to hold.

    Attributes:
        noise_n: Standard deviation [N] of the reading's white noise.
        last_n: The last noisy reading [N].
        rng: The noise's generator (the episode's, from :meth:`reset`).
    """

    def __init__(self, model: mujoco.MjModel, threshold_n: float) -> None:
        sensor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, HANDLE_TOUCH_SENSOR)
        self.adr = int(model.sensor_adr[sensor])
        self.threshold_n = float(threshold_n)
        self.noise_n = 0.0
        self.last_n = 0.0
        self.rng = np.random.default_rng(0)

    def reset(self, rng: np.random.Generator, noise_n: float) -> None:
        """New episode: the noise's generator and its standard deviation [N]."""
        self.rng, self.noise_n = rng, float(noise_n)
        self.last_n = 0.0

    def true_force(self, data: mujoco.MjData) -> float:
        """The noise-free reading [N]: the thumb's normal force on the handle."""
        return float(data.sensordata[self.adr])

    def human_holds(self, data: mujoco.MjData) -> bool:
        """Read the sensor once (noisy) and judge whether the human holds the object."""
        noise = self.noise_n * self.rng.standard_normal() if self.noise_n > 0.0 else 0.0
        self.last_n = max(0.0, self.true_force(data) + noise)  # a touch sensor reads >= 0
        return self.last_n > self.threshold_n
