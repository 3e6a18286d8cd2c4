"""One control period of every world in a run, vectorised over the worlds
(:class:`PandaPeriod`, ``PandaSim._run``'s loop body for all worlds at once).

The period's phases, in the C backend's order: MuJoCo Warp's ``step1`` (kinematics); the
human (their reach's reference and noise, their arm's targets and wrench); the wrist sensor
and the grip's overload; the seats; the robot's reference (its straight line, DAVI, the IK
reference's batched mink-warp step); the impedance controller; ``step2`` and the period's
remaining physics steps; then the totals, the platform, the stability and floor checks and
the settle test, and the events of the worlds whose run ended
(:mod:`~hri_envs.physics.panda.warp.events`). A world not in a run waits frozen: its integration
state is put back after the period.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from hri_envs.physics.panda.warp.build import IDLE
from hri_envs.physics.panda.warp.events import PandaEvents
from hri_envs.physics.scene.warp import batchmath as bm
from hri_envs.physics.scene.warp.control import davi, disagreement

__all__ = ["PandaPeriod"]


class _Object(NamedTuple):
    """The object's state in the worlds of a period after ``step1``: (R, ...) arrays."""

    pos: np.ndarray
    quat: np.ndarray
    rot: np.ndarray
    vel: np.ndarray
    angvel: np.ndarray


class _Reference(NamedTuple):
    """The robot's grip reference in the worlds of a period."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    angvel: np.ndarray
    active: np.ndarray  # (R,) bool: tracking (else passive)
    scale: np.ndarray  # (R,) the stiffness scale


class PandaPeriod(PandaEvents):
    """The vectorised control period (see the module)."""

    def run_period(self) -> None:
        """One control period of every world that is in a run (PandaSim._run's loop body)."""
        mjw = self._mjw
        run = self.phase != IDLE
        rows = np.flatnonzero(run)
        frozen = ~run
        saved = self.freeze(frozen)
        mjw.step1(self.m, self.d)
        obj = self._object_state(rows)
        w_human = self._human_period(rows, obj)
        faults: dict[int, str] = {}
        holding = self.holding[rows]
        sensed = self._sensor_period(rows, holding, obj, faults)
        self.seats.apply(self, rows, self.scene.object_body, obj.pos, obj.quat, obj.vel,
                         obj.angvel)
        ref = self._robot_reference(rows, sensed, faults)
        qpos, qvel = self._get("qpos"), self._get("qvel")
        n_r = self.n_robot
        tau = self.robot.torques(self, rows, qpos[rows, :n_r].astype(float),
                                 qvel[rows, :n_r].astype(float),
                                 np.concatenate([ref.pos, ref.quat, ref.vel, ref.angvel],
                                                axis=1), ref.active,
                                 ref.scale, holding, self.q_ref[rows])
        ctrl = self._get("ctrl")
        ctrl[rows[:, None], self._acts[None]] = tau
        self._put("ctrl", ctrl)
        mjw.step2(self.m, self.d)
        for _ in range(self.k - 1):
            mjw.step(self.m, self.d)
        self.thaw(frozen, saved)
        self._after_period(rows, run, obj, sensed, w_human, faults)

    def _object_state(self, rows: np.ndarray) -> _Object:
        body = self.scene.object_body
        quat = self._get("xquat")[rows, body].astype(float)
        dof0 = int(self.scene.object_dofs[0])
        qv = self._get("qvel")[rows, dof0:dof0 + 6].astype(float)
        return _Object(self._get("xpos")[rows, body].astype(float), quat,
                       self._get("xmat")[rows, body].astype(float), qv[:, :3],
                       bm.rotate(quat, qv[:, 3:]))

    # ------------------------------------------------------------------ the human
    def _human_period(self, rows: np.ndarray, obj: _Object) -> np.ndarray:
        """SimulatedHuman.advance, HumanArm.drive per world; (R, 6) the arm's wrench."""
        design, dt_c, arm = self.design, self.dt_control, self._arm
        ctrl = self._get("ctrl")
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
            ctrl[rows[tracking][:, None], arm.actuators[None]] = self._arm_targets(
                obj.pos[tracking], obj.quat[tracking])
        if h_rows.size and ref_h is not None:
            p_h, q_h, v_h, w_h = ref_h
            target = self._arm_targets(p_h, q_h)
            lever = np.einsum("nij,j->ni", bm.quat_to_mat(q_h), self._handle)
            wrist = self._get("xaxis")[h_rows][:, arm.joints[3:]].astype(float)  # (R, 3, 3)
            rates = np.concatenate([v_h + np.cross(w_h, lever),
                                    np.einsum("rij,rj->ri", wrist, w_h)], axis=1)
            target += self.lead[h_rows] * rates + self.noise_scale[h_rows] * self.h_noise[h_rows]
            ctrl[h_rows[:, None], arm.actuators[None]] = target
        self._put("ctrl", ctrl)
        welded_h = self._get("eq_active")[rows, arm.weld].astype(bool)
        f_act = self._get("actuator_force")[rows][:, arm.actuators].astype(float)
        axes = self._get("xaxis")[rows][:, arm.joints[3:]].astype(float)
        hand = self._get("xpos")[rows, arm.hand_body].astype(float)
        force_h = f_act[:, :3]
        torque_h = np.einsum("rj,rji->ri", f_act[:, 3:], axes) + np.cross(hand - obj.pos,
                                                                          force_h)
        return np.where(welded_h[:, None], np.concatenate([force_h, torque_h], axis=1), 0.0)

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

    def _arm_targets(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """HumanArm.targets per world: (R, 6) joint targets putting the hand on the handle."""
        rot = bm.quat_to_mat(quat)
        out = np.empty((len(pos), 6))
        out[:, :3] = pos + np.einsum("nij,j->ni", rot, self._handle)
        r = rot @ self._arm.rest_t
        out[:, 3] = np.arctan2(r[:, 1, 0], r[:, 0, 0])
        out[:, 5] = np.arctan2(r[:, 2, 1], r[:, 2, 2])
        out[:, 4] = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
        return np.clip(out, self._arm_lo, self._arm_hi)

    # ------------------------------------------------------------------ the robot
    def _sensor_period(self, rows: np.ndarray, holding: np.ndarray, obj: _Object,
                       faults: dict[int, str]) -> np.ndarray:
        """The wrist sensor's reading (R, 6) and the grip's overload (``pulled_out``)."""
        design, dt_c = self.design, self.dt_control
        sensed = self.sensors.external(self, rows, self.sensordata[rows], holding, obj.pos,
                                       obj.rot)
        f_true = self.sensors.true_wrench[rows, :3]
        over = holding & (np.einsum("ij,ij->i", f_true, f_true) > design.grip_hold_force_n ** 2)
        self.overload[rows] = np.where(over, self.overload[rows] + dt_c, 0.0)
        for j in np.flatnonzero(holding & (self.overload[rows] > design.grip_overload_time_s)):
            i = int(rows[j])
            self._weld(i, False)
            faults[i] = f"pulled_out: {np.linalg.norm(f_true[j]):.0f} N on the grip"
        return sensed

    def _robot_reference(self, rows: np.ndarray, sensed: np.ndarray,
                         faults: dict[int, str]) -> _Reference:
        """The robot's straight line (with DAVI) or hold pose, and the IK reference."""
        design, dt_c = self.design, self.dt_control
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
            force = disagreement(design, sensed[lined, :3], sensed[lined, 3:], u, ax)
            sc_l = davi(design, lr, force, dt_c, self.alpha, self.high, self.yielded)
            scale[lined] = sc_l
            p, q, v, om = bm.line_sample(self.t_line[lr], self.l_dur[lr], self.l_start[lr],
                                         self.l_delta[lr], self.l_q0[lr], self.l_q1[lr],
                                         self.l_rot[lr])
            ref_pos[lined], ref_quat[lined], ref_vel[lined], ref_angvel[lined] = p, q, v, om
            has_ref[lined] = True
            self.t_line[lr] += dt_c * sc_l
        has_ref &= ~self.yielded[rows]
        ref = _Reference(ref_pos, ref_quat, ref_vel, ref_angvel, has_ref, scale)
        due = self.period[rows] % self.ik_every == 0
        if due.any():
            self._ik_update(rows, due, ref, faults)
        return ref

    def _ik_update(self, rows: np.ndarray, due: np.ndarray, ref: _Reference,
                   faults: dict[int, str]) -> None:
        """The IK reference's step of the worlds ``rows[due]`` (``ik_failure``)."""
        design, sc, n_r, ik = self.design, self.scene, self.n_robot, self.ik
        has_ref = ref.active
        robot_q = self._get("qpos")[rows, :n_r].astype(float)
        restart = due & ~has_ref  # passive: restart from the actual arm, all such at once
        passive = rows[restart]
        ik.q[passive] = self.template.ik.home
        ik.q[passive, :n_r] = robot_q[restart]
        if self.n_base:
            ik.target[passive, :self.n_base] = robot_q[restart, :self.n_base]
        grip_now_pos = self._get("site_xpos")[rows, sc.grip_site].astype(float)
        grip_now_quat = bm.mat_to_quat(self._get("site_xmat")[rows, sc.grip_site].astype(float))
        t_pos = np.where(has_ref[:, None], ref.pos, grip_now_pos)
        t_quat = np.where(has_ref[:, None], ref.quat, grip_now_quat)
        dt_ik = self.ik_every * self.dt_control
        error = ik.step(rows[due], t_pos[due], t_quat[due], dt_ik)
        self.q_ref[rows[due]] = ik.q[rows[due], :n_r]
        check = due & has_ref & self.has_line[rows]
        bad = np.zeros(len(rows), bool)
        bad[due] = error > design.ik_error_max_m
        self.ik_bad[rows[check]] = np.where(bad[check], self.ik_bad[rows[check]] + dt_ik, 0.0)
        for j in np.flatnonzero(check & (self.ik_bad[rows] > design.ik_error_time_max_s)):
            faults.setdefault(int(rows[j]), "ik_failure: the IK reference cannot follow "
                                            "the trajectory")

    # ------------------------------------------------------------------ after the physics
    def _after_period(self, rows: np.ndarray, run: np.ndarray, obj: _Object,
                      sensed: np.ndarray, w_human: np.ndarray,
                      faults: dict[int, str]) -> None:
        """Totals, the platform, the checks, settling; the ended runs' events."""
        design, sc, dt_c = self.design, self.scene, self.dt_control
        f_s, t_s = sensed[:, :3], sensed[:, 3:]
        self.elapsed[rows] += dt_c
        self.period[rows] += 1
        self.sensordata[rows] = self._get("sensordata")[rows]
        self.tot[rows, 0] += np.linalg.norm(f_s, axis=1) * dt_c
        self.tot[rows, 1] += np.linalg.norm(t_s, axis=1) * dt_c
        self.tot[rows, 2] += (bm.dot(f_s, obj.vel) + bm.dot(t_s, obj.angvel)) * dt_c
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
        pos_now = self._get("xpos")[rows, sc.object_body].astype(float)
        quat_now = self._get("xquat")[rows, sc.object_body].astype(float)
        check_every = max(1, design.stability_check_every_steps // self.k)
        checking = period % check_every == 0
        if checking.any():
            self._check_stability(rows, checking, pos_now, faults)
        slow = ((bm.dot(obj.vel, obj.vel) < design.settle_vel_sq_max_m2_s2)
                & (bm.dot(obj.angvel, obj.angvel) < design.settle_angvel_sq_max_rad2_s2))
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

    def _check_stability(self, rows: np.ndarray, checking: np.ndarray, pos_now: np.ndarray,
                         faults: dict[int, str]) -> None:
        """PandaSim._run's periodic checks: diverged, or the object dropped."""
        design = self.design
        qv_all = self._get("qvel")[rows]
        with np.errstate(invalid="ignore"):  # NaN velocities: caught by isfinite
            diverged = ~np.isfinite(qv_all).all(1) | (np.abs(qv_all).max(1)
                                                      > design.diverged_qvel_max)
        floor = self.touching(rows, self.scene.floor_geom)
        for j in np.flatnonzero(checking):
            i = int(rows[j])
            if diverged[j]:
                faults.setdefault(i, "unstable: the simulation diverged")
            elif floor[j] or pos_now[j, 2] < self.lowest_z[i] - design.drop_margin_m:
                faults.setdefault(i, "dropped: the object " + (
                    "hit the floor" if floor[j] else "fell below every state"))
