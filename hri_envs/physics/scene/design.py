"""Physical design of each scenario: robot placement, grasps, object, gains and tolerances.

The scenario geometry (:mod:`hri_envs.task.geometry`) fixes where the supports and
waypoints are; this module fixes everything the abstract model leaves open. Frames:

* The *object frame* is the pose the scenario gives for a state: its origin is the point
  that rests on a support, its orientation the scenario's quaternion ``(w, x, y, z)``.
* The robot's *grip frame* is fixed in the object frame (``grip_pos``, ``grip_quat``); the
  hand's grip site is welded onto it while the robot holds the object. Its z axis is the
  gripper's approach direction.
* The human holds the object at ``handle_pos`` (object frame).

**Hanger.** The scenario's coordinates are those of the paper's user study. With the robot
base at their origin, no single grasp of the hanger reaches all 12 waypoints and 3 supports
in both orientations (checked with mink IK); the Panda is therefore mounted 20 cm in front of
and 5 cm to the left of that origin on a 10 cm plate, ``base_pos = (0.20, 0.05, 0.10)``, and
holds the hanger by its neck, 8 cm below the hook, with the gripper pointing along the
hanger's bar and tilted 45° down. This placement and grasp came out of a search over base
positions and grasp directions in which the IK reference had to follow every abstract
motion (straight lines and rotations) of the graph; with it all 108 (state, motion) pairs
of the hanger reach the state the graph predicts (``tests/test_physics.py``).

**Wheel.** The wheel scenario is human-scale: the rack is at 1.7 m and the stands are
1.6-3.6 m from it. A fixed-base Panda reaches about 0.85 m, so here the Panda stands on an
omnidirectional mobile base with a vertical lift, modelled as three prismatic joints
(x, y on the floor, z for the lift) under the arm, torque-driven like the arm. The robot
holds the wheel's rim on the -x side with its gripper pointing at the wheel's centre (+x),
the human holds the opposite rim point, so the abstract "rotate" (about x, the axis from the
robot to the human) spins the gripper about its own axis.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from hri_envs.errors import BackendUnavailableError, ConfigError
from hri_envs.physics.scene.shapes import HangerShapes, SceneShapes, WheelShapes
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import SCENARIOS, scenario_graph, scenario_spec, spec_of

__all__ = ["PRESET_NAMES", "PhysicsDesign", "design_for", "hanger_design", "physical_graph",
           "wheel_design"]

#: The named sets of physics options every design defines (``physics={"preset": ...}``):
#: ``weak-human``, a partner with a third of the default stiffness and strength (below the
#: robot's disagreement threshold on the hanger), slower to react and shakier, whose grip
#: the handle barely feels (2.5 N against the robot's 2 N threshold); ``noisy-sensor``, a
#: cheap, uncalibrated, slow wrist sensor and a noisy handle sensor.
PRESET_NAMES: tuple[str, ...] = ("weak-human", "noisy-sensor")


def _quat_from_axes(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of the frame with axes x, z (y = z × x)."""
    x = np.asarray(x, float) / np.linalg.norm(x)
    z = np.asarray(z, float) / np.linalg.norm(z)
    r = np.stack([x, np.cross(z, x), z], axis=1)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, r.flatten())
    return q


@dataclass(frozen=True)
class PhysicsDesign:
    """Everything physical about one scenario that the task graph does not fix.

    Units: metres, kilograms, seconds, newtons, radians.

    Attributes:
        scenario: "hanger" or "wheel".
        base_pos: Panda mount position (fixed base), or the zero of the mobile base's joints.
        mobile_base: Add prismatic x, y, z joints under the arm (wheel).
        home: Nominal arm configuration (7,), the IK posture target.
        grip_pos, grip_quat: The robot's grip frame in the object frame.
        handle_pos: The human's handle in the object frame.
        object_mass: Mass of the carried object.
        object_com: Its centre of mass in the object frame.
        object_inertia: Diagonal inertia about the centre of mass.
        linear_speed, angular_speed: Peak speeds of the robot's straight-line motions.
        stiffness: Cartesian stiffness (translational [N/m], rotational [N m/rad]).
        damping: Cartesian damping when tracking (translational, rotational).
        passive_damping: Cartesian damping in passive mode (zero stiffness).
        posture_stiffness, posture_damping: Null-space joint impedance (arm joints).
        base_stiffness, base_damping: Null-space impedance of the base joints (mobile).
        human_stiffness, human_damping, human_force: The simulated human's translational
            spring, damper and force saturation.
        human_rot_stiffness, human_rot_damping, human_torque: The same for rotation.
        human_noise: Standard deviation of the human's force noise [N] (torque: x 0.1 m).
        seat_stiffness, seat_damping, seat_hold: Supports' seat spring, damper and the
            detent force needed to pull the object out of a seat.
        seat_rot_stiffness, seat_rot_damping: The seat's rotational spring and damper.
        disagree_force: Disagreement force [N] where the robot starts softening, and where
            it is fully soft (DAVI); torques count as force × ``lever``.
        lever: Length [m] converting torques into comparable forces.
        position_tolerance, angle_tolerance: Distance to an abstract state's pose within
            which the object counts as *at* that state.
        step_time_limit: Simulated seconds after which an abstract step ends.
        human_mass: Effective mass [kg] of the human's embodied forearm (the hand adds
            0.1 kg); the arm carries its own weight (:mod:`~hri_envs.physics.panda.human_arm`).
        human_follow_damping: Damping of the human's arm while they follow (translational
            [N s/m], rotational [N m s/rad]): what a following human resists with, besides
            the hand's inertia.
        human_reach_lo, human_reach_hi: (3,) the box [m, world frame] the human's hand can
            reach (the joint ranges of the arm; the wheel's human walks).
        shapes: The object's and the supports' geometry in the scene
            (:class:`~hri_envs.physics.scene.shapes.SceneShapes`).
        presets: Values of the physics options per preset name (:data:`PRESET_NAMES`).

    The remaining fields are thresholds and times of the simulation loop, the same for both
    scenarios (class defaults); the unit is in the name (``_m``, ``_s``, ``_rad``, ``_j``;
    ``_steps``: physics time steps) or given here:

        pregrasp_distance_m: The idle hand waits this far back along its approach axis.
        grip_finger_pos_m: Finger joint position commanded when the hand closes on the grip
            (inside the grip geometry's half width, so the fingers press on it).
        motion_min_duration_s: Shortest straight-line motion (robot moves and retreat,
            the human's reaches).
        grasp_approach_min_duration_s: Shortest approach of the open hand to its grip.
        grasp_approach_time_limit_s: Time limit of that approach.
        grasp_close_time_s: Time the hand holds still while it closes (weld on).
        release_retreat_time_limit_s: Time limit of the retreat after letting go.
        reset_grip_ik_error_max_m, reset_pregrasp_ik_error_max_m: Largest IK error
            (:meth:`ReferenceIK.error`, [m] + 0.1 m/rad x [rad]) at reset on the grip and
            at the waiting pose; beyond it the layout cannot be served.
        ik_error_max_m: IK error (same measure) above which the reference lags its target.
        ik_error_time_max_s: How long the reference may lag before it is an IK failure.
        settle_vel_sq_max_m2_s2: Squared speed [m²/s²] below which the object is slow.
        settle_angvel_sq_max_rad2_s2: Squared angular speed [rad²/s²] below which it is
            slow.
        settle_calm_time_s: How long the object must stay slow (both agents done) to have
            settled.
        settle_min_time_s: Shortest simulated time of a motion phase before it can settle.
        timeout_fault_factor: A step that ends with the object farther than this multiple
            of ``position_tolerance`` or ``angle_tolerance`` from the observed state ends
            with an "off_support" fault (dimensionless).
        diverged_qvel_max: Largest |qvel| entry [m/s or rad/s] of a stable simulation.
        stability_check_every_steps: Check the simulation's stability this often.
        platform_update_every_steps: Move the mobile base's floor platform this often.
        human_work_min_j: Work of the human along the robot's motion above which the robot
            infers the human made the same action (else the human followed: wait).
        disagree_slack_factor: Opposing force tolerated along the motion, as a fraction of
            ``disagree_force[0]`` (torques: x ``lever``).
        disagree_rise_time_s, disagree_fall_time_s: Time constants of the softening α
            when the disagreement rises and when it falls.
        disagree_yield_alpha: α above which the robot is about to yield (dimensionless).
        disagree_yield_time_s: How long α must stay above it for the robot to yield.
        human_speed_factor: The human's reach speeds over the robot's ``linear_speed``
            and ``angular_speed`` (dimensionless).
        human_noise_time_s: Time constant of the human's force noise (band ~1 Hz).
        human_noise_torque_lever_m: The torque noise is the force noise x this lever.
        seat_capture_m: A seat captures the object within this distance across and along
            its exit direction.
        seat_capture_angle_rad: ... and within this angle of the seat's orientation.
        seat_fade_m: The seat force fades out over this last stretch of the capture region.
        sensor_noise_n, sensor_bias_n, sensor_delay_s: The wrist sensor's white noise
            (std per control step), constant bias and delay
            (:mod:`~hri_envs.physics.scene.sensing`).
        sensor_torque_lever_m: Torque noise and bias are the force's times this lever.
        human_delay_s: The human's reaction delay before a reach starts.
        grasp_tolerance_m, grasp_tolerance_rad: After closing, the hand's grip frame must lie
            within this distance and angle of the object's grip (the weld holds the object
            where the grip is meant to be); else the grasp fails (fault ``grasp_failed``).
        human_grip_force: How hard [N] the human's thumb squeezes the handle while they hold
            it (the thumb's position actuator saturates there).
        handle_noise_n: Standard deviation [N] of the handle's touch sensor reading.
        hold_touch_min_n: The robot takes the human to hold the object when the handle's
            touch sensor reads more than this [N] as a step ends.
        grasp_contact_force_n: After closing, each finger must press on the object's grip
            geometry with at least this normal force [N] for the grasp to hold (weld on);
            else the grasp fails (fault ``grasp_failed``).
        grip_hold_force_n: External force on the held object beyond which the grasp slips
            (fault ``pulled_out``) once it lasts ``grip_overload_time_s``.
        drop_margin_m: An object this far below the lowest abstract state, or touching the
            floor, has dropped (fault ``dropped``).
        control_every_steps: The robot's controller, the seat law, the sensor reading and
            the human's reference update once every this many physics steps (MuJoCo runs
            the steps in between in C, with the human's actuators and the robot's torques
            held). The settle test runs at the same rate; the stability and floor-contact
            checks every ``stability_check_every_steps`` physics steps (rounded down to
            whole control periods), so a touch of the floor shorter than that can be missed.
    """

    scenario: str
    base_pos: np.ndarray
    mobile_base: bool
    home: np.ndarray
    grip_pos: np.ndarray
    grip_quat: np.ndarray
    handle_pos: np.ndarray
    object_mass: float
    object_com: np.ndarray
    object_inertia: np.ndarray
    linear_speed: float
    angular_speed: float
    stiffness: tuple[float, float]
    damping: tuple[float, float]
    passive_damping: tuple[float, float]
    posture_stiffness: float
    posture_damping: float
    base_stiffness: float
    base_damping: float
    human_stiffness: float
    human_damping: float
    human_force: float
    human_rot_stiffness: float
    human_rot_damping: float
    human_torque: float
    human_noise: float
    seat_stiffness: float
    seat_damping: float
    seat_hold: float
    seat_rot_stiffness: float
    seat_rot_damping: float
    disagree_force: tuple[float, float]
    lever: float
    position_tolerance: float
    angle_tolerance: float
    step_time_limit: float
    human_mass: float
    human_follow_damping: tuple[float, float]
    human_reach_lo: np.ndarray
    human_reach_hi: np.ndarray
    shapes: SceneShapes
    presets: Mapping[str, Mapping[str, float]]
    # Simulation-loop thresholds and times (see the class docstring), shared by both scenarios.
    # Grasp toggles and motions (PandaSim.reset, step, _robot_toggle).
    pregrasp_distance_m: float = 0.08
    grip_finger_pos_m: float = 0.012
    motion_min_duration_s: float = 0.6
    grasp_approach_min_duration_s: float = 0.8
    grasp_approach_time_limit_s: float = 4.0
    grasp_close_time_s: float = 0.2
    release_retreat_time_limit_s: float = 3.0
    # IK (PandaSim.reset, _run): error = position [m] + 0.1 m/rad x orientation [rad].
    reset_grip_ik_error_max_m: float = 5e-3
    reset_pregrasp_ik_error_max_m: float = 0.03
    ik_error_max_m: float = 0.03
    ik_error_time_max_s: float = 0.5
    # Settling, faults and bookkeeping of the physics loop (PandaSim._run, step).
    settle_vel_sq_max_m2_s2: float = 1e-4  # (1 cm/s)²
    settle_angvel_sq_max_rad2_s2: float = 2.5e-3  # (0.05 rad/s)²
    settle_calm_time_s: float = 0.15
    settle_min_time_s: float = 0.05
    timeout_fault_factor: float = 2.5  # [-] x position_tolerance, angle_tolerance
    diverged_qvel_max: float = 50.0  # [m/s or rad/s]
    stability_check_every_steps: int = 50
    platform_update_every_steps: int = 25
    # The wrist force/torque sensor (sensing.SensorModel) and the human's reaction delay
    # (defaults of the physics options, hri_envs.physics.panda.options).
    sensor_noise_n: float = 0.05
    sensor_bias_n: float = 0.0
    sensor_delay_s: float = 0.0
    sensor_torque_lever_m: float = 0.1
    human_delay_s: float = 0.0
    # The handle's touch sensor: how the robot knows that the human holds
    # (panda.human_arm.HandleSensor).
    human_grip_force: float = 6.0
    handle_noise_n: float = 0.2
    hold_touch_min_n: float = 2.0
    # Physical failures (PandaSim.step, _run, _robot_toggle).
    grasp_tolerance_m: float = 0.015
    grasp_tolerance_rad: float = 0.25
    grasp_contact_force_n: float = 0.5
    grip_hold_force_n: float = 60.0
    grip_overload_time_s: float = 0.05
    drop_margin_m: float = 0.15
    # Human action inference (infer_human_action).
    human_work_min_j: float = 0.05
    # Disagreement-aware variable impedance (Disagreement).
    disagree_slack_factor: float = 0.5  # [-] x disagree_force[0]
    disagree_rise_time_s: float = 0.1
    disagree_fall_time_s: float = 0.3
    disagree_yield_alpha: float = 0.9  # [-]
    disagree_yield_time_s: float = 0.3
    # The simulated human (SimulatedHuman).
    human_speed_factor: float = 1.2  # [-] x linear_speed, angular_speed
    human_noise_time_s: float = 0.2
    human_noise_torque_lever_m: float = 0.1
    # Seats (Seats).
    seat_capture_m: float = 0.03
    seat_capture_angle_rad: float = float(np.deg2rad(25.0))
    seat_fade_m: float = 0.01
    # Control rate (PandaSim._run): 4 x 2 ms = 125 Hz.
    control_every_steps: int = 4


def hanger_design() -> PhysicsDesign:
    """The clothes hanger on a fixed-base Panda (see the module docstring)."""
    tilt = np.deg2rad(45.0)  # the gripper points along the bar, 45° down
    approach = np.array([-np.sin(tilt), np.cos(tilt), 0.0])
    up = np.array([np.cos(tilt), np.sin(tilt), 0.0])
    return PhysicsDesign(
        scenario="hanger",
        base_pos=np.array([0.20, 0.05, 0.10]),
        mobile_base=False,
        home=np.array([0.0, -0.5, 0.0, -2.2, 0.0, 0.9, 0.785]),
        grip_pos=np.array([-0.08, 0.0, 0.0]),
        grip_quat=_quat_from_axes(up, approach),
        handle_pos=np.array([-0.16, 0.2, 0.0]),
        object_mass=0.3,
        object_com=np.array([-0.12, 0.0, 0.0]),
        object_inertia=np.array([0.004, 0.0015, 0.0055]),
        linear_speed=0.25,
        angular_speed=0.9,
        stiffness=(600.0, 30.0),
        damping=(60.0, 2.5),
        passive_damping=(12.0, 0.6),
        posture_stiffness=15.0,
        posture_damping=2.0,
        base_stiffness=0.0,
        base_damping=0.0,
        human_stiffness=200.0,
        human_damping=18.0,
        human_force=12.0,
        human_rot_stiffness=8.0,
        human_rot_damping=0.8,
        human_torque=2.0,
        human_noise=0.4,
        seat_stiffness=2000.0,
        seat_damping=40.0,
        seat_hold=4.0,
        seat_rot_stiffness=20.0,
        seat_rot_damping=0.25,
        disagree_force=(4.0, 9.0),
        lever=0.2,
        position_tolerance=0.02,
        angle_tolerance=np.deg2rad(8.0),
        step_time_limit=20.0,
        human_mass=1.0,
        human_follow_damping=(2.0, 0.05),
        human_reach_lo=np.array([0.05, -0.9, 0.2]),  # the handle's states' box ± 0.15 m
        human_reach_hi=np.array([1.05, 0.8, 0.9]),
        shapes=HangerShapes(),
        presets={"weak-human": {"human_stiffness": 70.0, "human_force": 3.5,
                                "human_noise": 0.8, "human_delay_s": 0.4,
                                "human_grip_force": 2.5},
                 "noisy-sensor": {"sensor_noise_n": 3.0, "sensor_bias_n": 2.5,
                                  "sensor_delay_s": 0.05, "handle_noise_n": 1.0}},
    )


def wheel_design() -> PhysicsDesign:
    """The wheel on a Panda with a mobile base and lift (see the module docstring)."""
    return PhysicsDesign(
        scenario="wheel",
        base_pos=np.array([-0.9, 0.0, 0.6]),
        mobile_base=True,
        # Gripper horizontal and forward: q6 - (q2 - q4) = 0 in this model's convention.
        home=np.array([0.0, 0.3, 0.0, -1.4, 0.0, 1.7, 0.0]),
        grip_pos=np.array([-0.32, 0.0, 0.0]),
        grip_quat=_quat_from_axes(np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])),
        handle_pos=np.array([0.32, 0.0, 0.0]),
        object_mass=1.0,  # a bicycle wheel: the Panda's wrist (12 N m) holds it at the rim
        object_com=np.zeros(3),
        object_inertia=np.array([0.025, 0.025, 0.045]),
        linear_speed=0.5,
        angular_speed=0.9,
        stiffness=(900.0, 60.0),
        damping=(120.0, 6.0),
        passive_damping=(30.0, 1.5),
        posture_stiffness=20.0,
        posture_damping=3.0,
        base_stiffness=3000.0,
        base_damping=800.0,
        human_stiffness=300.0,
        human_damping=50.0,
        human_force=30.0,
        human_rot_stiffness=25.0,
        human_rot_damping=3.0,
        human_torque=8.0,
        human_noise=1.0,
        seat_stiffness=8000.0,
        seat_damping=200.0,
        seat_hold=10.0,
        seat_rot_stiffness=150.0,
        seat_rot_damping=6.0,
        # Fully soft at 22 N (18 N before the human was embodied): pulling the wheel off the
        # rack against the rack's 10 N detent while the human's hand (1.5 kg) follows must
        # not look like disagreement.
        disagree_force=(8.0, 22.0),
        lever=0.3,
        position_tolerance=0.03,
        angle_tolerance=np.deg2rad(8.0),
        step_time_limit=40.0,
        human_mass=1.5,
        human_follow_damping=(5.0, 0.3),
        human_reach_lo=np.array([-4.0, -1.0, 0.5]),  # the room the stands are placed in
        human_reach_hi=np.array([4.0, 4.5, 2.1]),
        shapes=WheelShapes(),
        presets={"weak-human": {"human_stiffness": 100.0, "human_force": 8.0,
                                "human_noise": 2.0, "human_delay_s": 0.4,
                                "human_grip_force": 2.5},
                 "noisy-sensor": {"sensor_noise_n": 6.0, "sensor_bias_n": 5.0,
                                  "sensor_delay_s": 0.05, "handle_noise_n": 1.0}},
    )


def design_for(graph: TaskGraph) -> PhysicsDesign:
    """The physical design of ``graph``'s scenario (its spec's ``physics_design``).

    Raises:
        BackendUnavailableError: The scenario has no physical design.
    """
    spec = spec_of(graph)
    entry = spec.physics_design
    if entry is None:
        raise BackendUnavailableError(f"scenario {spec.name!r} has no physical design, so no "
                                      "physics backend; use backend='graph'", field="backend")
    module, _, factory = entry.partition(":")
    design: PhysicsDesign = getattr(importlib.import_module(module), factory)()
    return design


def physical_graph(scenario: str) -> TaskGraph:
    """The task graph of the registered scenario ``scenario`` (an env constructor's
    ``scenario=``, resolved once here), which must have a physical design.

    Raises:
        ConfigError: An unknown scenario, or one without a physical design
            (``field="scenario"``; the message lists those with one).
    """
    if scenario_spec(scenario).physics_design is None:
        allowed = (name for name, spec in SCENARIOS.items() if spec.physics_design is not None)
        raise ConfigError(f"scenario {scenario!r} has no physical design; allowed: "
                          f"{', '.join(allowed)}", field="scenario")
    return scenario_graph(scenario)
