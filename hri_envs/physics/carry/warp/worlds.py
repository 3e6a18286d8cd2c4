"""N worlds of the continuous envs' scene (the robot, the whole human arm and the object) on
MuJoCo Warp, stepped together at 25 Hz: :class:`WarpCarryWorlds`.

Each world runs :meth:`hri_envs.physics.carry.sim.CarrySim.step`: the robot's command (a grip
target and a stiffness) becomes one batched mink-warp IK step and a straight line tracked
by the impedance controller; the human's reference advances along their route (or follows
the human agent's command), their arm's impedance and torque drive pull the hand, the torso
follows; the seats hold a resting object; the wrist sensor reads; 5 control periods of
MuJoCo Warp's ``step1``/``step2``/``step`` for all worlds at once; the effort, disagreement,
faults and placement per world (the end-of-step rules, :mod:`~hri_envs.physics.carry.rules`).
The control laws are the C backend's compiled ones
(:mod:`~hri_envs.physics.scene.laws`, :mod:`~hri_envs.physics.carry.human.laws`) run over the worlds
that step (:mod:`~hri_envs.physics.scene.warp.control`,
:mod:`~hri_envs.physics.carry.warp.human`): only the engine that steps differs.

**Contacts and grasps per world.** The human's grip is friction: the palm and the finger pad
collide with the handle in every world (``contype`` bit 64, always on, so MuJoCo Warp's
per-model collision pairs hold it), and each world's finger pad squeezes with its human's
grip force (``actuator_forcerange``, a per-world model value, like the strength limits'
``actuator_ctrlrange``). The robot's grasp is its weld (``eq_active``, per world), as on the
C backend (whose robot fingers never collide in this scene). Faults (``dropped``,
``slipped``, ``too_weak``, ``unstable``, ``ik_failure``) are per world.

Resets are simulated by a C :class:`~hri_envs.physics.carry.sim.CarrySim` (its IK places the
robot's and the human's arm, from the same random streams) and copied into the world. Only
the torque drive runs here (the backend's ``carry_drives``). Differences from the C backend: float32
physics; mink-warp's IK (an ADMM QP, not daqp; a failed solve is an ``ik_failure`` only if
its result is not finite); a world's kinematics after another world's reset are recomputed
from its state (the C backend's are those of one physics step earlier).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from hri_envs.envs.backends import backend_spec
from hri_envs.errors import ConfigError
from hri_envs.physics.carry import rules
from hri_envs.physics.carry.human import laws as hl
from hri_envs.physics.carry.human.body import WARP_BODY_FIELDS
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.interaction import InteractionMeter
from hri_envs.physics.carry.sim import CarrySim, CarryStep
from hri_envs.physics.carry.stages import ANGVEL_SQ_MAX, PERIODS, VEL_SQ_MAX
from hri_envs.physics.carry.warp.human import WarpArms
from hri_envs.physics.scene import laws
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.warp import batchmath as bm
from hri_envs.physics.scene.warp.control import RobotImpedance, WarpSeats, WristSensors, host
from hri_envs.physics.scene.warp.ik import BatchIK
from hri_envs.physics.scene.warp.model import WarpModel
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph

__all__ = ["Commands", "WarpCarryWorlds"]

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
        design, max_step_m, max_step_rad, sensor: As :class:`~hri_envs.physics.carry.sim.CarrySim`.
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
        tpl.weld(True)  # the grasp weld's relative pose, the robot fingers' contacts off
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
        #: Each world's human's route, line and clock (what ``intention_advance`` of
        #: :mod:`~hri_envs.physics.carry.human.laws` advances); ``route.humans``: the C humans.
        self.route = hl.RouteArrays(n, self.design.lever)
        imp = tpl.impedance
        self.arms = WarpArms(n, tpl.model, tpl.arm, tpl.posture, (imp.kn, imp.dn),
                             tpl.arm_drive.actuators,  # type: ignore[attr-defined]
                             tpl.rest_quat, tpl.handle_pos, tpl.handle_quat)
        self.handle_adr = (tpl.handle_force_adr, tpl.handle_torque_adr)
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
        self.route.bind(i, tpl.human)
        self.arms.gains[i] = tpl.hand_gains()
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
        self.lowest_z[i] = tpl.lowest_z
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
        for part in (self.ik, self.sensors, self.seats, self.route):
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
        self._refresh()
        a = np.ascontiguousarray(actions, dtype=float)
        target = np.empty((len(rows), 7))
        laws.grip_target(host(self, "site_xpos", rows, site), host(self, "site_xmat", rows, site),
                         a, self.max_step_m, self.max_step_rad, target)
        out = Commands(np.zeros((self.n, 3)), np.tile([1.0, 0, 0, 0], (self.n, 1)),
                       np.zeros(self.n))
        out.pos[rows], out.quat[rows] = target[:, :3], target[:, 3:]
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
            Per world its :class:`~hri_envs.physics.carry.sim.CarryStep`, None where inactive.
        """
        self._refresh()
        rows = np.flatnonzero(active)
        agent = (np.zeros(len(rows), bool) if human is None or human_active is None
                 else np.asarray(human_active, bool)[rows])
        plan = self._plan(rows, robot, human, agent)
        bad = ~np.all(np.isfinite(self.ik.q[rows]), axis=1)
        out: list[CarryStep | None] = [None] * self.n
        if bad.any():
            failed = rows[bad].tolist()
            for i, result in zip(failed, self._results(
                    rows[bad], np.zeros((len(failed), 3)),
                    dict.fromkeys(failed, "ik_failure: the IK reference is not finite")),
                    strict=True):
                out[i] = result
        keep = ~bad
        rows, agent = rows[keep], agent[keep]
        plan = _Plan(*(x[keep] for x in plan))
        frozen = np.ones(self.n, bool)
        frozen[rows] = False
        totals = np.zeros((len(rows), 3))  # lin, ang, disagreement
        samples = (np.zeros((len(rows), PERIODS)), np.zeros((len(rows), PERIODS, 3)))
        sat = np.zeros((len(rows), self.arms.lo.shape[1]))
        start_obj = self._get("xpos")[rows, self.scene.object_body].astype(float)
        faults: dict[int, str] = {}
        for p in range(PERIODS):
            self._period(p, rows, frozen, plan, agent, totals, sat, samples)
            if p == PERIODS - 1:
                self._check(rows, faults)
        self._after_step(rows, start_obj, sat, faults)
        inter = self.meter.step(rows, *samples)
        for i, result in zip(rows.tolist(), self._results(
                rows, totals, faults, np.stack([inter.peak_force, inter.force_sq,
                                                inter.jerk_sq], axis=1)), strict=True):
            out[i] = result
        return out

    def _plan(self, rows: np.ndarray, robot: Commands, human: Commands | None,
              agent: np.ndarray) -> _Plan:
        """The step's set-up per world: the robot grip's line
        (:func:`~hri_envs.physics.scene.laws.grip_motion`), its IK reference step (stiff: towards
        the target; passive: restarted from the actual arm towards its grip), the human
        agent's line and the hand's gains.
        """
        n_r, n_b, ik, grip = self.n_robot, self.n_base, self.ik, self.scene.grip_site
        stiffness = robot.stiffness[rows]
        stiff = (stiffness > 1e-3) & self.robot_holds[rows]
        motion = np.empty((len(rows), 19))
        laws.grip_motion(host(self, "site_xpos", rows, grip), host(self, "site_xmat", rows, grip),
                         np.ascontiguousarray(robot.pos[rows], dtype=float),
                         np.ascontiguousarray(robot.quat[rows], dtype=float), self.dt_step,
                         motion)
        robot_q = self._get("qpos")[rows, :n_r].astype(float)
        loose = rows[~stiff]  # ReferenceIK.reset(robot_q), in every loose world at once
        ik.q[loose] = ik.target[loose] = self.template.ik.home
        ik.q[loose, :n_r] = robot_q[~stiff]
        ik.target[loose, :n_b] = robot_q[~stiff, :n_b]
        t_pos = np.where(stiff[:, None], robot.pos[rows], motion[:, :3])
        t_quat = np.where(stiff[:, None], robot.quat[rows], motion[:, 3:7])
        if len(rows):
            ik.step(rows, t_pos, t_quat, self.dt_step)
            self.q_ref[rows] = ik.q[rows, :n_r]
        command = np.zeros((len(rows), 13))  # the hand now, its translation and rotation
        gains = self.arms.gains[rows].copy()
        if human is not None and agent.any():
            hand_pos, hand_quat = self.site_poses(rows[agent], self.arms.grip_site)
            command[agent, :3], command[agent, 3:7] = hand_pos, hand_quat
            command[agent, 7:10] = human.pos[rows[agent]] - hand_pos
            command[agent, 10:] = bm.rotation_error(human.quat[rows[agent]], hand_quat)
            gains[agent] *= human.stiffness[rows[agent]][:, None]
        return _Plan(motion, stiff, np.minimum(stiffness, 1.0), command, gains)

    def _period(self, p: int, rows: np.ndarray, frozen: np.ndarray, plan: _Plan,
                agent: np.ndarray, totals: np.ndarray, sat: np.ndarray,
                samples: tuple[np.ndarray, np.ndarray]) -> None:
        """One control period of the worlds ``rows`` (CarrySim.step's loop body: the C
        backend's stages, :mod:`~hri_envs.physics.carry.stages`, over the worlds).
        """
        mjw, sc, arms, r = self._mjw, self.scene, self.arms, len(rows)
        saved = self.freeze(frozen)
        mjw.step1(self.m, self.d)
        body, dof0 = sc.object_body, int(sc.object_dofs[0])
        pos, quat = host(self, "xpos", rows, body), host(self, "xquat", rows, body)
        vel = host(self, "qvel", rows, slice(dof0, dof0 + 3))
        angvel = np.empty((r, 3))
        laws.world_angvel(quat, host(self, "qvel", rows, slice(dof0 + 3, dof0 + 6)), angvel)
        s = (p + 1) / PERIODS
        # The human: their reference, the torso's targets, the hand impedance, the drive.
        hand_ref, obj_quat = self._human_reference(s, rows, plan, agent, pos, quat)
        torso = np.empty((r, 4))
        hl.torso_target(np.ascontiguousarray(hand_ref[:, :3]), obj_quat, arms.rest_quat,
                        arms.hand_in_torso[rows], arms.torso_height[rows], torso)
        ctrl = self._get("ctrl")
        ctrl[rows[:, None], arms.torso_actuators[None]] = torso
        holds = self.robot_holds[rows]
        ff = np.empty((r, 6))
        hl.carried_weight(~holds, host(self, "xipos", rows, body),
                          host(self, "site_xpos", rows, arms.grip_site), self.weight, ff)
        tau = arms.torques(self, rows, hand_ref, ff, plan.gains)
        made = np.empty_like(tau)
        hl.torque_drive(tau, arms.lo[rows], arms.hi[rows], made, sat)
        ctrl[rows[:, None], arms.actuators[None]] = made
        # The robot: the wrist sensor, the seats, the impedance controller.
        self.sensed[rows] = self.sensors.external(self, rows, self.sensordata[rows], holds,
                                                  pos, host(self, "xmat", rows, body))
        seat = self.seats.apply(self, rows, body, pos, quat, vel, angvel)
        self.left_start[rows[seat < 0]] = True
        ref = np.empty((r, 13))
        laws.robot_reference(plan.motion, s, plan.stiff, ref)
        n_r = self.n_robot
        ctrl[rows[:, None], sc.robot_actuators[None]] = self.robot.torques(
            self, rows, host(self, "qpos", rows, slice(0, n_r)),
            host(self, "qvel", rows, slice(0, n_r)), ref, plan.stiff, plan.scale, holds,
            self.q_ref[rows])
        self._put("ctrl", ctrl)
        mjw.step2(self.m, self.d)
        for _ in range(self.k - 1):
            mjw.step(self.m, self.d)
        self.thaw(frozen, saved)
        live = self._get("sensordata")[rows].astype(float)
        f_adr, t_adr = self.handle_adr
        laws.handle_sample(np.ascontiguousarray(live[:, f_adr:f_adr + 3]),
                           np.ascontiguousarray(live[:, t_adr:t_adr + 3]),
                           host(self, "site_xmat", rows, arms.handle_site),
                           host(self, "qvel", rows, slice(dof0, dof0 + 3)), angvel,
                           self.dt_control, totals, samples[0][:, p], samples[1][:, p])
        self.sensordata[rows] = live

    def _human_reference(self, s: float, rows: np.ndarray, plan: _Plan, agent: np.ndarray,
                         pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The hand's reference (R, 13) (the scripted human's route,
        :func:`~hri_envs.physics.carry.human.laws.intention_advance`, or the agent's line a
        fraction ``s`` of the step along) and the object orientation (R, 4) it stands for.
        """
        r, route = len(rows), self.route
        hand, obj_quat = np.empty((r, 13)), np.empty((r, 4))
        scripted = ~agent
        if scripted.any():
            ref, href = np.empty((int(scripted.sum()), 13)), np.empty((int(scripted.sum()), 13))
            hl.intention_advance(rows[scripted], self.dt_control, pos[scripted], quat[scripted],
                                 route.index, route.t, route.done, route.n_lines,
                                 route.hesitation, route.start, route.delta, route.rotvec,
                                 route.q0, route.q1, route.dur, route.lever, route.grid,
                                 route.phase, ref)
            hl.hand_reference(ref, self.arms.handle_pos, self.arms.handle_quat, href)
            hand[scripted], obj_quat[scripted] = href, ref[:, 3:7]
        if agent.any():
            cmd = plan.command[agent]
            href, oq = np.empty((len(cmd), 13)), np.empty((len(cmd), 4))
            hl.commanded_reference(cmd[:, 0:3], cmd[:, 3:7], cmd[:, 7:10], cmd[:, 10:13], s,
                                   self.dt_step, self.arms.handle_quat, href, oq)
            hand[agent], obj_quat[agent] = href, oq
        return hand, obj_quat

    def progress(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """IntentionHuman.progress per world of ``rows``: (R,) the objects' progress along
        their humans' routes (:func:`~hri_envs.physics.carry.human.laws.route_progress`).
        """
        route, out = self.route, np.empty(len(rows))
        hl.route_progress(np.asarray(rows, dtype=np.int64), np.ascontiguousarray(pos, float),
                          np.ascontiguousarray(quat, float), route.n_lines, route.start,
                          route.delta, route.rotvec, route.q0, route.length, route.lever,
                          0.05, out)
        return out

    def _check(self, rows: np.ndarray, faults: dict[int, str]) -> None:
        """check_faults per world (:func:`~hri_envs.physics.carry.rules.fault_codes`, the
        step's last period): dropped, diverged, slipped (then the human no longer holds).
        """
        pos = self._get("xpos")[rows, self.scene.object_body].astype(float)
        floor = self.touching(rows, self.scene.floor_geom)
        finite = np.all(np.isfinite(self._get("qpos")[rows]), axis=1)
        grip, handle = self.arms.grip_site, self.arms.handle_site
        off, angle = np.empty(len(rows)), np.empty(len(rows))
        laws.handle_slip(host(self, "site_xpos", rows, grip), host(self, "site_xmat", rows, grip),
                         host(self, "site_xpos", rows, handle),
                         host(self, "site_xmat", rows, handle), off, angle)
        codes = np.empty(len(rows), np.int64)
        rules.fault_codes(floor, pos[:, 2], self.lowest_z[rows], finite, off, angle, codes)
        self.human_holds[rows[codes == rules.FAULT_SLIPPED]] = False
        messages = rules.fault_messages(codes, off, angle, self.robot_holds[rows],
                                        lambda j: self._why_slipped(int(rows[j])))
        faults.update((int(i), m) for i, m in zip(rows, messages, strict=True) if m is not None)

    def _why_slipped(self, i: int) -> str:
        """why_slipped of world ``i`` (:func:`~hri_envs.physics.carry.rules.slip_reason`)."""
        lift = float(self.arms.max_lift(self, np.array([i]))[0])
        grip = float(self.m.actuator_forcerange.numpy()[i, self.template.arm.fingers, 1])
        return rules.slip_reason(bool(self.robot_holds[i]), lift, self.weight, grip,
                                 self.joint_names, self.sat_counts[i])

    def _after_step(self, rows: np.ndarray, start_obj: np.ndarray, sat: np.ndarray,
                    faults: dict[int, str]) -> None:
        """The clock, the saturation counts, the too-weak rule
        (:func:`~hri_envs.physics.carry.rules.strain_update`) and the platform.
        """
        sc = self.scene
        self.time[rows] += self.dt_step
        self.sat_counts[rows] = sat
        alone = np.flatnonzero(~self.robot_holds[rows]
                               & ~np.isin(rows, np.fromiter(faults, dtype=np.int64)))
        if alone.size:
            ar = rows[alone]
            now = self._get("xpos")[ar, sc.object_body].astype(float)
            strained = self.strained[ar]
            weak = rules.strain_update(strained, sat[alone], start_obj[alone], now, self.dt_step,
                                       self.weight, lambda due: self.arms.max_lift(self, ar[due]))
            self.strained[ar] = strained
            for i in ar[weak].tolist():
                faults[i] = rules.fault_message(rules.FAULT_TOO_WEAK, why=self._why_slipped(i))
        if sc.platform_mocap >= 0 and len(rows):
            mocap = self._get("mocap_pos")
            mocap[rows, sc.platform_mocap, :2] = (self._get("qpos")[rows, :2]
                                                  + self.design.base_pos[:2])
            self._put("mocap_pos", mocap)

    def _results(self, rows: np.ndarray, totals: np.ndarray, faults: dict[int, str],
                 interaction: np.ndarray | None = None) -> list[CarryStep]:
        """CarrySim._result of the worlds ``rows``: progress, placement
        (:func:`~hri_envs.physics.carry.rules.calm_update`), effort (``totals``: (R, 3) lin,
        ang, disagreement; ``interaction``: (R, 3) the peak force, ∫ |F|² dt, ∫ |jerk|² dt,
        default zeros).
        """
        pos, quat = self.object_poses(rows)
        progress = self.progress(rows, pos, quat)
        seat = self.seats.engaged(rows, pos, quat)
        dof0 = int(self.scene.object_dofs[0])
        v = self._get("qvel")[rows, dof0:dof0 + 6].astype(float)
        slow = ((np.sum(v[:, :3] * v[:, :3], axis=1) < VEL_SQ_MAX)
                & (np.sum(v[:, 3:] * v[:, 3:], axis=1) < ANGVEL_SQ_MAX))
        calm, placed = self.calm[rows], np.empty(len(rows), np.int64)
        rules.calm_update(calm, seat, self.left_start[rows], slow, self.dt_step, placed)
        self.calm[rows] = calm
        extra = np.zeros((len(rows), 3)) if interaction is None else interaction
        out = []
        for j, i in enumerate(rows.tolist()):
            lin, ang, disagree = totals[j].tolist()
            sat = tuple(rules.saturated_joints(self.joint_names, self.sat_counts[i],
                                               PERIODS / 2))
            out.append(CarryStep(float(progress[j]), lin + ang / self.design.lever, lin, ang,
                                 disagree, self.sensed[i].copy(), int(placed[j]), faults.get(i),
                                 sat, *extra[j].tolist()))
        return out


class _Plan(NamedTuple):
    """A step's set-up of the worlds that step, (R, ...) each (see ``_plan``): the robot
    grip's line (R, 19), tracking (R,) bool, the stiffness scale (R,), the human agent's
    line (R, 13: the hand's position and quaternion, translation, rotation) and the hand's
    gains (R, 4).
    """

    motion: np.ndarray
    stiff: np.ndarray
    scale: np.ndarray
    command: np.ndarray
    gains: np.ndarray
