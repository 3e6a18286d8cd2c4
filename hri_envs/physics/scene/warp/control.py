"""The control period's laws over a leading axis of worlds on MuJoCo Warp: the compiled laws
of :mod:`~hri_envs.physics.scene.laws` (those the C backend of the continuous envs runs with one
world) with R = the worlds ``rows`` that run the period, their inputs gathered from MuJoCo
Warp's arrays (host views on the CPU device, as float64).

* :class:`RobotImpedance`: :class:`~hri_envs.physics.scene.controller.ImpedanceController`'s
  torques (:func:`~hri_envs.physics.scene.laws.robot_task`, ``M⁻¹`` by MuJoCo Warp's ``solve_m``,
  :func:`~hri_envs.physics.scene.laws.robot_null_space`; site Jacobians from the joint axes);
* :class:`WristSensors`: :class:`~hri_envs.physics.scene.sensing.WristSensor` and its
  :class:`~hri_envs.physics.scene.sensing.SensorModel`
  (:func:`~hri_envs.physics.scene.laws.wrist_wrench`, each world's delay line,
  :func:`~hri_envs.physics.scene.laws.sensor_noise` with each world's bias and noise generator);
* :class:`WarpSeats`: :class:`~hri_envs.physics.scene.seats.Seats`
  (:func:`~hri_envs.physics.scene.laws.seat_wrench`), each world with its own layout;
* :func:`disagreement`, :func:`davi`: :class:`~hri_envs.physics.scene.controller.Disagreement`
  (the discrete Panda backend's, vectorised in numpy here).
"""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np

from hri_envs.physics.scene import laws
from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.controller import LAMBDA_INV_REGULARIZATION, ImpedanceController
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.seats import Seats
from hri_envs.physics.scene.sensing import SensorModel, WristSensor
from hri_envs.physics.scene.warp import batchmath as bm
from hri_envs.physics.scene.warp.model import WarpModel

__all__ = ["RobotImpedance", "WarpSeats", "WristSensors", "chain_jacobian", "davi",
           "disagreement", "host"]


def host(wm: WarpModel, name: str, rows: np.ndarray, *index: int | slice) -> np.ndarray:
    """The Data array ``name`` of the worlds ``rows`` at ``index`` as a contiguous float64
    array (what the compiled laws take; a 3 x 3 matrix per world as its 9 entries, row-major
    as MuJoCo's).
    """
    out = np.ascontiguousarray(wm._get(name)[(rows, *index)], dtype=float)
    return out.reshape(len(rows), 9) if out.shape[1:] == (3, 3) else out


def chain_jacobian(wm: WarpModel, rows: np.ndarray, joints: np.ndarray, hinge: np.ndarray,
                   point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R, 6, n) Jacobian of ``point`` (R, 3) w.r.t. the 1-dof ``joints`` (n,) that move it
    (``hinge`` (n,) bool: hinge, else slide), from the joints' world axes and anchors; also
    the axes and anchors (R, n, 3).
    """
    anchor = wm._get("xanchor")[rows][:, joints].astype(float)  # (R, n, 3)
    axis = wm._get("xaxis")[rows][:, joints].astype(float)
    h = hinge[None, :, None]
    jac = np.empty((len(rows), 6, len(joints)))
    jac[:, :3] = np.where(h, np.cross(axis, point[:, None] - anchor), axis).transpose(0, 2, 1)
    jac[:, 3:] = np.where(h, axis, 0.0).transpose(0, 2, 1)
    return jac, axis, anchor


class RobotImpedance:
    """The robot's Cartesian impedance controller, per world.

    Args:
        model: The C model (joint axes' types).
        scene: The scene (ids, torque limits).
        controller: The C controller (its posture gains and the payload's weight).
        design: Stiffness, damping.
    """

    def __init__(self, model: mujoco.MjModel, scene: Scene, controller: ImpedanceController,
                 design: PhysicsDesign) -> None:
        self.scene = scene
        self.n = len(scene.robot_dofs)
        jnt = [int(np.flatnonzero(model.jnt_dofadr == d)[0]) for d in scene.robot_dofs]
        self.joints = np.array(jnt)
        self.hinge = model.jnt_type[self.joints] == mujoco.mjtJoint.mjJNT_HINGE
        self.weight = np.asarray(controller.weight, dtype=float)
        self.kn, self.dn = controller.kn, controller.dn
        self.gains = np.array([*design.stiffness, *design.damping, *design.passive_damping],
                              dtype=float)
        self.tau_hi = np.asarray(scene.torque_limit, dtype=float)

    def torques(self, wm: WarpModel, rows: np.ndarray, q: np.ndarray, qd: np.ndarray,
                ref: np.ndarray, has_ref: np.ndarray, scale: np.ndarray, payload: np.ndarray,
                q_ref: np.ndarray) -> np.ndarray:
        """ImpedanceController.torques per world: (R, n) torques of the robot's joints.

        Args:
            wm: The worlds (kinematics of this period computed).
            rows: (R,) the worlds.
            q: (R, n) the robot's joint positions.
            qd: (R, n) their velocities.
            ref: (R, 13) the grip frame's reference (position, quaternion, velocities).
            has_ref: (R,) bool, tracking (else passive).
            scale: (R,) the stiffness scale.
            payload: (R,) bool, compensate the held object's weight.
            q_ref: (R, n) the null-space posture reference.
        """
        sc, n, r = self.scene, self.n, len(rows)
        site = host(wm, "site_xpos", rows, sc.grip_site)
        jac, axis, anchor = chain_jacobian(wm, rows, self.joints, self.hinge, site)
        com = host(wm, "xipos", rows, sc.object_body)
        jac_com = np.ascontiguousarray(np.where(self.hinge[None, :, None], np.cross(
            axis, com[:, None] - anchor), axis).transpose(0, 2, 1))  # (R, 3, n)
        tau, rhs = np.empty((r, n)), np.empty((r, 7, n))
        laws.robot_task(jac, np.ascontiguousarray(qd, dtype=float), site,
                        host(wm, "site_xmat", rows, sc.grip_site),
                        np.ascontiguousarray(ref, dtype=float), np.asarray(has_ref, np.bool_),
                        np.asarray(scale, dtype=float), self.gains,
                        host(wm, "qfrc_bias", rows, slice(0, n)), np.asarray(payload, np.bool_),
                        jac_com, self.weight, np.ascontiguousarray(q, dtype=float),
                        np.ascontiguousarray(q_ref, dtype=float), self.kn, self.dn, tau, rhs)
        # M⁻¹ [Jᵀ | τ₀] by MuJoCo Warp's factorised mass matrix (all worlds, 7 solves).
        minv = wm.solve_m(rows, [rhs[:, c] for c in range(7)], n)
        out = np.empty((r, n))
        laws.robot_null_space(jac, minv, rhs, tau, LAMBDA_INV_REGULARIZATION, -self.tau_hi,
                              self.tau_hi, out)
        return out


class WristSensors:
    """The wrist sensor of every world: its compensation and each world's sensor model.

    Args:
        n: The number of worlds.
        sensor: The C template's sensor (addresses, the known weights).
        lever: The torque noise and bias lever [m].

    Attributes:
        noise: (n,) the white noise [N]; bias: (n, 6) the constant bias.
        true_wrench: (n, 6) the last noise-free estimate.
        delay: (n,) the delay [control periods]; queues: each world's delay line.
        rngs: Each world's noise generator (None: never reset).
    """

    def __init__(self, n: int, sensor: WristSensor, lever: float) -> None:
        self.adr_force, self.adr_torque = sensor.force_adr, sensor.torque_adr
        self.site, self.hand = sensor.site, sensor.hand
        self.hand_weight = np.asarray(sensor.hand_weight, dtype=float)
        self.object_weight = np.asarray(sensor.object_weight, dtype=float)
        self.object_com = np.asarray(sensor.object_com, dtype=float)
        self.lever = lever
        self.noise = np.zeros(n)
        self.bias = np.zeros((n, 6))
        self.true_wrench = np.zeros((n, 6))
        self.delay = np.zeros(n, dtype=np.int64)
        self.queues: list[deque[np.ndarray]] = [deque() for _ in range(n)]
        self.rngs: list[np.random.Generator | None] = [None] * n

    def reset_world(self, i: int, model: SensorModel) -> None:
        """World ``i`` takes a C sensor model just reset (its bias and generator)."""
        self.noise[i], self.bias[i] = model.noise_n, model.bias
        self.delay[i] = model.delay_steps
        self.rngs[i] = model.rng
        self.queues[i] = deque()
        self.true_wrench[i] = 0.0

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` take world ``src``'s sensor state, each its own generator
        (seeded by its index).
        """
        for value in (self.noise, self.bias, self.true_wrench, self.delay):
            value[rows] = value[src]
        for i in rows:
            self.queues[int(i)] = deque(self.queues[src])
            self.rngs[int(i)] = np.random.default_rng([int(i), 1])

    def _rng(self, i: int) -> np.random.Generator:
        rng = self.rngs[int(i)]
        if rng is None:
            raise RuntimeError(f"world {i} was never reset")
        return rng

    def external(self, wm: WarpModel, rows: np.ndarray, sensordata: np.ndarray,
                 holding: np.ndarray, pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """WristSensor.external per world: (R, 6) the sensed external wrench on the object.

        Args:
            wm: The worlds (kinematics of this period).
            rows: (R,) the worlds.
            sensordata: (R, nsensordata) the sensors after the last physics step.
            holding: (R,) the robot holds the object (else the true estimate is zero).
            pos: (R, 3) the object's position.
            rot: (R, 3, 3) its orientation.
        """
        r = len(rows)
        fa, ta = self.adr_force, self.adr_torque
        true = np.empty((r, 6))
        laws.wrist_wrench(np.asarray(holding, np.bool_),
                          np.ascontiguousarray(sensordata[:, fa:fa + 3], dtype=float),
                          np.ascontiguousarray(sensordata[:, ta:ta + 3], dtype=float),
                          host(wm, "site_xpos", rows, self.site),
                          host(wm, "site_xmat", rows, self.site),
                          host(wm, "subtree_com", rows, self.hand),
                          np.ascontiguousarray(pos, dtype=float),
                          np.ascontiguousarray(rot, dtype=float).reshape(r, 9),
                          self.hand_weight, self.object_weight, self.object_com, true)
        self.true_wrench[rows] = true
        delayed = true.copy()
        for j in np.flatnonzero(self.delay[rows] > 0):
            i = int(rows[j])
            queue = self.queues[i]
            queue.append(true[j].copy())
            delayed[j] = queue.popleft() if len(queue) > self.delay[i] else queue[0]
        noise = self.noise[rows]
        z = np.zeros((r, 6))
        for j in np.flatnonzero(noise > 0.0):
            z[j] = self._rng(rows[j]).standard_normal(6)
        out = np.empty((r, 6))
        laws.sensor_noise(delayed, np.ascontiguousarray(self.bias[rows]), noise, z,
                          self.lever, out)
        return out


class WarpSeats:
    """The seats of every world (each world's layout: the wheel's stands move).

    Args:
        n: The number of worlds.
        seats: The C template's seats (the seat orientations, the same in every layout; the
            capture region).
        design: Stiffness, damping, fade.

    Attributes:
        pos, exit: (n, K, 3) each world's seat positions and exit directions.
        quat: (n, K, 4) the seats' orientations.
        hold: (n,) each world's detent force [N].
    """

    def __init__(self, n: int, seats: Seats, design: PhysicsDesign) -> None:
        self.capture, self.max_angle = float(seats.capture), float(seats.max_angle)
        self.gains = np.array([design.seat_stiffness, design.seat_damping,
                               design.seat_rot_stiffness, design.seat_rot_damping,
                               design.seat_fade_m], dtype=float)
        self.pos = np.zeros((n, len(seats.pos), 3))
        self.exit = np.zeros_like(self.pos)
        self.quat = np.repeat(seats.quat[None], n, axis=0).astype(float)
        self.hold = np.zeros(n)

    def set_world(self, i: int, seats: Seats, hold: float) -> None:
        """World ``i``'s layout: that of the C ``seats`` (set to the world's scenario)."""
        self.pos[i], self.exit[i], self.hold[i] = seats.pos, seats.exit, hold

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` take world ``src``'s layout."""
        for value in (self.pos, self.exit, self.quat, self.hold):
            value[rows] = value[src]

    def engaged(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(R,) the support whose seat holds the object in each world of ``rows``, or -1."""
        return laws.seat_engaged(np.ascontiguousarray(pos, dtype=float),
                                 np.ascontiguousarray(quat, dtype=float), self.pos[rows],
                                 self.exit[rows], self.quat[rows], self.capture,
                                 self.max_angle)

    def apply(self, wm: WarpModel, rows: np.ndarray, body: int, pos: np.ndarray,
              quat: np.ndarray, vel: np.ndarray, angvel: np.ndarray) -> np.ndarray:
        """The seats' wrenches on the object ``body`` as its applied force (``xfrc_applied``
        of the worlds ``rows``, the others' unchanged); (R,) the seat of each, or -1.
        """
        wrench = np.empty((len(rows), 6))
        seat = laws.seat_wrench(np.ascontiguousarray(pos, dtype=float),
                                np.ascontiguousarray(quat, dtype=float),
                                np.ascontiguousarray(vel, dtype=float),
                                np.ascontiguousarray(angvel, dtype=float), self.pos[rows],
                                self.exit[rows], self.quat[rows], self.capture,
                                self.max_angle, self.gains, self.hold[rows], wrench)
        xfrc = wm._get("xfrc_applied")
        xfrc[rows, body] = wrench
        wm._put("xfrc_applied", xfrc)
        return seat


def disagreement(design: PhysicsDesign, force: np.ndarray, torque: np.ndarray, u: np.ndarray,
                 axis: np.ndarray) -> np.ndarray:
    """Disagreement.force per world [N]."""
    f0 = design.disagree_force[0]
    slack = design.disagree_slack_factor * f0
    lever = design.lever
    along = bm.dot(force, u)
    across = np.linalg.norm(force - along[:, None] * u, axis=1)
    t_along = bm.dot(torque, axis)
    t_across = np.linalg.norm(torque - t_along[:, None] * axis, axis=1)
    return (across + np.maximum(-along - slack, 0.0)
            + (t_across + np.maximum(-t_along - slack * lever, 0.0)) / lever)


def davi(design: PhysicsDesign, rows: np.ndarray, force: np.ndarray, dt: float,
         alpha: np.ndarray, high: np.ndarray, yielded: np.ndarray) -> np.ndarray:
    """Disagreement.update per world (``alpha``, ``high``, ``yielded``: (N,) arrays of all
    the worlds, updated at ``rows``); the stiffness scales (R,).
    """
    f0, f1 = design.disagree_force
    target = np.clip((force - f0) / (f1 - f0), 0.0, 1.0)
    a = alpha[rows]
    tau = np.where(target > a, design.disagree_rise_time_s, design.disagree_fall_time_s)
    a = a + (target - a) * np.minimum(dt / tau, 1.0)
    alpha[rows] = a
    h = np.where(a > design.disagree_yield_alpha, high[rows] + dt, 0.0)
    high[rows] = h
    yielded[rows] |= h >= design.disagree_yield_time_s
    return np.where(yielded[rows], 0.0, 1.0 - a)
