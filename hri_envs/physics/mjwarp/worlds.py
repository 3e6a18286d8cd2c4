"""N worlds of the Panda scene stepped together on MuJoCo Warp: :class:`WarpWorlds`.

Each world runs the C backend's abstract step (:meth:`hri_envs.physics.sim.PandaSim.step`):
the robot's grasp toggle (approach, close, check the fingers, weld; or unweld and retreat),
the human's toggle, then the motion until the object settles or a time limit, the faults, the
observed state and the inferred human action. The worlds advance in lockstep, one control
period (``control_every_steps`` physics steps) at a time:

* *per control period, vectorised over the worlds* (numpy on the arrays of MuJoCo Warp's
  ``Data``): the human's reference and noise and their arm's actuator targets, the arm's
  wrench, the wrist sensor's reading and its compensation, bias, noise and delay, the
  grip's overload, the seat law, disagreement-aware variable impedance, the robot's
  straight line, the impedance controller (site Jacobians from the joint axes, ``M⁻¹`` by
  MuJoCo Warp's ``solve_m``, the 6 × 6 operational-space inverse by batched Cholesky), the
  impulses, the stability, floor and settle tests; the IK reference is one batched
  mink-warp step of every world due for an update;
* *per world, at the few events of a step* (its start, the end of each phase, its end):
  plain Python, as in the C backend;
* *physics*: ``mujoco_warp.step1``/``step2``/``step`` for all worlds at once. A world whose
  step has ended waits for the others frozen: its integration state (qpos, qvel, act,
  warm start, time) is put back after each period.

Per-world model values (the object's true mass, the human's strength and gains, the finger
servos' stiffness while welded) live in MuJoCo Warp's per-world model arrays. The grasps are
per world: the welds are equality constraints whose ``eq_active`` lives in ``Data``, and the
contacts that the C backend switches off by ``contype`` (the finger pads while the weld
holds, the open thumb) are switched off per world by a geom margin of -1 m (MuJoCo Warp fixes
the colliding pairs per model from ``contype``/``conaffinity``; a contact with a margin of -1 m
is never detected). Resets are made by a C :class:`~hri_envs.physics.sim.PandaSim` (its mink
IK places the arm) and copied into the world.

Differences from the C backend, all within the tolerances of ``tests/test_mjwarp.py``:
MuJoCo Warp computes in float32 (the C backend in float64); MuJoCo's ``BADQACC``/``BADQVEL``
warnings are not kept per world (the ``unstable`` fault comes from non-finite or too fast
velocities only); mink-warp's IK is an ADMM box-constrained QP (:data:`IK_ADMM_ITERATIONS`),
mink's is daqp; a fault found before a control period's physics (``pulled_out``,
``ik_failure``) ends the world's step after that period's physics, 8 ms later than the C
backend; a frozen world's kinematics are those of its current state (C: of the state one
physics step before).
"""

from __future__ import annotations

import copy
import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from hri_envs.physics.design import PhysicsDesign
from hri_envs.physics.human_arm import HAND_CONTACT_BIT
from hri_envs.physics.kinematics import Pose, StraightLine, compose
from hri_envs.physics.mjwarp import batchmath as bm
from hri_envs.physics.mjwarp.device import require_warp
from hri_envs.physics.observer import infer_human_action
from hri_envs.physics.sim import PandaSim, StepResult
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import BOTH, HUMAN_BIT, ROBOT_BIT, TOGGLE, WAIT, TaskGraph

__all__ = ["WarpWorlds"]

# Phases of a world's abstract step.
_IDLE, _APPROACH, _CLOSE, _RETREAT, _MAIN = 0, 1, 2, 3, 4
_FINGER_OPEN_M = 0.04  # as in sim.py
_FINGER_ON_GRIP_M = 0.0219
_FINGER_HOLD_STIFFENING = 10.0
_CONTACT_OFF_MARGIN_M = -1.0  # a geom margin that no contact reaches
_LAMBDA_INV_REGULARIZATION = 1e-6  # as in controller.py
#: ADMM iterations of mink-warp's box-constrained IK step. The IK reference steers the arm's
#: null space, so an unconverged QP lets a redundant arm drift away from the C backend's
#: (mink's daqp solves the QP exactly): on the wheel's human-led move down from A′ (10
#: joints) the object ended 18 mm from the C backend's with mink-warp's default 30
#: iterations, 1.6 mm with 100, 26 µm with 300 and 1.6 µm with 1000; the C IK itself in
#: place of mink-warp gave 0.3 µm.
IK_ADMM_ITERATIONS = 300
#: Contacts allocated per world, and constraint rows (both far above what the scene uses).
NCONMAX, NJMAX = 48, 300


#: The per-world arrays of :class:`WarpWorlds` (first axis: the worlds).
_PER_WORLD: tuple[str, ...] = (
    "phase", "holding", "human_holding", "q_ref", "states", "has_line", "has_hold", "l_start",
    "l_delta", "l_rot", "l_q0", "l_q1", "l_dur", "l_dir", "l_axis", "hold_pos", "hold_quat",
    "limit_s", "min_time_s", "elapsed", "calm", "ik_bad", "t_line", "yielded", "alpha", "high",
    "overload", "period", "settled", "h_plan", "h_t", "h_noise", "h_start", "h_delta", "h_rot",
    "h_q0", "h_q1", "h_dur", "following", "reach_kp", "reach_kv", "follow_kv", "noise_scale",
    "lead", "sensor_noise", "sensor_bias", "true_wrench", "seat_pos", "seat_exit", "seat_quat",
    "seat_hold", "tot", "lowest_z", "sensordata")


@dataclass
class _World:
    """What one world keeps between control periods, apart from the arrays."""

    rng: np.random.Generator | None = None  # the human's noise (the episode's generator)
    sensor_rng: np.random.Generator | None = None
    handle_rng: np.random.Generator | None = None
    handle_noise_n: float = 0.0
    delay_steps: int = 0
    queue: deque[np.ndarray] = field(default_factory=deque)
    scenario: Scenario | None = None
    seats_pos: np.ndarray | None = None  # (K, 3)
    lowest_z: float = 0.0
    design: PhysicsDesign | None = None  # the episode's true design
    # The step in progress.
    s: int = 0
    a_r: int = WAIT
    a_h: int = WAIT
    t0: float = 0.0
    fault: str | None = None
    settled: bool = False
    yielded: bool = False
    human_moves: bool = False
    robot_moves: bool = False
    result: StepResult | None = None


class WarpWorlds:
    """``n_worlds`` worlds of one scenario's Panda scene on MuJoCo Warp.

    Args:
        graph: The task graph.
        n_worlds: How many worlds are stepped together.
        design: Physical design (default: the scenario's).
        options: Validated ``physics`` options (as for :class:`~hri_envs.physics.sim.PandaSim`).
        device: Warp device (default: Warp's default device, a GPU where there is one).
        ik_rate: Rate [Hz] of the IK reference updates.

    Attributes:
        template: The C simulation that resets worlds (its IK places the arm) and renders.
        device: The Warp device the worlds run on ("cpu", "cuda:0", ...).
        on_period: Called after every control period with the (N,) mask of the worlds that
            ran it (for videos; None: nothing).
    """

    def __init__(self, graph: TaskGraph, n_worlds: int, design: PhysicsDesign | None = None,
                 options: Mapping[str, Any] | None = None, device: str | None = None,
                 ik_rate: float = 25.0) -> None:
        wp, mjw, mink_warp = require_warp()
        self._wp, self._mjw = wp, mjw
        self.graph = graph
        self.n = n = int(n_worlds)
        tpl = self.template = PandaSim(graph, design, ik_rate=ik_rate, options=options)
        self.design = tpl.design
        self.device = str(wp.get_device(device))
        sc = self.scene = tpl.scene
        # The grasp weld's relative pose is written into the model on the first grasp: do
        # it once before the model is copied to Warp (it is the same for every grasp).
        tpl._weld(True)
        tpl._weld(False)
        mjm = copy.copy(tpl.model)
        # Every switchable contact on in the Warp model (MuJoCo Warp fixes the colliding
        # pairs from these bits); per world they are switched by geom margin.
        mjm.geom_contype[sc.finger_geoms.ravel()] = tpl._finger_contype
        mjm.geom_contype[tpl.arm.thumb_pad] = HAND_CONTACT_BIT
        # MuJoCo Warp has no switch for mid-phase culling (the C backend turns it off).
        mjm.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_MIDPHASE)
        self._mjm = mjm
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(mjm)
            self.d = mjw.make_data(mjm, nworld=n, nconmax=NCONMAX, njmax=NJMAX)
            for name in ("geom_margin", "actuator_gainprm", "actuator_biasprm",
                         "actuator_forcerange", "body_mass", "body_inertia"):
                arr = getattr(self.m, name)
                tiled = np.repeat(arr.numpy()[:1], n, axis=0)
                setattr(self.m, name, wp.array(tiled, dtype=arr.dtype))
            self._rhs = wp.zeros((n, mjm.nv), dtype=float)
            self._sol = wp.zeros((n, mjm.nv), dtype=float)
        self.nv = mjm.nv
        self.dt = tpl.dt
        self.k = tpl.control_every
        self.dt_control = tpl.dt_control
        self.ik_every = tpl.ik_every
        self.n_robot = n_r = len(sc.robot_dofs)
        self.n_base = tpl.n_base
        self.n_tree = n_r + 2  # the robot's tree: base, arm and the two fingers
        # Joint axes of the robot's joints (base slides, then the arm's hinges).
        jnt = [int(np.flatnonzero(mjm.jnt_dofadr == d)[0]) for d in sc.robot_dofs]
        self._jnt = np.array(jnt)
        self._hinge = mjm.jnt_type[self._jnt] == mujoco.mjtJoint.mjJNT_HINGE
        self._acts = sc.robot_actuators
        self._arm = tpl.arm
        self._finger_geoms = sc.finger_geoms.ravel()
        self._finger_margin = mjm.geom_margin[self._finger_geoms].copy()
        self._thumb_margin = float(mjm.geom_margin[self._arm.thumb_pad])
        self._finger_kp = mjm.actuator_gainprm[sc.finger_actuators, 0].copy()
        self._adr_force = int(mjm.sensor_adr[sc.force_sensor])
        self._adr_torque = int(mjm.sensor_adr[sc.torque_sensor])
        self._adr_touch = tpl.handle.adr
        self._hand_weight = tpl.sensor.hand_weight
        self._object_weight = tpl.sensor.object_weight
        self._object_com = np.asarray(self.design.object_com, float)
        self._weight = tpl.controller.weight
        self._kn, self._dn = tpl.controller.kn, tpl.controller.dn
        self._tau_hi = np.asarray(sc.torque_limit, float)
        self._rest_t = self._arm._rest_t
        self._handle = self._arm.handle
        self._arm_lo, self._arm_hi = self._arm._lo, self._arm._hi
        # The IK reference: mink-warp on the robot-only model, one problem per world.
        self._ik_model = tpl.ik.model
        with wp.ScopedDevice(self.device):
            self.ik_config = mink_warp.Configuration(self._ik_model, nworld=n,
                                                     device=self.device)
            self.ik_frame = mink_warp.FrameTask("grip", "site", position_cost=1.0,
                                                orientation_cost=0.5, lm_damping=1e-3)
            cost = np.full(self._ik_model.nv, 1e-2)
            cost[:self.n_base] = 1e-4
            self.ik_posture = mink_warp.PostureTask(self._ik_model, cost=cost)
            self.ik_solver = mink_warp.ConstrainedSolver(
                self.ik_config, [mink_warp.ConfigurationLimit(self._ik_model, gain=0.9)],
                damping=1e-4, admm_iters=IK_ADMM_ITERATIONS)
        self._ik_q = np.repeat(tpl.ik.home[None], n, axis=0)  # (N, nq_ik)
        self._ik_target = self._ik_q.copy()  # the posture targets
        self._ik_pose = np.zeros((n, 7))
        self._ik_pose[:, 0] = 1.0
        self.worlds = [_World() for _ in range(n)]
        self.on_period: Callable[[np.ndarray], None] | None = None
        self._placed: set[int] = set()
        self._alloc()

    # ------------------------------------------------------------------ state
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
        # The sensor model, the seats and the step's totals.
        self.sensor_noise = np.zeros(n)
        self.sensor_bias = np.zeros((n, 6))
        self.true_wrench = np.zeros((n, 6))
        self.seat_pos = np.zeros((n, len(self.template.seats.pos), 3))
        self.seat_exit = np.zeros_like(self.seat_pos)
        self.seat_quat = np.repeat(self.template.seats.quat[None], n, axis=0)
        self.seat_hold = np.zeros(n)
        self.tot = np.zeros((n, 5))  # lin, ang, work, lin_true, ang_true
        self.lowest_z = np.zeros(n)
        self.sensordata = np.zeros((n, self._mjm.nsensordata))

    # ------------------------------------------------------------------ host access
    def _get(self, name: str) -> np.ndarray:
        """A Data array on the host (a view on the CPU device; write back with _put)."""
        return getattr(self.d, name).numpy()

    def _put(self, name: str, value: np.ndarray) -> None:
        arr = getattr(self.d, name)
        if self.device != "cpu" or value.ctypes.data != arr.ptr:
            arr.assign(value.astype(arr.numpy().dtype, copy=False))

    def _model_put(self, name: str, value: np.ndarray) -> None:
        arr = getattr(self.m, name)
        if self.device != "cpu" or value.ctypes.data != arr.ptr:
            arr.assign(value.astype(arr.numpy().dtype, copy=False))

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
        src = tpl.data
        for name in ("qpos", "qvel", "ctrl", "act", "mocap_pos", "mocap_quat"):
            arr = self._get(name)
            arr[i] = getattr(src, name)
            self._put(name, arr)
        eq = self._get("eq_active")
        eq[i] = src.eq_active
        self._put("eq_active", eq)
        for name in ("qacc_warmstart", "xfrc_applied", "qacc"):
            arr = self._get(name)
            arr[i] = 0.0
            self._put(name, arr)
        t = self._get("time")
        t[i] = 0.0
        self._put("time", t)
        mjm = tpl.model
        for name in ("actuator_gainprm", "actuator_biasprm", "actuator_forcerange",
                     "body_mass", "body_inertia"):
            arr = getattr(self.m, name).numpy()
            arr[i] = getattr(mjm, name)
            self._model_put(name, arr)
        w.rng, w.sensor_rng = tpl.human.rng, tpl.sensor.model._rng
        w.handle_rng, w.handle_noise_n = tpl.handle._rng, tpl.handle.noise_n
        w.delay_steps = tpl.sensor.model.delay_steps
        w.queue = deque()
        w.scenario = tpl.scenario
        w.design = tpl.human.design
        w.fault, w.result = None, None
        self.lowest_z[i] = tpl._lowest_z
        self.seat_pos[i] = tpl.seats.pos
        self.seat_exit[i] = tpl.seats.exit
        self.seat_hold[i] = tpl.seats.design.seat_hold
        self.sensor_noise[i] = tpl.sensor.model.noise_n
        self.sensor_bias[i] = tpl.sensor.model.bias
        self.true_wrench[i] = 0.0
        arm = tpl.arm
        self.reach_kp[i], self.reach_kv[i] = arm._reach_gains
        self.follow_kv[i] = arm._follow_damping
        self.noise_scale[i], self.lead[i] = arm._noise_scale, arm._lead
        self.following[i] = arm.following
        self.holding[i] = tpl.holding
        self.human_holding[i] = tpl.human.holding
        self.h_plan[i], self.h_t[i], self.h_noise[i] = False, 0.0, 0.0
        self.q_ref[i] = tpl.q_ref
        self._ik_q[i] = tpl.ik.configuration.q
        self._ik_target[i] = tpl.ik.posture.target_q
        self.phase[i] = _IDLE
        self.states[i] = s0
        self._set_contacts(np.array([i]), self.holding[i:i + 1], self.human_holding[i:i + 1])
        self._finger_gains(np.array([i]), self.holding[i:i + 1])
        # Kinematics, contacts and sensors of the placed world (as PandaSim.reset's
        # mj_forward) before it is read or stepped: one forward pass for all the worlds
        # placed meanwhile (the others' are recomputed from their unchanged state).
        self._placed.add(i)
        return s0

    def _refresh(self) -> None:
        """Forward pass for the worlds placed since the last one (see :meth:`reset_world`)."""
        if self._placed:
            self._mjw.forward(self.m, self.d)
            rows = np.fromiter(self._placed, dtype=np.int64)
            self.sensordata[rows] = self._get("sensordata")[rows]
            self._placed.clear()

    def copy_world(self, src: int, rows: np.ndarray) -> None:
        """Make the worlds ``rows`` copies of world ``src`` (its state, its episode's
        parameters and its step's set-up; each copy draws its noise from a generator of its
        own, seeded by its index). For measurements: a reset costs a C IK solve per world.
        """
        rows = np.asarray(rows, dtype=np.int64)
        for name in ("qpos", "qvel", "ctrl", "act", "mocap_pos", "mocap_quat", "eq_active",
                     "qacc_warmstart", "xfrc_applied", "time"):
            arr = self._get(name)
            arr[rows] = arr[src]
            self._put(name, arr)
        for name in ("geom_margin", "actuator_gainprm", "actuator_biasprm",
                     "actuator_forcerange", "body_mass", "body_inertia"):
            arr = getattr(self.m, name).numpy()
            arr[rows] = arr[src]
            self._model_put(name, arr)
        for name in _PER_WORLD:
            value = getattr(self, name)
            value[rows] = value[src]
        for value in (self._ik_q, self._ik_target, self._ik_pose):
            value[rows] = value[src]
        w = self.worlds[src]
        for i in rows:
            copy_ = self.worlds[int(i)] = copy.copy(w)
            copy_.queue = deque(w.queue)
            copy_.rng, copy_.sensor_rng, copy_.handle_rng = (
                np.random.default_rng([int(i), k]) for k in range(3))
        self._placed.update(int(i) for i in rows)
        self._refresh()

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
        kp = self._finger_kp[None] * np.where(on, _FINGER_HOLD_STIFFENING, 1.0)[:, None]
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
        ctrl[i, self.scene.finger_actuators] = _FINGER_ON_GRIP_M if on else _FINGER_OPEN_M
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

    # ------------------------------------------------------------------ phases
    def _begin_run(self, i: int, line: StraightLine | None, hold: Pose | None,
                   limit_s: float, min_time_s: float | None = None) -> None:
        """Start world ``i``'s next run (PandaSim._run's set-up)."""
        self.has_line[i] = line is not None
        if line is not None:
            self.l_start[i], self.l_delta[i], self.l_rot[i] = (line.start.pos, line.delta,
                                                               line.rotvec)
            self.l_q0[i], self.l_q1[i] = line.start.quat, line.goal.quat
            self.l_dur[i], self.l_dir[i], self.l_axis[i] = (line.duration, line.direction,
                                                            line.axis)
        self.has_hold[i] = hold is not None
        if hold is not None:
            self.hold_pos[i], self.hold_quat[i] = hold.pos, hold.quat
        self.limit_s[i] = limit_s
        self.min_time_s[i] = self.design.settle_min_time_s if min_time_s is None else min_time_s
        self.elapsed[i] = self.calm[i] = self.ik_bad[i] = self.t_line[i] = 0.0
        self.alpha[i] = self.high[i] = self.overload[i] = 0.0
        self.yielded[i] = False
        self.period[i] = 0
        xfrc = self._get("xfrc_applied")
        xfrc[i, self.scene.object_body] = 0.0
        self._put("xfrc_applied", xfrc)

    def _pregrasp(self, grip: Pose) -> Pose:
        return compose(grip, np.array([0.0, 0.0, -self.design.pregrasp_distance_m]),
                       np.array([1.0, 0, 0, 0]))

    def begin_step(self, i: int, s: int, a_r: int, a_h: int) -> None:
        """World ``i`` starts the abstract step (PandaSim.step up to its first run)."""
        g, w, design = self.graph, self.worlds[i], self.design
        w.s, w.a_r, w.a_h = s, a_r, a_h
        w.t0 = float(self._get("time")[i])
        w.fault, w.result, w.settled, w.yielded = None, None, False, False
        self.tot[i] = 0.0
        toggle_ok = bool(g.valid[s, TOGGLE])
        attempt = self.template.settings.attempt_invalid
        if a_r == TOGGLE and (toggle_ok or attempt):
            if not self.holding[i]:
                grip = self._site_pose(i, self.scene.object_grip_site)
                line = StraightLine(self.grip_pose(i), grip, design.linear_speed,
                                    design.angular_speed,
                                    min_duration=design.grasp_approach_min_duration_s)
                self._begin_run(i, line, None, design.grasp_approach_time_limit_s)
                self.phase[i] = _APPROACH
            else:
                self._weld(i, False)
                grip = self.grip_pose(i)
                line = StraightLine(grip, self._pregrasp(grip), design.linear_speed,
                                    design.angular_speed, design.motion_min_duration_s)
                self._begin_run(i, line, None, design.release_retreat_time_limit_s)
                self.phase[i] = _RETREAT
            return
        self._start_main(i)

    def _start_main(self, i: int) -> None:
        """The human's toggle and the step's motion (PandaSim.step after the robot's toggle)."""
        g, w, design, tpl = self.graph, self.worlds[i], self.design, self.template
        s, a_r, a_h = w.s, w.a_r, w.a_h
        toggle_ok = bool(g.valid[s, TOGGLE])
        human_toggle = a_h == TOGGLE and toggle_ok
        if human_toggle:
            self.human_holding[i] = bool(g.grasp[int(g.next_state[s, WAIT, TOGGLE])]
                                         & HUMAN_BIT)
        self._human_hold(i, bool(self.human_holding[i]))
        s1 = int(g.next_state[s, a_r if a_r == TOGGLE and toggle_ok else WAIT,
                              a_h if human_toggle else WAIT])
        if tpl.settings.attempt_invalid:
            robot_moves = a_r > TOGGLE
            human_moves = a_h > TOGGLE and bool(g.valid[s1, a_h])
        else:
            aborted = not (g.valid[s1, a_r] and g.valid[s1, a_h])
            robot_moves = a_r > TOGGLE and not aborted
            human_moves = a_h > TOGGLE and not aborted
        line = None
        observer = self._observer(i)
        if robot_moves:
            pos, quat = observer.pose(tpl._motion_target(s1, a_r))
            goal = compose(Pose(pos, quat), *tpl.grip_in_object)
            line = StraightLine(self.grip_pose(i), goal, design.linear_speed,
                                design.angular_speed, design.motion_min_duration_s)
        self.h_plan[i] = human_moves
        if human_moves:
            pos, quat = observer.pose(int(g.next_state[s1, WAIT, a_h]))
            true = w.design if w.design is not None else design
            speed = (true.human_speed_factor * true.linear_speed,
                     true.human_speed_factor * true.angular_speed)
            plan = StraightLine(self.object_pose(i), Pose(pos, quat), *speed,
                                min_duration=true.motion_min_duration_s)
            self.h_start[i], self.h_delta[i], self.h_rot[i] = (plan.start.pos, plan.delta,
                                                               plan.rotvec)
            self.h_q0[i], self.h_q1[i], self.h_dur[i] = (plan.start.quat, plan.goal.quat,
                                                         plan.duration)
            self.h_t[i] = -true.human_delay_s
        hold = None if (self.holding[i] or robot_moves) else self.grip_pose(i)
        self._begin_run(i, line, hold, design.step_time_limit)
        self.phase[i] = _MAIN

    def _observer(self, i: int) -> Any:
        obs = self.template.observer
        scenario = self.worlds[i].scenario
        if scenario is not None and obs.scenario is not scenario:
            obs.set_scenario(scenario)
        return obs

    def _end_phase(self, i: int, fault: str | None) -> None:
        """World ``i``'s run ended (settled, at its limit, or with ``fault``): go on."""
        w, phase = self.worlds[i], int(self.phase[i])
        if fault is not None:
            w.fault = fault
            self._finish(i)
            return
        if phase == _APPROACH:
            ctrl = self._get("ctrl")
            ctrl[i, self.scene.finger_actuators] = self.design.grip_finger_pos_m
            self._put("ctrl", ctrl)
            self._begin_run(i, None, self.grip_pose(i), self.design.grasp_close_time_s,
                            min_time_s=self.design.grasp_close_time_s)
            self.phase[i] = _CLOSE
        elif phase == _CLOSE:
            fault = self._check_grasp(i)
            if fault is not None:
                w.fault = fault
                self._finish(i)
            else:
                self._weld(i, True)
                self._start_main(i)
        elif phase == _RETREAT:
            self._start_main(i)
        else:
            w.settled, w.yielded = bool(self.settled[i]), bool(self.yielded[i])
            self._finish(i)

    def _check_grasp(self, i: int) -> str | None:
        """PandaSim._close_on_grip's test of the closed fingers in world ``i``."""
        design, sc = self.design, self.scene
        forces = self._finger_forces(i)
        if forces.min() < design.grasp_contact_force_n:
            self._open_fingers(i)
            return (f"grasp_failed: the fingers press on the grip with {forces[0]:.1f} N "
                    f"and {forces[1]:.1f} N (a hold needs {design.grasp_contact_force_n:g} N "
                    "each)")
        grip = self.grip_pose(i)
        block_pos = self._get("geom_xpos")[i, sc.grip_geom].astype(float)
        block_quat = bm.mat_to_quat(self._get("geom_xmat")[i, sc.grip_geom].astype(float)[None])
        miss_m = float(np.linalg.norm(grip.pos - block_pos))
        miss_rad = float(np.linalg.norm(bm.rotation_error(block_quat, grip.quat[None])[0]))
        if miss_m > design.grasp_tolerance_m or miss_rad > design.grasp_tolerance_rad:
            self._open_fingers(i)
            return (f"grasp_failed: the hand closed {miss_m * 100:.1f} cm, "
                    f"{np.rad2deg(miss_rad):.0f}° from the grip (a hold needs "
                    f"{design.grasp_tolerance_m * 100:g} cm, "
                    f"{np.rad2deg(design.grasp_tolerance_rad):.0f}°)")
        return None

    def _open_fingers(self, i: int) -> None:
        ctrl = self._get("ctrl")
        ctrl[i, self.scene.finger_actuators] = _FINGER_OPEN_M
        self._put("ctrl", ctrl)

    def _finger_forces(self, i: int) -> np.ndarray:
        """(2,) normal force [N] of each finger's pads on the grip geometry in world ``i``."""
        wp, mjw = self._wp, self._mjw
        nacon = int(self.d.nacon.numpy()[0])
        out = np.zeros(2)
        if nacon == 0:
            return out
        nacon = min(nacon, self.d.contact.worldid.shape[0])
        with wp.ScopedDevice(self.device):
            ids = wp.array(np.arange(nacon, dtype=np.int32), dtype=int)
            force = wp.zeros(nacon, dtype=wp.spatial_vector)
            mjw.contact_force(self.m, self.d, ids, False, force)
        f = force.numpy()
        world = self.d.contact.worldid.numpy()[:nacon]
        geom = self.d.contact.geom.numpy()[:nacon]
        grip, fingers = self.scene.grip_geom, self.scene.finger_geoms
        for c in np.flatnonzero((world == i) & (geom == grip).any(axis=1)):
            other = geom[c, 0] if geom[c, 1] == grip else geom[c, 1]
            for side in range(2):
                if other in fingers[side]:
                    out[side] += abs(float(f[c, 0]))
        return out

    def _finish(self, i: int) -> None:
        """World ``i``'s step ends: observe, infer, report (the end of PandaSim.step)."""
        g, w, design = self.graph, self.worlds[i], self.design
        self.h_plan[i] = False
        self.phase[i] = _IDLE
        fault = w.fault
        pose = self.object_pose(i)
        grasp = (ROBOT_BIT if self.holding[i] else 0) | (HUMAN_BIT if self.human_holding[i]
                                                         else 0)
        reading = float(self.sensordata[i, self._adr_touch])
        noise = (w.handle_noise_n * w.handle_rng.standard_normal()
                 if w.handle_noise_n > 0.0 and w.handle_rng is not None else 0.0)
        human_seen = max(0.0, reading + noise) > self.template.handle.threshold_n
        seat = self._engaged_one(i, pose.pos, pose.quat)
        obs = self._observer(i).observe(pose.pos, pose.quat, seat,
                                        (grasp & ROBOT_BIT) | (HUMAN_BIT if human_seen else 0))
        far = (obs.position_error > design.timeout_fault_factor * design.position_tolerance
               or obs.angle_error > design.timeout_fault_factor * design.angle_tolerance)
        if fault is None and seat < 0 and not grasp:
            fault = "dropped: nobody holds the object and no support carries it"
        if fault is None and seat < 0 and grasp not in (0, BOTH):
            fault = ("off_support: only the " + ("robot" if grasp == ROBOT_BIT else "human")
                     + " holds the object away from every support")
        if fault is None and far:
            fault = ("off_support: the object " + ("settled" if w.settled else "stopped")
                     + " far from every abstract state")
        if not np.all(np.isfinite(self._get("qpos")[i])):
            fault = "unstable: the simulation diverged (NaN)"
        s, a_r = w.s, w.a_r
        graph_next = int(g.next_state[s, a_r, w.a_h])
        lin, ang, work, lin_t, ang_t = self.tot[i].tolist()
        a_h_seen = infer_human_action(g, s, a_r, obs.state, work, design.human_work_min_j)
        self.states[i] = obs.state
        w.result = StepResult(obs.state, a_h_seen, graph_next, obs.state == graph_next,
                              w.settled, float(self._get("time")[i]) - w.t0, lin, ang,
                              w.yielded, obs.position_error, obs.angle_error, fault, lin_t,
                              ang_t, bool(self.human_holding[i]), human_seen)

    def _engaged_one(self, i: int, pos: np.ndarray, quat: np.ndarray) -> int:
        return int(self._engaged(np.array([i]), pos[None], quat[None])[0])

    def _engaged(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(R,) the support whose seat holds the object in each world of ``rows``, or -1."""
        design = self.design
        cap, max_angle = design.seat_capture_m, design.seat_capture_angle_rad
        e = self.seat_pos[rows] - pos[:, None]  # (R, K, 3)
        along = -np.einsum("rkj,rkj->rk", e, self.seat_exit[rows])
        across2 = np.einsum("rkj,rkj->rk", e, e) - along * along
        inside = (np.abs(along) < cap) & (across2 < cap * cap)
        n_k = e.shape[1]
        out = np.full(len(rows), -1)
        for k in range(n_k - 1, -1, -1):  # the first seat that holds wins
            hit = inside[:, k]
            if hit.any():
                r = bm.rotation_error(self.seat_quat[rows[hit], k], quat[hit])
                ok = np.linalg.norm(r, axis=1) < max_angle
                idx = np.flatnonzero(hit)[ok]
                out[idx] = k
        return out

    # ------------------------------------------------------------------ stepping
    def step(self, states: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
             active: np.ndarray) -> list[StepResult | None]:
        """One abstract step of every ``active`` world (the others stay frozen).

        Args:
            states: (N,) the abstract state each world observed before the step.
            a_r: (N,) the robot's abstract action per world.
            a_h: (N,) the human's true abstract action per world.
            active: (N,) bool, the worlds that step.

        Returns:
            Per world its :class:`~hri_envs.physics.sim.StepResult`, None where inactive.
        """
        self._refresh()
        rows = np.flatnonzero(active)
        for i in rows:
            w = self.worlds[i]
            if w.fault is not None and w.result is None:  # a reset that failed
                continue
            self.begin_step(int(i), int(states[i]), int(a_r[i]), int(a_h[i]))
        while (self.phase != _IDLE).any():
            self.run_period()
        out: list[StepResult | None] = [None] * self.n
        for i in rows:
            out[i] = self.worlds[i].result
        return out

    def run_period(self) -> None:
        """One control period of every world that is in a run (PandaSim._run's loop body)."""
        mjw, design, sc = self._mjw, self.design, self.scene
        run = self.phase != _IDLE
        rows = np.flatnonzero(run)
        frozen = ~run
        saved = None
        if frozen.any():
            saved = {name: self._get(name)[frozen].copy()
                     for name in ("qpos", "qvel", "act", "qacc_warmstart", "time")}
        mjw.step1(self.m, self.d)
        dt_c, body = self.dt_control, sc.object_body
        qpos, qvel = self._get("qpos"), self._get("qvel")
        xpos, xquat, xmat = self._get("xpos"), self._get("xquat"), self._get("xmat")
        pos = xpos[rows, body].astype(float)
        quat = xquat[rows, body].astype(float)
        rot = xmat[rows, body].astype(float)
        dof0 = int(sc.object_dofs[0])
        qv = qvel[rows, dof0:dof0 + 6].astype(float)
        vel = qv[:, :3]
        angvel = bm.rotate(quat, qv[:, 3:])
        ctrl = self._get("ctrl")
        # --- the human (SimulatedHuman.advance, HumanArm.drive and wrench)
        holding_h = self.human_holding[rows]
        plan = self.h_plan[rows]
        reacting = holding_h & plan & (self.h_t[rows] < 0.0)
        reaching = holding_h & plan & ~reacting
        h_rows = rows[reaching]
        ref_h = None
        if h_rows.size:
            ref_h = bm.line_sample(self.h_t[h_rows], self.h_dur[h_rows], self.h_start[h_rows],
                                   self.h_delta[h_rows], self.h_q0[h_rows], self.h_q1[h_rows],
                                   self.h_rot[h_rows])
            self.h_t[h_rows] += dt_c
            tau_n = design.human_noise_time_s
            a = min(dt_c / tau_n, 1.0)
            kz = math.sqrt(2.0 * a)
            z = np.stack([self._rng(i).standard_normal(6) for i in h_rows])
            self.h_noise[h_rows] = self.h_noise[h_rows] + (-self.h_noise[h_rows] * a + kz * z)
        self.h_t[rows[reacting]] += dt_c
        following = holding_h & ~reaching
        changed = following != self.following[rows]
        if changed.any():
            self._arm_gains(rows[changed], following[changed])
        tracking = ~holding_h  # the open hand tracks the handle
        if tracking.any():
            ctrl[rows[tracking][:, None], self._arm.actuators[None]] = self._arm_targets(
                pos[tracking], quat[tracking])
        if h_rows.size and ref_h is not None:
            p_h, q_h, v_h, w_h = ref_h
            target = self._arm_targets(p_h, q_h)
            lever = np.einsum("nij,j->ni", bm.quat_to_mat(q_h), self._handle)
            xaxis = self._get("xaxis")
            wrist = xaxis[h_rows][:, self._arm.joints[3:]].astype(float)  # (R, 3, 3)
            rates = np.concatenate([v_h + np.cross(w_h, lever),
                                    np.einsum("rij,rj->ri", wrist, w_h)], axis=1)
            target += self.lead[h_rows] * rates + self.noise_scale[h_rows] * self.h_noise[h_rows]
            ctrl[h_rows[:, None], self._arm.actuators[None]] = target
        welded_h = self._get("eq_active")[rows, self._arm.weld].astype(bool)
        f_act = self._get("actuator_force")[rows][:, self._arm.actuators].astype(float)
        axes = self._get("xaxis")[rows][:, self._arm.joints[3:]].astype(float)
        hand = xpos[rows, self._arm.hand_body].astype(float)
        force_h = f_act[:, :3]
        torque_h = np.einsum("rj,rji->ri", f_act[:, 3:], axes) + np.cross(hand - pos, force_h)
        w_human = np.where(welded_h[:, None], np.concatenate([force_h, torque_h], axis=1), 0.0)
        # --- the wrist sensor (WristSensor.external, SensorModel.apply)
        holding = self.holding[rows]
        sensed = self._sense(rows, holding, pos, rot)
        f_s, t_s = sensed[:, :3], sensed[:, 3:]
        faults: dict[int, str] = {}
        f_true = self.true_wrench[rows, :3]
        over = holding & (np.einsum("ij,ij->i", f_true, f_true) > design.grip_hold_force_n ** 2)
        self.overload[rows] = np.where(over, self.overload[rows] + dt_c, 0.0)
        for j in np.flatnonzero(holding & (self.overload[rows] > design.grip_overload_time_s)):
            i = int(rows[j])
            self._weld(i, False)
            faults[i] = f"pulled_out: {np.linalg.norm(f_true[j]):.0f} N on the grip"
        # --- the seats (Seats.engaged, Seats.wrench)
        seat = self._engaged(rows, pos, quat)
        xfrc = self._get("xfrc_applied")
        wrench = np.zeros((len(rows), 6))
        on = seat >= 0
        if on.any():
            wrench[on] = self._seat_wrench(rows[on], seat[on], pos[on], quat[on], vel[on],
                                           angvel[on])
        xfrc[rows, body] = wrench
        # --- the robot's reference, DAVI (Disagreement) and the IK
        ref_pos, ref_quat = self.hold_pos[rows].copy(), self.hold_quat[rows].copy()
        ref_vel, ref_angvel = np.zeros((len(rows), 3)), np.zeros((len(rows), 3))
        has_ref = self.has_hold[rows].copy()
        scale = np.ones(len(rows))
        lined = self.has_line[rows] & ~self.yielded[rows]
        if lined.any():
            lr = rows[lined]
            moving = self.t_line[lr] < self.l_dur[lr]
            u = np.where(moving[:, None], self.l_dir[lr], 0.0)
            ax = np.where(moving[:, None], self.l_axis[lr], 0.0)
            sc_l = self._davi(lr, self._disagreement(f_s[lined], t_s[lined], u, ax), dt_c)
            scale[lined] = sc_l
            p, q, v, om = bm.line_sample(self.t_line[lr], self.l_dur[lr], self.l_start[lr],
                                         self.l_delta[lr], self.l_q0[lr], self.l_q1[lr],
                                         self.l_rot[lr])
            ref_pos[lined], ref_quat[lined], ref_vel[lined], ref_angvel[lined] = p, q, v, om
            has_ref[lined] = True
            self.t_line[lr] += dt_c * sc_l
        yielded = self.yielded[rows]
        has_ref &= ~yielded
        robot_q = qpos[rows, :self.n_robot].astype(float)
        due = self.period[rows] % self.ik_every == 0
        if due.any():
            for j in np.flatnonzero(due & ~has_ref):  # passive: restart from the actual arm
                i = int(rows[j])
                self._ik_q[i] = self.template.ik.home
                self._ik_q[i, :self.n_robot] = robot_q[j]
                if self.n_base:
                    self._ik_target[i, :self.n_base] = robot_q[j, :self.n_base]
            site_xpos, site_xmat = self._get("site_xpos"), self._get("site_xmat")
            grip_now_pos = site_xpos[rows, sc.grip_site].astype(float)
            grip_now_quat = bm.mat_to_quat(site_xmat[rows, sc.grip_site].astype(float))
            t_pos = np.where(has_ref[:, None], ref_pos, grip_now_pos)
            t_quat = np.where(has_ref[:, None], ref_quat, grip_now_quat)
            error = self._ik_step(rows[due], t_pos[due], t_quat[due])
            self.q_ref[rows[due]] = self._ik_q[rows[due], :self.n_robot]
            check = due & has_ref & self.has_line[rows]
            dt_ik = self.ik_every * dt_c
            bad = np.zeros(len(rows), bool)
            bad[due] = error > design.ik_error_max_m
            self.ik_bad[rows[check]] = np.where(bad[check], self.ik_bad[rows[check]] + dt_ik,
                                                0.0)
            for j in np.flatnonzero(check & (self.ik_bad[rows] > design.ik_error_time_max_s)):
                faults.setdefault(int(rows[j]), "ik_failure: the IK reference cannot follow "
                                                "the trajectory")
        # --- the controller (ImpedanceController.torques)
        tau = self._torques(rows, robot_q, qvel[rows, :self.n_robot].astype(float),
                            (ref_pos, ref_quat, ref_vel, ref_angvel), has_ref, scale, holding)
        ctrl[rows[:, None], self._acts[None]] = tau
        self._put("ctrl", ctrl)
        self._put("xfrc_applied", xfrc)
        mjw.step2(self.m, self.d)
        for _ in range(self.k - 1):
            mjw.step(self.m, self.d)
        if saved is not None:
            for name, value in saved.items():
                arr = self._get(name)
                arr[frozen] = value
                self._put(name, arr)
        # --- after the period: totals, the platform, the checks, settling
        self.elapsed[rows] += dt_c
        self.period[rows] += 1
        self.sensordata[rows] = self._get("sensordata")[rows]
        self.tot[rows, 0] += np.linalg.norm(f_s, axis=1) * dt_c
        self.tot[rows, 1] += np.linalg.norm(t_s, axis=1) * dt_c
        self.tot[rows, 2] += (bm.dot(f_s, vel) + bm.dot(t_s, angvel)) * dt_c
        self.tot[rows, 3] += np.linalg.norm(w_human[:, :3], axis=1) * dt_c
        self.tot[rows, 4] += np.linalg.norm(w_human[:, 3:], axis=1) * dt_c
        period = self.period[rows]
        if sc.platform_mocap >= 0:
            every = max(1, design.platform_update_every_steps // self.k)
            upd = rows[period % every == 0]
            if upd.size:
                mocap, q_now = self._get("mocap_pos"), self._get("qpos")
                mocap[upd, sc.platform_mocap, :2] = q_now[upd, :2] + design.base_pos[:2]
                self._put("mocap_pos", mocap)
        pos_now = self._get("xpos")[rows, body].astype(float)
        quat_now = self._get("xquat")[rows, body].astype(float)
        check_every = max(1, design.stability_check_every_steps // self.k)
        checking = period % check_every == 0
        if checking.any():
            qv_all = self._get("qvel")[rows]
            floor = self._floor_touch(rows)
            for j in np.flatnonzero(checking):
                i = int(rows[j])
                if not np.all(np.isfinite(qv_all[j])) or np.abs(qv_all[j]).max() > \
                        design.diverged_qvel_max:
                    faults.setdefault(i, "unstable: the simulation diverged")
                elif floor[j] or pos_now[j, 2] < self.lowest_z[i] - design.drop_margin_m:
                    faults.setdefault(i, "dropped: the object " + (
                        "hit the floor" if floor[j] else "fell below every state"))
        slow = ((bm.dot(vel, vel) < design.settle_vel_sq_max_m2_s2)
                & (bm.dot(angvel, angvel) < design.settle_angvel_sq_max_rad2_s2))
        robot_done = ~self.has_line[rows] | self.yielded[rows] | (self.t_line[rows]
                                                                 >= self.l_dur[rows])
        at_target = self._human_at_target(rows, pos_now, quat_now)
        calm = slow & robot_done & (self.elapsed[rows] >= self.min_time_s[rows]) & at_target
        self.calm[rows] = np.where(calm, self.calm[rows] + dt_c, 0.0)
        settled = self.calm[rows] >= design.settle_calm_time_s
        timeout = self.elapsed[rows] >= self.limit_s[rows]
        if self.on_period is not None:
            self.on_period(run)
        for j in np.flatnonzero(settled | timeout | np.isin(rows, list(faults))):
            i = int(rows[j])
            if i in faults:
                self._end_phase(i, faults[i])
                continue
            self.settled[i] = bool(settled[j])
            if not settled[j]:  # at the limit: PandaSim._run's final stability check
                qv_i = self._get("qvel")[i]
                if not np.all(np.isfinite(qv_i)) or np.abs(qv_i).max() > \
                        design.diverged_qvel_max:
                    self._end_phase(i, "unstable: the simulation diverged")
                    continue
            self._end_phase(i, None)

    def _rng(self, i: int, which: str = "rng") -> np.random.Generator:
        """World ``i``'s generator of the human's noise (or ``which`` other)."""
        rng = getattr(self.worlds[int(i)], which)
        if rng is None:
            raise RuntimeError(f"world {i} was never reset")
        return rng

    def _floor_touch(self, rows: np.ndarray) -> np.ndarray:
        """(R,) bool: a contact of each world in ``rows`` involves the floor."""
        nacon = min(int(self.d.nacon.numpy()[0]), self.d.contact.worldid.shape[0])
        out = np.zeros(len(rows), bool)
        if nacon == 0:
            return out
        world = self.d.contact.worldid.numpy()[:nacon]
        geom = self.d.contact.geom.numpy()[:nacon]
        hit = np.unique(world[(geom == self.scene.floor_geom).any(axis=1)])
        return np.isin(rows, hit)

    def _human_at_target(self, rows: np.ndarray, pos: np.ndarray,
                         quat: np.ndarray) -> np.ndarray:
        """SimulatedHuman.at_target per world: no plan, or the object at the reach's goal."""
        out = np.ones(len(rows), bool)
        plan = self.h_plan[rows]
        if plan.any():
            pr = rows[plan]
            goal = self.h_start[pr] + self.h_delta[pr]
            near = np.linalg.norm(goal - pos[plan], axis=1) < self.design.position_tolerance
            ang = np.linalg.norm(bm.rotation_error(self.h_q1[pr], quat[plan]), axis=1)
            out[plan] = near & (ang < self.design.angle_tolerance)
        return out

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

    def _arm_targets(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """HumanArm.targets per world: (R, 6) joint targets putting the hand on the handle."""
        rot = bm.quat_to_mat(quat)
        out = np.empty((len(pos), 6))
        out[:, :3] = pos + np.einsum("nij,j->ni", rot, self._handle)
        r = rot @ self._rest_t
        out[:, 3] = np.arctan2(r[:, 1, 0], r[:, 0, 0])
        out[:, 5] = np.arctan2(r[:, 2, 1], r[:, 2, 2])
        out[:, 4] = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
        return np.clip(out, self._arm_lo, self._arm_hi)

    def _sense(self, rows: np.ndarray, holding: np.ndarray, pos: np.ndarray,
               rot: np.ndarray) -> np.ndarray:
        """WristSensor.external per world: (R, 6) the sensed external wrench on the object."""
        sc = self.scene
        sens = self.sensordata[rows]
        smat = self._get("site_xmat")[rows, sc.wrist_site].astype(float)
        f_raw = np.einsum("rij,rj->ri", smat, sens[:, self._adr_force:self._adr_force + 3])
        t_raw = np.einsum("rij,rj->ri", smat, sens[:, self._adr_torque:self._adr_torque + 3])
        site = self._get("site_xpos")[rows, sc.wrist_site].astype(float)
        hand_com = self._get("subtree_com")[rows, sc.hand_body].astype(float)
        com = pos + np.einsum("rij,j->ri", rot, self._object_com)
        gw, ow = self._hand_weight, self._object_weight
        f_ext = -f_raw - gw - ow
        t_ext = (-t_raw - np.cross(hand_com - site, gw) - np.cross(com - site, ow)
                 - np.cross(pos - site, f_ext))
        true = np.where(holding[:, None], np.concatenate([f_ext, t_ext], axis=1), 0.0)
        self.true_wrench[rows] = true
        out = true.copy()
        for j in np.flatnonzero([self.worlds[i].delay_steps > 0 for i in rows]):
            w = self.worlds[int(rows[j])]
            w.queue.append(true[j].copy())
            out[j] = w.queue.popleft() if len(w.queue) > w.delay_steps else w.queue[0]
        out += self.sensor_bias[rows]
        noisy = self.sensor_noise[rows] > 0.0
        if noisy.any():
            lever = self.template.design.sensor_torque_lever_m
            z = np.stack([self._rng(i, "sensor_rng").standard_normal(6) for i in rows[noisy]])
            k = self.sensor_noise[rows[noisy]][:, None]
            z[:, 3:] *= lever
            out[noisy] += k * z
        return out

    def _seat_wrench(self, rows: np.ndarray, k: np.ndarray, pos: np.ndarray, quat: np.ndarray,
                     vel: np.ndarray, angvel: np.ndarray) -> np.ndarray:
        """Seats.wrench per world: (R, 6) force and torque of seat ``k`` on the object."""
        design = self.design
        e = self.seat_pos[rows, k] - pos
        force = design.seat_stiffness * e - design.seat_damping * vel
        n = self.seat_exit[rows, k]
        f_out = bm.dot(force, n)
        along = -bm.dot(e, n)
        fade = np.clip((design.seat_capture_m - along) / design.seat_fade_m, 0.0, 1.0)
        force = (force + (np.maximum(f_out, -self.seat_hold[rows]) - f_out)[:, None] * n)
        torque = (design.seat_rot_stiffness * bm.rotation_error(self.seat_quat[rows, k], quat)
                  - design.seat_rot_damping * angvel)
        return np.concatenate([force, torque], axis=1) * fade[:, None]

    def _disagreement(self, force: np.ndarray, torque: np.ndarray, u: np.ndarray,
                      axis: np.ndarray) -> np.ndarray:
        """Disagreement.force per world [N]."""
        design = self.design
        f0 = design.disagree_force[0]
        slack = design.disagree_slack_factor * f0
        lever = design.lever
        along = bm.dot(force, u)
        across = np.linalg.norm(force - along[:, None] * u, axis=1)
        t_along = bm.dot(torque, axis)
        t_across = np.linalg.norm(torque - t_along[:, None] * axis, axis=1)
        return (across + np.maximum(-along - slack, 0.0)
                + (t_across + np.maximum(-t_along - slack * lever, 0.0)) / lever)

    def _davi(self, rows: np.ndarray, disagreement: np.ndarray, dt: float) -> np.ndarray:
        """Disagreement.update per world; the stiffness scales (R,)."""
        design = self.design
        f0, f1 = design.disagree_force
        target = np.clip((disagreement - f0) / (f1 - f0), 0.0, 1.0)
        alpha = self.alpha[rows]
        tau = np.where(target > alpha, design.disagree_rise_time_s, design.disagree_fall_time_s)
        alpha = alpha + (target - alpha) * np.minimum(dt / tau, 1.0)
        self.alpha[rows] = alpha
        high = np.where(alpha > design.disagree_yield_alpha, self.high[rows] + dt, 0.0)
        self.high[rows] = high
        self.yielded[rows] |= high >= design.disagree_yield_time_s
        return np.where(self.yielded[rows], 0.0, 1.0 - alpha)

    def _ik_step(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """One mink-warp differential-IK step of the worlds ``rows`` towards the grip poses
        (pos, quat); the others keep their reference. Returns the (R,) error of mink's
        ReferenceIK.error (position + 0.1 m/rad x orientation of the frame task).
        """
        wp = self._wp
        dt_ik = self.ik_every * self.dt_control
        self._ik_pose[rows, :4] = quat
        self._ik_pose[rows, 4:] = pos
        with wp.ScopedDevice(self.device):
            self.ik_config.update(self._ik_q)
            self.ik_frame.set_target(self._ik_pose)
            self.ik_posture.set_target(self._ik_target)
            v = self.ik_solver.solve([self.ik_frame, self.ik_posture], dt_ik)
            self.ik_config.integrate_inplace(v, dt_ik)
            q_new = self.ik_config.q.numpy().astype(float)
            error = self.ik_frame.compute_error(self.ik_config).numpy().astype(float)
        self._ik_q[rows] = q_new[rows]
        e = error[rows]
        return np.linalg.norm(e[:, :3], axis=1) + 0.1 * np.linalg.norm(e[:, 3:], axis=1)

    def _torques(self, rows: np.ndarray, q: np.ndarray, qd: np.ndarray,
                 ref: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                 has_ref: np.ndarray, scale: np.ndarray, payload: np.ndarray) -> np.ndarray:
        """ImpedanceController.torques per world: (R, n) torques of the robot's joints."""
        sc, design, n = self.scene, self.design, self.n_robot
        r_count = len(rows)
        anchor = self._get("xanchor")[rows][:, self._jnt].astype(float)  # (R, n, 3)
        axis = self._get("xaxis")[rows][:, self._jnt].astype(float)
        site = self._get("site_xpos")[rows, sc.grip_site].astype(float)
        site_quat = bm.mat_to_quat(self._get("site_xmat")[rows, sc.grip_site].astype(float))
        hinge = self._hinge[None, :, None]
        jac = np.empty((r_count, 6, n))
        jac[:, :3] = np.where(hinge, np.cross(axis, site[:, None] - anchor), axis).transpose(
            0, 2, 1)
        jac[:, 3:] = np.where(hinge, axis, 0.0).transpose(0, 2, 1)
        twist = np.einsum("rij,rj->ri", jac, qd)
        v, w = twist[:, :3], twist[:, 3:]
        d_pp, d_pr = design.passive_damping
        s = np.where(has_ref, scale, 0.0)[:, None]
        k_p, k_r = design.stiffness[0] * s, design.stiffness[1] * s
        d_p = s * design.damping[0] + (1 - s) * d_pp
        d_r = s * design.damping[1] + (1 - s) * d_pr
        p_ref, q_ref, v_ref, w_ref = ref
        e_rot = bm.rotation_error(q_ref, site_quat)
        active = has_ref[:, None]
        wrench = np.concatenate([
            np.where(active, k_p * (p_ref - site) + d_p * (s * v_ref - v), -d_pp * v),
            np.where(active, k_r * e_rot + d_r * (s * w_ref - w), -d_pr * w)], axis=1)
        tau = np.einsum("rij,ri->rj", jac, wrench)
        tau += self._get("qfrc_bias")[rows, :n].astype(float)
        if payload.any():
            com = self._get("xipos")[rows, sc.object_body].astype(float)
            jc = np.where(hinge, np.cross(axis, com[:, None] - anchor), axis)  # (R, n, 3)
            tau += np.where(payload[:, None], np.einsum("rji,i->rj", jc, self._weight), 0.0)
        tau0 = self._kn * (self.q_ref[rows] - q) - self._dn * qd
        # M⁻¹ [Jᵀ | τ₀] by MuJoCo Warp's factorised mass matrix (all worlds, 7 solves).
        minv = np.zeros((r_count, 7, n))
        rhs_host = np.zeros((self.n, self.nv))
        for c in range(7):
            rhs_host[:] = 0.0
            rhs_host[rows, :n] = jac[:, c] if c < 6 else tau0
            self._rhs.assign(rhs_host.astype(np.float32))
            self._mjw.solve_m(self.m, self.d, self._sol, self._rhs)
            minv[:, c] = self._sol.numpy()[rows, :n]
        minv_jt = minv[:, :6]  # (R, 6, n) = (M⁻¹ Jᵀ)ᵀ
        lam_inv = np.einsum("rin,rjn->rij", minv_jt, jac) + _LAMBDA_INV_REGULARIZATION * np.eye(6)
        lam_x = np.linalg.solve(lam_inv, np.einsum("rin,rn->ri", jac, minv[:, 6])[..., None])
        tau0 = tau0 - np.einsum("rin,ri->rn", jac, lam_x[..., 0])
        return np.clip(tau + tau0, -self._tau_hi, self._tau_hi)

    # ------------------------------------------------------------------ rendering
    def sync_template(self, i: int) -> mujoco.MjData:
        """Copy world ``i``'s state into the C template's data (for pictures); its data."""
        tpl = self.template
        for name in ("qpos", "qvel", "mocap_pos", "mocap_quat", "ctrl"):
            getattr(tpl.data, name)[:] = self._get(name)[i]
        tpl.data.eq_active[:] = self._get("eq_active")[i]
        mujoco.mj_forward(tpl.model, tpl.data)
        return tpl.data
