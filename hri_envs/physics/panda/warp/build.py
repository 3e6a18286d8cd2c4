"""The v0 Panda scene's worlds built from a C :class:`~hri_envs.physics.panda.sim.PandaSim`: their
model, per-world arrays, resets and per-world switches (:class:`PandaWorldsState`, the base of
:class:`~hri_envs.physics.panda.warp.worlds.WarpWorlds`).

The grasps are per world: the welds are equality constraints whose ``eq_active`` lives in
``Data``, and the contacts that the C backend switches off by ``contype`` (the finger pads
while the weld holds, the open thumb) are switched off per world by a geom margin of -1 m
(MuJoCo Warp fixes the colliding pairs per model from ``contype``/``conaffinity``; a contact
with a margin of -1 m is never detected). The finger servos' stiffening while welded, the
human's gains and strength and the object's true mass are per-world model values.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hri_envs.physics.panda.human_arm import HAND_CONTACT_BIT
from hri_envs.physics.panda.sim import PandaSim, StepResult
from hri_envs.physics.scene.build import (
    FINGER_HOLD_STIFFENING,
    FINGER_ON_GRIP_M,
    FINGER_OPEN_M,
)
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import Pose
from hri_envs.physics.scene.warp import batchmath as bm
from hri_envs.physics.scene.warp.control import RobotImpedance, WarpSeats, WristSensors
from hri_envs.physics.scene.warp.ik import BatchIK
from hri_envs.physics.scene.warp.model import WarpModel
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import WAIT, TaskGraph

__all__ = ["PER_WORLD", "PandaWorldsState"]

# Phases of a world's abstract step.
IDLE, APPROACH, CLOSE, RETREAT, MAIN = 0, 1, 2, 3, 4
_CONTACT_OFF_MARGIN_M = -1.0  # a geom margin that no contact reaches
#: The model values that differ per world.
_MODEL_PER_WORLD = ("geom_margin", "actuator_gainprm", "actuator_biasprm",
                    "actuator_forcerange", "body_mass", "body_inertia")

#: The per-world arrays of :class:`PandaWorldsState` (first axis: the worlds).
PER_WORLD: tuple[str, ...] = (
    "phase", "holding", "human_holding", "q_ref", "states", "has_line", "has_hold", "l_start",
    "l_delta", "l_rot", "l_q0", "l_q1", "l_dur", "l_dir", "l_axis", "hold_pos", "hold_quat",
    "limit_s", "min_time_s", "elapsed", "calm", "ik_bad", "t_line", "yielded", "alpha", "high",
    "overload", "period", "settled", "h_plan", "h_t", "h_noise", "h_start", "h_delta", "h_rot",
    "h_q0", "h_q1", "h_dur", "following", "reach_kp", "reach_kv", "follow_kv", "noise_scale",
    "lead", "tot", "lowest_z", "sensordata")


@dataclass
class World:
    """What one world keeps between control periods, apart from the arrays."""

    rng: np.random.Generator | None = None  # the human's noise (the episode's generator)
    handle_rng: np.random.Generator | None = None
    handle_noise_n: float = 0.0
    scenario: Scenario | None = None
    design: PhysicsDesign | None = None  # the episode's true design
    # The step in progress.
    s: int = 0
    a_r: int = WAIT
    a_h: int = WAIT
    t0: float = 0.0
    fault: str | None = None
    settled: bool = False
    yielded: bool = False
    result: StepResult | None = None


class PandaWorldsState(WarpModel):
    """``n_worlds`` worlds of one scenario's v0 Panda scene on MuJoCo Warp: the model, the
    per-world arrays, resets and switches (see :class:`~hri_envs.physics.panda.warp.worlds.
    WarpWorlds` for the arguments).
    """

    def __init__(self, graph: TaskGraph, n_worlds: int, design: PhysicsDesign | None = None,
                 options: Mapping[str, Any] | None = None, device: str | None = None,
                 ik_rate: float = 25.0) -> None:
        self.graph = graph
        tpl = self.template = PandaSim(graph, design, ik_rate=ik_rate, options=options)
        self.design = tpl.design
        sc = self.scene = tpl.scene
        # The grasp weld's relative pose is written into the model on the first grasp: do
        # it once before the model is copied to Warp (it is the same for every grasp).
        tpl.weld(True)
        tpl.weld(False)
        mjm = copy.copy(tpl.model)
        # Every switchable contact on in the Warp model (MuJoCo Warp fixes the colliding
        # pairs from these bits); per world they are switched by geom margin.
        mjm.geom_contype[sc.finger_geoms.ravel()] = tpl.finger_contype
        mjm.geom_contype[tpl.arm.thumb_pad] = HAND_CONTACT_BIT
        super().__init__(mjm, n_worlds, _MODEL_PER_WORLD, device)
        n = self.n
        self.dt = tpl.dt
        self.k = tpl.control_every
        self.dt_control = tpl.dt_control
        self.ik_every = tpl.ik_every
        self.n_robot = len(sc.robot_dofs)
        self.n_base = tpl.n_base
        self.n_tree = self.n_robot + 2  # the robot's tree: base, arm and the two fingers
        self._acts = sc.robot_actuators
        self._arm = tpl.arm
        self._finger_geoms = sc.finger_geoms.ravel()
        self._finger_margin = mjm.geom_margin[self._finger_geoms].copy()
        self._thumb_margin = float(mjm.geom_margin[self._arm.thumb_pad])
        self._finger_kp = mjm.actuator_gainprm[sc.finger_actuators, 0].copy()
        self._adr_touch = tpl.handle.adr
        self._handle = self._arm.handle
        self._arm_lo, self._arm_hi = self._arm.range_lo, self._arm.range_hi
        self.robot = RobotImpedance(mjm, sc, tpl.controller, self.design)
        self.sensors = WristSensors(n, tpl.sensor, tpl.design.sensor_torque_lever_m)
        self.seats = WarpSeats(n, tpl.seats, self.design)
        # The IK reference: mink-warp on the robot-only model, one problem per world.
        self.ik = BatchIK(tpl.ik.model, n, self.n_base, tpl.ik.home, self.device)
        self.worlds = [World() for _ in range(n)]
        self.on_period: Callable[[np.ndarray], None] | None = None
        self._alloc()

    def _alloc(self) -> None:
        n, n_r = self.n, self.n_robot
        z3, z4 = np.zeros((n, 3)), np.zeros((n, 4))
        self.phase = np.zeros(n, dtype=np.int64)
        self.holding = np.zeros(n, dtype=bool)
        self.human_holding = np.zeros(n, dtype=bool)
        self.q_ref = np.zeros((n, n_r))
        self.states = np.zeros(n, dtype=np.int64)
        # The phase's run (PandaSim._run): its line, hold reference, limits and counters.
        self.has_line, self.has_hold = np.zeros(n, bool), np.zeros(n, bool)
        self.l_start, self.l_delta, self.l_rot = z3.copy(), z3.copy(), z3.copy()
        self.l_q0, self.l_q1 = z4.copy(), z4.copy()
        self.l_dur = np.ones(n)
        self.l_dir, self.l_axis = z3.copy(), z3.copy()
        self.hold_pos, self.hold_quat = z3.copy(), z4.copy()
        self.limit_s, self.min_time_s = np.zeros(n), np.zeros(n)
        self.elapsed, self.calm, self.ik_bad, self.t_line = (np.zeros(n) for _ in range(4))
        self.yielded = np.zeros(n, bool)
        self.alpha, self.high, self.overload = np.zeros(n), np.zeros(n), np.zeros(n)
        self.period = np.zeros(n, dtype=np.int64)
        self.settled = np.zeros(n, bool)
        # The human's reach (SimulatedHuman) and their arm's gains (HumanArm).
        self.h_plan = np.zeros(n, bool)
        self.h_t = np.zeros(n)
        self.h_noise = np.zeros((n, 6))
        self.h_start, self.h_delta, self.h_rot = z3.copy(), z3.copy(), z3.copy()
        self.h_q0, self.h_q1 = z4.copy(), z4.copy()
        self.h_dur = np.ones(n)
        self.following = np.zeros(n, bool)
        self.reach_kp, self.reach_kv = np.ones((n, 6)), np.ones((n, 6))
        self.follow_kv = np.ones((n, 6))
        self.noise_scale, self.lead = np.zeros((n, 6)), np.zeros((n, 6))
        # The step's totals.
        self.tot = np.zeros((n, 5))  # lin, ang, work, lin_true, ang_true
        self.lowest_z = np.zeros(n)

    # ------------------------------------------------------------------ reset
    def reset_world(self, i: int, start: int, scenario: Scenario | None = None,
                    rng: np.random.Generator | None = None, state: int | None = None) -> int:
        """Place world ``i`` at the start of an episode, as :meth:`PandaSim.reset` does.

        The C template simulates the reset (its IK places the arm) with the same arguments
        and draws; its state, the episode's parameters and the random streams are copied
        into world ``i``.

        Raises:
            IKFailure: The robot cannot reach its pose.
        """
        tpl, w = self.template, self.worlds[i]
        rng = rng if rng is not None else np.random.default_rng(0)
        s0 = tpl.reset(start, scenario, rng, state)
        self.load_world(i, tpl.model, tpl.data)
        w.rng = tpl.human.rng
        w.handle_rng, w.handle_noise_n = tpl.handle.rng, tpl.handle.noise_n
        w.scenario = tpl.scenario
        w.design = tpl.human.design
        w.fault, w.result = None, None
        self.sensors.reset_world(i, tpl.sensor.model)
        self.lowest_z[i] = tpl.lowest_z
        self.seats.set_world(i, tpl.seats, tpl.seats.design.seat_hold)
        arm = tpl.arm
        self.reach_kp[i], self.reach_kv[i] = arm.reach_gains
        self.follow_kv[i] = arm.follow_damping
        self.noise_scale[i], self.lead[i] = arm.noise_scale, arm.lead
        self.following[i] = arm.following
        self.holding[i] = tpl.holding
        self.human_holding[i] = tpl.human.holding
        self.h_plan[i], self.h_t[i], self.h_noise[i] = False, 0.0, 0.0
        self.q_ref[i] = tpl.q_ref
        self.ik.q[i] = tpl.ik.configuration.q
        self.ik.target[i] = tpl.ik.posture.target_q
        self.phase[i] = IDLE
        self.states[i] = s0
        self._set_contacts(np.array([i]), self.holding[i:i + 1], self.human_holding[i:i + 1])
        self._finger_gains(np.array([i]), self.holding[i:i + 1])
        # Kinematics, contacts and sensors of the placed world (as PandaSim.reset's
        # mj_forward) before it is read or stepped: one forward pass for all the worlds
        # placed meanwhile (the others' are recomputed from their unchanged state).
        self._placed.add(i)
        return s0

    def copy_world(self, src: int, rows: np.ndarray) -> None:
        """Make the worlds ``rows`` copies of world ``src`` (its state, its episode's
        parameters and its step's set-up; each copy draws its noise from a generator of its
        own, seeded by its index). For measurements: a reset costs a C IK solve per world.
        """
        rows = np.asarray(rows, dtype=np.int64)
        self.copy_rows(src, rows)
        for name in PER_WORLD:
            value = getattr(self, name)
            value[rows] = value[src]
        self.ik.copy_rows(src, rows)
        self.sensors.copy_rows(src, rows)
        self.seats.copy_rows(src, rows)
        w = self.worlds[src]
        for i in rows:
            copy_ = self.worlds[int(i)] = copy.copy(w)
            copy_.rng, copy_.handle_rng = (np.random.default_rng([int(i), k]) for k in (0, 2))
        self._placed.update(int(i) for i in rows)
        self._refresh()

    # ------------------------------------------------------------------ switches
    def _set_contacts(self, rows: np.ndarray, robot_weld: np.ndarray,
                      human_holds: np.ndarray) -> None:
        """Finger pads off while the robot's weld holds; the thumb on while the human holds
        (the C backend's ``contype`` switches, per world by geom margin).
        """
        margin = self.m.geom_margin.numpy()
        fingers = np.where(robot_weld[:, None], _CONTACT_OFF_MARGIN_M,
                           self._finger_margin[None])
        margin[rows[:, None], self._finger_geoms[None]] = fingers
        margin[rows, self._arm.thumb_pad] = np.where(human_holds, self._thumb_margin,
                                                     _CONTACT_OFF_MARGIN_M)
        self._model_put("geom_margin", margin)

    def _finger_gains(self, rows: np.ndarray, on: np.ndarray) -> None:
        acts = self.scene.finger_actuators
        kp = self._finger_kp[None] * np.where(on, FINGER_HOLD_STIFFENING, 1.0)[:, None]
        gain, bias = self.m.actuator_gainprm.numpy(), self.m.actuator_biasprm.numpy()
        gain[rows[:, None], acts[None], 0] = kp
        bias[rows[:, None], acts[None], 1] = -kp
        self._model_put("actuator_gainprm", gain)
        self._model_put("actuator_biasprm", bias)

    def _weld(self, i: int, on: bool) -> None:
        """The robot's grasp weld of world ``i`` (PandaSim._weld; its relative pose is the
        model's, set once by the template).
        """
        eq = self._get("eq_active")
        eq[i, self.scene.weld] = on
        self._put("eq_active", eq)
        ctrl = self._get("ctrl")
        ctrl[i, self.scene.finger_actuators] = FINGER_ON_GRIP_M if on else FINGER_OPEN_M
        self._put("ctrl", ctrl)
        rows = np.array([i])
        self._finger_gains(rows, np.array([on]))
        self.holding[i] = on
        self._set_contacts(rows, self.holding[rows], self.human_holding[rows])

    def _human_hold(self, i: int, on: bool) -> None:
        """The human grasps or lets go in world ``i`` (HumanArm.hold)."""
        eq = self._get("eq_active")
        eq[i, self._arm.weld] = on
        self._put("eq_active", eq)
        ctrl = self._get("ctrl")
        ctrl[i, self._arm.thumb] = self._arm.thumb_ctrl(on)
        self._put("ctrl", ctrl)
        self.human_holding[i] = on
        rows = np.array([i])
        self._set_contacts(rows, self.holding[rows], self.human_holding[rows])

    def _arm_gains(self, rows: np.ndarray, following: np.ndarray) -> None:
        """HumanArm._set_gains per world: following (damping only) or reaching gains."""
        acts = self._arm.actuators
        kp = np.where(following[:, None], 0.0, self.reach_kp[rows])
        kv = np.where(following[:, None], self.follow_kv[rows], self.reach_kv[rows])
        gain, bias = self.m.actuator_gainprm.numpy(), self.m.actuator_biasprm.numpy()
        gain[rows[:, None], acts[None], 0] = kp
        bias[rows[:, None], acts[None], 1] = -kp
        bias[rows[:, None], acts[None], 2] = -kv
        self._model_put("actuator_gainprm", gain)
        self._model_put("actuator_biasprm", bias)
        self.following[rows] = following

    # ------------------------------------------------------------------ poses (one world)
    def _site_pose(self, i: int, site: int) -> Pose:
        self._refresh()
        pos = self._get("site_xpos")[i, site].astype(float)
        quat = bm.mat_to_quat(self._get("site_xmat")[i, site].astype(float)[None])[0]
        return Pose(pos, quat)

    def grip_pose(self, i: int) -> Pose:
        """The hand's grip frame in world ``i``."""
        return self._site_pose(i, self.scene.grip_site)

    def object_pose(self, i: int) -> Pose:
        """The object's pose in world ``i``."""
        self._refresh()
        b = self.scene.object_body
        return Pose(self._get("xpos")[i, b].astype(float),
                    self._get("xquat")[i, b].astype(float))

    def _rng(self, i: int) -> np.random.Generator:
        """World ``i``'s generator of the human's noise."""
        rng = self.worlds[int(i)].rng
        if rng is None:
            raise RuntimeError(f"world {i} was never reset")
        return rng
