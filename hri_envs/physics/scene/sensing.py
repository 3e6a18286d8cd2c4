"""What the robot senses of the human: the wrist force/torque sensor and its model.

The scene has MuJoCo ``force`` and ``torque`` sensors at the Panda's flange (site
``wrist_ft`` on link 7): they measure the wrench that link 6 exerts on link 7's subtree
(link 7, hand, fingers) and, while the grasp weld holds, through it on the object. The robot
turns the reading into an estimate of the *external* wrench on the object, the way a real
controller does with a calibrated sensor:

* rotate the reading into the world frame;
* remove the static load the robot knows of: the weight of its hand (link 7's subtree mass
  at its centre of mass) and, while it holds the object, the object's *nominal* weight
  (``PhysicsDesign.object_mass`` at ``object_com``); inertial forces are not compensated;
* move the torque to the object's origin.

What remains is the human's wrench plus whatever else acts on the object (a support's seat,
the floor, a mass that differs from the nominal one, the inertia of the hand and object).
The sensor model then adds a constant bias (a random direction per episode, magnitude
``sensor_bias_n``), white noise (``sensor_noise_n`` per control step) and a delay of
``sensor_delay_s``; torques get the same, times ``sensor_torque_lever_m``. Without a grasp
the robot senses nothing of the object: the estimate is zero.

Whether the human holds the object the wrist cannot tell: the human grasps and lets go
only while a support's seat carries the object, and the seat, not the robot, takes up what
the hand adds (docs/physics.md). The object's handle is therefore instrumented: a MuJoCo
``touch`` sensor under the human's thumb, which
:class:`~hri_envs.physics.panda.human_arm.HandleSensor` reads with white noise (the discrete
Panda backend's human arm; the continuous envs' human holds by friction).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.kinematics import cross3

__all__ = ["SensorModel", "WristSensor"]


class SensorModel:
    """Noise, bias and delay of the wrist sensor.

    Args:
        noise_n: Standard deviation [N] of the white force noise per control step.
        bias_n: Magnitude [N] of the constant force bias (random direction per episode).
        delay_s: Delay [s] of the reading.
        torque_lever_m: Torque noise and bias are the force's times this lever [m].
        dt: Control (physics) time step [s].

    Attributes:
        rng: The noise's generator (the episode's, from :meth:`reset`).
    """

    def __init__(self, noise_n: float, bias_n: float, delay_s: float, torque_lever_m: float,
                 dt: float) -> None:
        self.noise_n, self.bias_n, self.lever = float(noise_n), float(bias_n), torque_lever_m
        self.delay_steps = max(0, round(delay_s / dt))
        self.bias = np.zeros(6)
        self._queue: deque[np.ndarray] = deque()
        self.rng = np.random.default_rng(0)

    def reset(self, rng: np.random.Generator) -> None:
        """New episode: a fresh bias direction, an empty delay line."""
        self.rng = rng
        self.bias[:] = 0.0
        if self.bias_n > 0.0:
            d = rng.standard_normal(6)
            self.bias[:3] = self.bias_n * d[:3] / np.linalg.norm(d[:3])
            self.bias[3:] = self.lever * self.bias_n * d[3:] / np.linalg.norm(d[3:])
        self._queue.clear()

    def apply(self, wrench: np.ndarray) -> np.ndarray:
        """The sensed (6,) wrench for the true (6,) one: delayed, biased, noisy."""
        if self.delay_steps:
            self._queue.append(wrench.copy())
            wrench = (self._queue.popleft() if len(self._queue) > self.delay_steps
                      else self._queue[0])
        if self.noise_n <= 0.0:
            return wrench + self.bias
        # Element by element what numpy would compute, on plain floats (6 values).
        k, lever = self.noise_n, self.lever
        z = self.rng.standard_normal(6).tolist()
        w = (wrench + self.bias).tolist()
        return np.array([w[0] + k * z[0], w[1] + k * z[1], w[2] + k * z[2],
                         w[3] + k * z[3] * lever, w[4] + k * z[4] * lever,
                         w[5] + k * z[5] * lever])


    def apply_all(self, wrenches: np.ndarray) -> np.ndarray:
        """The last of the readings :meth:`apply` gives for the true (P, 6) ``wrenches`` of
        P control periods in order (the same draws and delay line; without a delay the
        noise of all P periods is drawn at once, the same numbers).
        """
        if self.delay_steps or self.noise_n <= 0.0:
            out = self.bias.copy()
            for w in wrenches:
                out = self.apply(w)
            return np.array(out, dtype=float)
        z = self.rng.standard_normal((len(wrenches), 6))
        k, lever = self.noise_n, self.lever
        # Element by element what apply() computes for the last wrench.
        w = (wrenches[-1] + self.bias).tolist()
        zl = z[-1].tolist()
        return np.array([w[0] + k * zl[0], w[1] + k * zl[1], w[2] + k * zl[2],
                         w[3] + k * zl[3] * lever, w[4] + k * zl[4] * lever,
                         w[5] + k * zl[5] * lever])


class WristSensor:
    """Reads the wrist sensor and estimates the external wrench on the held object.

    Args:
        scene: The compiled scene (sensor addresses, bodies, nominal design).
        model: The sensor's noise, bias and delay.

    Attributes:
        true_wrench: (6,) the last noise-free estimate (compensated, not delayed) [N, N m].
    """

    def __init__(self, scene: Scene, model: SensorModel) -> None:
        m = scene.model
        design = scene.design
        self.scene = scene
        self.model = model
        self.force_adr = int(m.sensor_adr[scene.force_sensor])
        self.torque_adr = int(m.sensor_adr[scene.torque_sensor])
        self.site = scene.wrist_site
        self.hand = scene.hand_body
        gravity = np.asarray(m.opt.gravity, dtype=float)
        self.hand_weight = float(m.body_subtreemass[self.hand]) * gravity  # (3,) [N]
        self.object_weight = design.object_mass * gravity  # the nominal payload [N]
        self.object_com = np.asarray(design.object_com, dtype=float)
        self.true_wrench = np.zeros(6)
        self._zero = np.zeros(6)
        self._hand_weight = tuple(self.hand_weight.tolist())
        self._object_weight = tuple(self.object_weight.tolist())
        self._data: object = None

    def reset(self, rng: np.random.Generator) -> None:
        """New episode (see :meth:`SensorModel.reset`)."""
        self.model.reset(rng)
        self.true_wrench[:] = 0.0

    def _bind(self, data: object) -> None:
        """Views into ``data``'s arrays read each control period (their memory is fixed)."""
        d = data  # mujoco.MjData
        self._data = data
        self._rot = d.site_xmat[self.site].reshape(3, 3)  # type: ignore[attr-defined]
        s = d.sensordata  # type: ignore[attr-defined]
        self._force = s[self.force_adr:self.force_adr + 3]
        self._torque = s[self.torque_adr:self.torque_adr + 3]
        self._site_pos = d.site_xpos[self.site]  # type: ignore[attr-defined]
        self._hand_com = d.subtree_com[self.hand]  # type: ignore[attr-defined]

    def raw(self, data: object) -> tuple[np.ndarray, np.ndarray]:
        """The reading in the world frame: force [N] and torque [N m] about the flange."""
        if data is not self._data:
            self._bind(data)
        return self._rot.dot(self._force), self._rot.dot(self._torque)

    def external(self, data: object, holding: bool, obj_pos: np.ndarray,
                 obj_rot: np.ndarray) -> np.ndarray:
        """(6,) compensated external wrench on the object: force [N], torque at its origin.

        Args:
            data: The simulation state after a step (sensors computed).
            holding: The robot holds the object (else the estimate is zero).
            obj_pos: (3,) the object's origin as the robot sees it [m].
            obj_rot: (3, 3) its orientation.
        """
        if not holding:
            self.true_wrench[:] = 0.0
            return self.model.apply(self._zero)
        f_s, t_s = self.raw(data)
        # Statics of the subtree (hand + object): F_parent + Σ m g + F_ext = 0, torques about
        # the flange likewise; the sensor reads the parent's wrench on the subtree. The
        # 3-vector arithmetic runs on plain floats, element by element as numpy would.
        fx, fy, fz = f_s.tolist()
        tx, ty, tz = t_s.tolist()
        px, py, pz = self._site_pos.tolist()
        hx, hy, hz = self._hand_com.tolist()
        ox, oy, oz = obj_pos.tolist()
        cx, cy, cz = obj_rot.dot(self.object_com).tolist()
        cx, cy, cz = ox + cx, oy + cy, oz + cz  # the object's centre of mass
        gx, gy, gz = self._hand_weight
        wx, wy, wz = self._object_weight
        f_ext = (-fx - gx - wx, -fy - gy - wy, -fz - gz - wz)
        a, b = (hx - px, hy - py, hz - pz), (cx - px, cy - py, cz - pz)
        ah, bo = cross3(a, self._hand_weight), cross3(b, self._object_weight)
        t_ext = (-tx - ah[0] - bo[0], -ty - ah[1] - bo[1], -tz - ah[2] - bo[2])
        rf = cross3((ox - px, oy - py, oz - pz), f_ext)
        w = self.true_wrench
        w[:] = (*f_ext, t_ext[0] - rf[0], t_ext[1] - rf[1], t_ext[2] - rf[2])
        return self.model.apply(w)
