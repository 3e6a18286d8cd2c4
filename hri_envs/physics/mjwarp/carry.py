"""N worlds of the continuous envs' scene (the robot, the whole human arm and the object) on
MuJoCo Warp, stepped together at 25 Hz: :class:`WarpCarryWorlds`.

Each world runs :meth:`hri_envs.physics.carry.CarrySim.step`: the robot's command (a grip
target and a stiffness) becomes one batched mink-warp IK step and a straight line tracked
by the impedance controller; the human's reference advances along their route (or follows
the human agent's command), their arm's impedance and torque drive pull the hand, the torso
follows; the seats hold a resting object; the wrist sensor reads; 5 control periods of
MuJoCo Warp's ``step1``/``step2``/``step`` for all worlds at once; the effort, disagreement,
faults and placement per world. The control laws are vectorised over the worlds
(:mod:`~hri_envs.physics.mjwarp.control`, :mod:`~hri_envs.physics.mjwarp.carry_human`).

**Contacts and grasps per world.** The human's grip is friction: the palm and the finger pad
collide with the handle in every world (``contype`` bit 64, always on, so MuJoCo Warp's
per-model collision pairs hold it), and each world's finger pad squeezes with its human's
grip force (``actuator_forcerange``, a per-world model value, like the strength limits'
``actuator_ctrlrange``). The robot's grasp is its weld (``eq_active``, per world), as on the
C backend (whose robot fingers never collide in this scene). Faults (``dropped``,
``slipped``, ``too_weak``, ``unstable``, ``ik_failure``) are per world.

Resets are simulated by a C :class:`~hri_envs.physics.carry.CarrySim` (its IK places the
robot's and the human's arm, from the same random streams) and copied into the world. Only
the torque drive runs here (the backend's ``carry_drives``). Differences from the C backend: float32
physics; mink-warp's IK (an ADMM QP, not daqp; a failed solve is an ``ik_failure`` only if
its result is not finite); a world's kinematics after another world's reset are recomputed
from its state (the C backend's are those of one physics step earlier).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from hri_envs.envs.backends import backend_spec
from hri_envs.errors import ConfigError
from hri_envs.physics.body import WARP_BODY_FIELDS
from hri_envs.physics.carry import (
    _ANGVEL_SQ_MAX,
    _CALM_S,
    _CONTROL_PERIODS,
    _DROP_BELOW_M,
    _SLIP_M,
    _SLIP_RAD,
    _STRAINED_S,
    _VEL_SQ_MAX,
    CarrySim,
    CarryStep,
)
from hri_envs.physics.design import PhysicsDesign
from hri_envs.physics.intention import HumanParams
from hri_envs.physics.interaction import InteractionMeter
from hri_envs.physics.mjwarp import batchmath as bm
from hri_envs.physics.mjwarp.carry_human import Samples, WarpArms, WarpIntention, rotate_by
from hri_envs.physics.mjwarp.control import RobotImpedance, WarpSeats, WristSensors
from hri_envs.physics.mjwarp.ik import BatchIK
from hri_envs.physics.mjwarp.model import WarpModel
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph

__all__ = ["Commands", "WarpCarryWorlds"]

_PERIODS = _CONTROL_PERIODS
_PER_WORLD = ("robot_holds", "human_holds", "q_ref", "left_start", "strained", "calm",
              "time", "sensed", "sat_counts", "lowest_z", "sensordata")


class Commands(NamedTuple):
    """Commands of every world: grip (or hand) targets and stiffness scales, (N, ...)."""

    pos: np.ndarray
    quat: np.ndarray
    stiffness: np.ndarray


class WarpCarryWorlds(WarpModel):
    """``n_worlds`` worlds of a scenario's continuous-control scene on MuJoCo Warp.

    Args:
        graph: The scenario's task graph.
        n_worlds: How many worlds are stepped together.
        drive: The arm's drive (only "torque" runs here).
        design, max_step_m, max_step_rad, sensor: As :class:`~hri_envs.physics.carry.CarrySim`.
        device: Warp device (default: Warp's default device, a GPU where there is one).

    Raises:
        ConfigError: A drive that does not run on MuJoCo Warp (naming the one that does).
    """

    def __init__(self, graph: TaskGraph, n_worlds: int, drive: str = "torque",
                 design: PhysicsDesign | None = None, max_step_m: float = 0.02,
                 max_step_rad: float = 0.06, sensor: Mapping[str, float] | None = None,
                 device: str | None = None) -> None:
        drives = backend_spec("mjwarp").carry_drives  # the registry says what runs here
        if drive not in drives:
            raise ConfigError(f"drive {drive!r} does not run on backend='mjwarp' (MyoSuite's "
                              "muscles need a least-squares problem per world and control "
                              f"period); allowed there: {', '.join(drives)}",
                              field="drive")
        tpl = self.template = CarrySim(graph, drive, design, max_step_m, max_step_rad, sensor)
        tpl._weld(True)  # the grasp weld's relative pose, the robot fingers' contacts off
        super().__init__(tpl.model, n_worlds, ("actuator_ctrlrange", "actuator_forcerange",
                                               *WARP_BODY_FIELDS), device)
        n, sc = self.n, tpl.scene
        self.graph, self.design, self.scene = graph, tpl.design, sc
        self.max_step_m, self.max_step_rad = max_step_m, max_step_rad
        self.k, self.dt, self.dt_control, self.dt_step = (tpl.control_every, tpl.dt,
                                                          tpl.dt_control, tpl.dt_step)
        self.n_robot, self.n_base = len(sc.robot_dofs), tpl.n_base
        self.weight = self.design.object_mass * 9.81
        self.robot = RobotImpedance(tpl.model, sc, tpl.controller, self.design)
        self.sensors = WristSensors(n, tpl.sensor, self.design.sensor_torque_lever_m)
        self.seats = WarpSeats(n, tpl.seats, self.design)
        self.ik = BatchIK(tpl.ik.model, n, self.n_base, tpl.ik.home, self.device)
        self.human = WarpIntention(n, self.design.lever)
        imp = tpl.impedance
        self.arms = WarpArms(n, tpl.model, tpl.arm, tpl.posture, (imp.kn, imp.dn),
                             tpl.arm_drive.actuators,  # type: ignore[attr-defined]
                             tpl.rest_quat, tpl.handle_pos, tpl.handle_quat)
        self._handle_adr = (tpl._hf, tpl._ht)
        self.robot_holds, self.human_holds = np.zeros(n, bool), np.zeros(n, bool)
        self.q_ref = np.zeros((n, self.n_robot))
        self.left_start = np.zeros(n, bool)
        self.strained, self.calm, self.time = np.zeros(n), np.zeros(n), np.zeros(n)
        self.sensed = np.zeros((n, 6))
        self.sat_counts = np.zeros((n, len(tpl.posture)))
        self.meter = InteractionMeter(n, self.dt_control)
        self.lowest_z = np.zeros(n)
        self.params: list[HumanParams] = [HumanParams()] * n
        self.scenarios: list[Scenario] = [graph.scenario] * n
        self.joint_names = tpl.joint_names()

    # ------------------------------------------------------------------ resets
    def reset_world(self, i: int, start: int, goal: int, rng: np.random.Generator,
                    scenario: Scenario | None = None, human: HumanParams | None = None,
                    robot_holds: bool = True) -> None:
        """World ``i`` at an episode's start, as :meth:`CarrySim.reset` places it (the C
        template simulates the reset with the same arguments and draws; its state, the
        episode's parameters and random streams are copied into the world).

        Raises:
            IKFailure: The robot cannot reach its grip, or the human's arm the handle.
        """
        tpl = self.template
        tpl.reset(start, goal, rng, scenario, human, robot_holds)
        self.load_world(i, tpl.model, tpl.data)
        self.sensors.reset_world(i, tpl.sensor.model)
        self.seats.set_world(i, tpl.seats, self.design.seat_hold)
        self.human.set_world(i, tpl.human)
        self.arms.gains[i] = tpl._gains()
        self.arms.hand_in_torso[i] = tpl.arm.hand_in_torso
        self.arms.torso_height[i] = tpl.arm.torso_height_m
        self.arms.lo[i], self.arms.hi[i] = tpl.arm_drive.lo, tpl.arm_drive.hi
        self.robot_holds[i], self.human_holds[i] = tpl.robot_holds, tpl.human_holds
        self.q_ref[i] = tpl.q_ref
        self.ik.q[i] = tpl.ik.configuration.q
        self.ik.target[i] = tpl.ik.posture.target_q
        self.left_start[i] = False
        self.strained[i] = self.calm[i] = self.time[i] = 0.0
        self.sensed[i], self.sat_counts[i] = 0.0, 0.0
        self.meter.reset(np.array([i]))
        self.lowest_z[i] = tpl._lowest_z
        self.params[i], self.scenarios[i] = tpl.params, tpl.scenario
        self._placed.add(i)

    def copy_world(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` become copies of world ``src`` (each copy's sensor noise from
        a generator of its own): for measurements, without a C reset per world.
        """
        rows = np.asarray(rows, dtype=np.int64)
        self.copy_rows(src, rows)
        for name in _PER_WORLD:
            value = getattr(self, name)
            value[rows] = value[src]
        for part in (self.ik, self.sensors, self.seats, self.human):
            part.copy_rows(src, rows)
        for value in (self.meter.v_prev, self.meter.a_prev, self.meter.samples):
            value[rows] = value[src]
        for value in (self.arms.gains, self.arms.lo, self.arms.hi, self.arms.hand_in_torso,
                      self.arms.torso_height):
            value[rows] = value[src]
        for i in rows:
            self.params[int(i)], self.scenarios[int(i)] = self.params[src], self.scenarios[src]
        self._placed.update(int(i) for i in rows)


    # ------------------------------------------------------------------ poses
    def site_poses(self, rows: np.ndarray, site: int) -> tuple[np.ndarray, np.ndarray]:
        """(R, 3) positions and (R, 4) orientations of ``site`` in the worlds ``rows``."""
        self._refresh()
        return (self._get("site_xpos")[rows, site].astype(float),
                bm.mat_to_quat(self._get("site_xmat")[rows, site].astype(float)))

    def object_poses(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(R, 3) positions and (R, 4) orientations of the object in the worlds ``rows``."""
        self._refresh()
        b = self.scene.object_body
        return (self._get("xpos")[rows, b].astype(float),
                self._get("xquat")[rows, b].astype(float))

    def commands(self, rows: np.ndarray, actions: np.ndarray, human: bool = False) -> Commands:
        """CarrySim.command (or human_command) per world: the commands of actions (R, 7) in
        [-1, 1], relative to the robot's grip (the human's hand) in the worlds ``rows``,
        as (N, ...) arrays (other worlds: zeros).
        """
        site = self.arms.grip_site if human else self.scene.grip_site
        pos, quat = self.site_poses(rows, site)
        a = np.asarray(actions, dtype=float)
        out = Commands(np.zeros((self.n, 3)), np.tile([1.0, 0, 0, 0], (self.n, 1)),
                       np.zeros(self.n))
        out.pos[rows] = pos + self.max_step_m * a[:, :3]
        out.quat[rows] = rotate_by(quat, self.max_step_rad * a[:, 3:6])
        out.stiffness[rows] = (a[:, 6] + 1.0) / 2.0
        return out

    # ------------------------------------------------------------------ stepping
    def step(self, robot: Commands, active: np.ndarray, human: Commands | None = None,
             human_active: np.ndarray | None = None) -> list[CarryStep | None]:
        """One 40 ms step of every ``active`` world (the others stay frozen).

        Args:
            robot: Each world's robot command (:meth:`commands`).
            active: (N,) bool, the worlds that step.
            human: The human agents' commands (:meth:`commands` with ``human=True``), for
                the worlds ``human_active``; the others' humans follow their routes.
            human_active: (N,) bool (default: none).

        Returns:
            Per world its :class:`~hri_envs.physics.carry.CarryStep`, None where inactive.
        """
        self._refresh()
        rows = np.flatnonzero(active)
        agent = (np.zeros(len(rows), bool) if human is None or human_active is None
                 else np.asarray(human_active, bool)[rows])
        plan = self._plan(rows, robot, human, agent)
        bad = ~np.all(np.isfinite(self.ik.q[rows]), axis=1)
        out: list[CarryStep | None] = [None] * self.n
        for failed in rows[bad].tolist():
            out[failed] = self._result(failed, 0.0, 0.0, 0.0, "ik_failure: the IK reference "
                                       "is not finite")
        keep = ~bad
        rows, agent = rows[keep], agent[keep]
        plan = _Plan(*(x[keep] for x in plan))
        frozen = np.ones(self.n, bool)
        frozen[rows] = False
        totals = np.zeros((len(rows), 3))  # lin, ang, disagreement
        samples = (np.zeros((len(rows), _PERIODS)), np.zeros((len(rows), _PERIODS, 3)))
        sat = np.zeros((len(rows), self.arms.lo.shape[1]))
        start_obj = self._get("xpos")[rows, self.scene.object_body].astype(float)
        faults: dict[int, str] = {}
        for p in range(_PERIODS):
            self._period(p, rows, frozen, plan, agent, totals, sat, samples)
            if p == _PERIODS - 1:
                self._check(rows, faults)
        self._after_step(rows, start_obj, sat, faults)
        inter = self.meter.step(rows, *samples)
        for j, i in enumerate(rows.tolist()):
            lin, ang, disagree = totals[j].tolist()
            out[i] = self._result(i, lin, ang, disagree, faults.get(i),
                                  (float(inter.peak_force[j]), float(inter.force_sq[j]),
                                   float(inter.jerk_sq[j])))
        return out

    def _plan(self, rows: np.ndarray, robot: Commands, human: Commands | None,
              agent: np.ndarray) -> _Plan:
        """The step's set-up per world: the robot's line, its IK reference step (stiff:
        towards the target; passive: restarted from the actual arm towards its grip), the
        human agent's line and the hand's gains.
        """
        n_r, n_b, ik = self.n_robot, self.n_base, self.ik
        grip_pos, grip_quat = self.site_poses(rows, self.scene.grip_site)
        stiffness = robot.stiffness[rows]
        stiff = (stiffness > 1e-3) & self.robot_holds[rows]
        delta = robot.pos[rows] - grip_pos
        rotvec = bm.rotation_error(robot.quat[rows], grip_quat)
        robot_q = self._get("qpos")[rows, :n_r].astype(float)
        loose = rows[~stiff]  # ReferenceIK.reset(robot_q), in every loose world at once
        ik.q[loose] = ik.target[loose] = self.template.ik.home
        ik.q[loose, :n_r] = robot_q[~stiff]
        ik.target[loose, :n_b] = robot_q[~stiff, :n_b]
        t_pos = np.where(stiff[:, None], robot.pos[rows], grip_pos)
        t_quat = np.where(stiff[:, None], robot.quat[rows], grip_quat)
        if len(rows):
            ik.step(rows, t_pos, t_quat, self.dt_step)
            self.q_ref[rows] = ik.q[rows, :n_r]
        hand_pos, hand_quat = self.site_poses(rows, self.arms.grip_site)
        h_delta, h_rot = np.zeros_like(hand_pos), np.zeros_like(hand_pos)
        gains = self.arms.gains[rows].copy()
        if human is not None and agent.any():
            h_delta[agent] = human.pos[rows[agent]] - hand_pos[agent]
            h_rot[agent] = bm.rotation_error(human.quat[rows[agent]], hand_quat[agent])
            gains[agent] *= human.stiffness[rows[agent]][:, None]
        return _Plan(grip_pos, grip_quat, delta, rotvec, stiff, np.minimum(stiffness, 1.0),
                     hand_pos, hand_quat, h_delta, h_rot, gains)

    def _period(self, p: int, rows: np.ndarray, frozen: np.ndarray, plan: _Plan,
                agent: np.ndarray, totals: np.ndarray, sat: np.ndarray,
                samples: tuple[np.ndarray, np.ndarray]) -> None:
        """One control period of the worlds ``rows`` (CarrySim.step's loop body)."""
        mjw, sc, dt_c, arms = self._mjw, self.scene, self.dt_control, self.arms
        saved = self.freeze(frozen)
        mjw.step1(self.m, self.d)
        body = sc.object_body
        pos = self._get("xpos")[rows, body].astype(float)
        quat = self._get("xquat")[rows, body].astype(float)
        dof0 = int(sc.object_dofs[0])
        qv = self._get("qvel")[rows, dof0:dof0 + 6].astype(float)
        v, w_body = qv[:, :3], bm.rotate(quat, qv[:, 3:])
        hand_ref, obj_quat = self._human_reference(p, rows, plan, agent, pos, quat)
        ctrl = self._get("ctrl")
        ctrl[rows[:, None], arms.torso_actuators[None]] = arms.torso_targets(hand_ref.pos,
                                                                             obj_quat, rows)
        ff = np.zeros((len(rows), 6))
        alone = ~self.robot_holds[rows]
        if alone.any():  # carrying alone: hold up the object's weight
            r = (self._get("xipos")[rows[alone], body].astype(float)
                 - self._get("site_xpos")[rows[alone], arms.grip_site].astype(float))
            up = np.array([0.0, 0.0, self.weight])
            ff[alone, 2] = self.weight
            ff[alone, 3:] = np.cross(r, up)
        tau = arms.torques(self, rows, hand_ref, ff, plan.gains)
        lo, hi = arms.lo[rows], arms.hi[rows]
        made = np.clip(tau, lo, hi)
        ctrl[rows[:, None], arms.actuators[None]] = made
        sat += (made <= lo + 1e-9) | (made >= hi - 1e-9)
        rot = self._get("xmat")[rows, body].astype(float)
        holds = self.robot_holds[rows]
        self.sensed[rows] = self.sensors.external(self, rows, self.sensordata[rows], holds,
                                                  pos, rot)
        seat = self.seats.apply(self, rows, body, pos, quat, v, w_body)
        self.left_start[rows[seat < 0]] = True
        s = (p + 1) / _PERIODS
        ref = (plan.grip_pos + s * plan.delta, rotate_by(plan.grip_quat, s * plan.rotvec),
               plan.delta / self.dt_step, plan.rotvec / self.dt_step)
        q = self._get("qpos")[rows, :self.n_robot].astype(float)
        qd = self._get("qvel")[rows, :self.n_robot].astype(float)
        ctrl[rows[:, None], sc.robot_actuators[None]] = self.robot.torques(
            self, rows, q, qd, ref, plan.stiff, plan.scale, holds, self.q_ref[rows])
        self._put("ctrl", ctrl)
        mjw.step2(self.m, self.d)
        for _ in range(self.k - 1):
            mjw.step(self.m, self.d)
        self.thaw(frozen, saved)
        live = self._get("sensordata")[rows].astype(float)
        f, t = arms.handle_wrench(self, rows, live, self._handle_adr)
        f_norm = np.linalg.norm(f, axis=1)
        totals[:, 0] += f_norm * dt_c
        totals[:, 1] += np.linalg.norm(t, axis=1) * dt_c
        hv = self._get("qvel")[rows, dof0:dof0 + 3].astype(float)
        samples[0][:, p], samples[1][:, p] = f_norm, hv
        power = bm.dot(f, hv) + bm.dot(t, w_body)
        totals[:, 2] += np.maximum(0.0, -power) * dt_c
        self.sensordata[rows] = live

    def _human_reference(self, p: int, rows: np.ndarray, plan: _Plan, agent: np.ndarray,
                         pos: np.ndarray, quat: np.ndarray) -> tuple[Samples, np.ndarray]:
        """The hand's reference (the scripted human's route, or the agent's line) and the
        object orientation it stands for, per world.
        """
        r = len(rows)
        hand = Samples(np.zeros((r, 3)), np.zeros((r, 4)), np.zeros((r, 3)), np.zeros((r, 3)))
        obj_quat = np.zeros((r, 4))
        scripted = ~agent
        if scripted.any():
            ref = self.human.advance(rows[scripted], self.dt_control, pos[scripted],
                                     quat[scripted])
            for field, value in zip(hand, self.arms.hand_reference(ref), strict=True):
                field[scripted] = value
            obj_quat[scripted] = ref.quat
        if agent.any():
            s_h = (p + 1) / _PERIODS
            hq = rotate_by(plan.hand_quat[agent], s_h * plan.h_rot[agent])
            hand.pos[agent] = plan.hand_pos[agent] + s_h * plan.h_delta[agent]
            hand.quat[agent] = hq
            hand.vel[agent] = plan.h_delta[agent] / self.dt_step
            hand.angvel[agent] = plan.h_rot[agent] / self.dt_step
            obj_quat[agent] = self.arms.object_quat(hq)
        return hand, obj_quat

    def _check(self, rows: np.ndarray, faults: dict[int, str]) -> None:
        """CarrySim._check per world (the step's last period): dropped, diverged, slipped."""
        pos = self._get("xpos")[rows, self.scene.object_body].astype(float)
        floor = self.touching(rows, self.scene.floor_geom)
        below = pos[:, 2] < self.lowest_z[rows] - _DROP_BELOW_M
        finite = np.all(np.isfinite(self._get("qpos")[rows]), axis=1)
        off, angle = self.arms.slip(self, rows)
        for j, i in enumerate(int(i) for i in rows):
            if floor[j] or below[j]:
                faults[i] = "dropped: the object " + ("hit the floor" if floor[j]
                                                      else "fell below every support")
            elif not finite[j]:
                faults[i] = "unstable: the simulation diverged"
            elif off[j] > _SLIP_M or angle[j] > _SLIP_RAD:
                self.human_holds[i] = False
                kind = "slipped" if self.robot_holds[i] else "dropped"
                faults[i] = (f"{kind}: the handle slipped out of the human's hand "
                             f"({off[j] * 100:.1f} cm, {math.degrees(angle[j]):.0f}° off); "
                             f"{self._why_slipped(i)}")

    def _why_slipped(self, i: int) -> str:
        """CarrySim._why_slipped of world ``i``."""
        names = self.joint_names
        sat = [n for n, c in zip(names, self.sat_counts[i], strict=True) if c > 0]
        lift = float(self.arms.max_lift(self, np.array([i]))[0])
        if not self.robot_holds[i] and lift < self.weight:
            return (f"the arm can lift at most {lift:.1f} N here, the object weighs "
                    f"{self.weight:.1f} N (joints at their strength limit: "
                    f"{', '.join(sat) or 'none'})")
        grip = float(self.m.actuator_forcerange.numpy()[i, self.template.arm.fingers, 1])
        return (f"grip force {grip:.1f} N; joints at their strength limit: "
                f"{', '.join(sat) or 'none'}")

    def _after_step(self, rows: np.ndarray, start_obj: np.ndarray, sat: np.ndarray,
                    faults: dict[int, str]) -> None:
        """The clock, the saturation counts, the too-weak test and the platform."""
        sc = self.scene
        self.time[rows] += self.dt_step
        self.sat_counts[rows] = sat
        alone = np.flatnonzero(~self.robot_holds[rows]
                               & ~np.isin(rows, np.fromiter(faults, dtype=np.int64)))
        if alone.size:
            ar = rows[alone]
            now = self._get("xpos")[ar, sc.object_body].astype(float)
            moved = np.linalg.norm(now - start_obj[alone], axis=1)
            strained = np.any(sat[alone] > _PERIODS / 2, axis=1) & (moved < 1e-3)
            self.strained[ar] = np.where(strained, self.strained[ar] + self.dt_step, 0.0)
            weak = self.strained[ar] >= _STRAINED_S
            if weak.any():
                lift = self.arms.max_lift(self, ar[weak])
                for i, value in zip(ar[weak], lift, strict=True):
                    if value < self.weight:
                        faults[int(i)] = ("too_weak: the human cannot carry the object "
                                          "alone; " + self._why_slipped(int(i)))
        if sc.platform_mocap >= 0 and len(rows):
            mocap = self._get("mocap_pos")
            mocap[rows, sc.platform_mocap, :2] = (self._get("qpos")[rows, :2]
                                                  + self.design.base_pos[:2])
            self._put("mocap_pos", mocap)

    def _result(self, i: int, lin: float, ang: float, disagree: float,
                fault: str | None,
                interaction: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> CarryStep:
        """CarrySim._result of world ``i``: progress, placement, effort."""
        rows = np.array([i])
        pos, quat = self.object_poses(rows)
        progress = float(self.human.progress(rows, pos, quat)[0])
        seat = int(self.seats.engaged(rows, pos, quat)[0])
        dof0 = int(self.scene.object_dofs[0])
        v = self._get("qvel")[i, dof0:dof0 + 6].astype(float)
        slow = float(v[:3].dot(v[:3])) < _VEL_SQ_MAX and float(v[3:].dot(v[3:])) < _ANGVEL_SQ_MAX
        placed = -1
        if seat >= 0 and self.left_start[i] and slow:
            self.calm[i] += self.dt_step
            if self.calm[i] >= _CALM_S:
                placed = seat
        else:
            self.calm[i] = 0.0
        sat = tuple(n for n, c in zip(self.joint_names, self.sat_counts[i], strict=True)
                    if c > _PERIODS / 2)
        return CarryStep(progress, lin + ang / self.design.lever, lin, ang, disagree,
                         self.sensed[i].copy(), placed, fault, sat, *interaction)


class _Plan(NamedTuple):
    """A step's set-up of the worlds that step, (R, ...) each (see ``_plan``)."""

    grip_pos: np.ndarray
    grip_quat: np.ndarray
    delta: np.ndarray
    rotvec: np.ndarray
    stiff: np.ndarray
    scale: np.ndarray
    hand_pos: np.ndarray
    hand_quat: np.ndarray
    h_delta: np.ndarray
    h_rot: np.ndarray
    gains: np.ndarray
