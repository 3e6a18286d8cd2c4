"""The events of a world's abstract step on MuJoCo Warp: its start, the end of each phase, its
end (:class:`PandaEvents`, plain Python per world, as in the C backend's
:meth:`~hri_envs.physics.panda.sim.PandaSim.step`).

A world's step is a sequence of *runs* (``PandaSim._run``), each tracking a straight line
and/or holding a pose until the object settles or a time limit: the grasp's approach and
closing (then the finger check and the weld) or the let-go's retreat, then the main motion.
Between runs, and at the step's end (observe, infer the human's action, report), the world's
events run here; the runs themselves advance all worlds together
(:mod:`~hri_envs.physics.panda.warp.period`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hri_envs.physics.panda.sim import StepResult, plan_step
from hri_envs.physics.panda.warp.build import (
    APPROACH,
    CLOSE,
    IDLE,
    MAIN,
    RETREAT,
    PandaWorldsState,
)
from hri_envs.physics.scene.build import FINGER_OPEN_M
from hri_envs.physics.scene.kinematics import Pose, StraightLine, compose
from hri_envs.physics.scene.observer import infer_human_action
from hri_envs.physics.scene.warp import batchmath as bm
from hri_envs.task.graph import BOTH, HUMAN_BIT, ROBOT_BIT, TOGGLE, WAIT

__all__ = ["PandaEvents"]


class PandaEvents(PandaWorldsState):
    """The per-world events of the abstract step (see the module)."""

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
        return self.template.pregrasp(grip)

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
                self.phase[i] = APPROACH
            else:
                self._weld(i, False)
                grip = self.grip_pose(i)
                line = StraightLine(grip, self._pregrasp(grip), design.linear_speed,
                                    design.angular_speed, design.motion_min_duration_s)
                self._begin_run(i, line, None, design.release_retreat_time_limit_s)
                self.phase[i] = RETREAT
            return
        self._start_main(i)

    def _start_main(self, i: int) -> None:
        """The human's toggle and the step's motion (PandaSim.step after the robot's toggle)."""
        g, w, design, tpl = self.graph, self.worlds[i], self.design, self.template
        s, a_r, a_h = w.s, w.a_r, w.a_h
        human_toggle, s1, robot_moves, human_moves = plan_step(
            g, s, a_r, a_h, tpl.settings.attempt_invalid)
        if human_toggle:
            self.human_holding[i] = bool(g.grasp[int(g.next_state[s, WAIT, TOGGLE])]
                                         & HUMAN_BIT)
        self._human_hold(i, bool(self.human_holding[i]))
        line = None
        observer = self._observer(i)
        if robot_moves:
            pos, quat = observer.pose(tpl.motion_target(s1, a_r))
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
        self.phase[i] = MAIN

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
        if phase == APPROACH:
            ctrl = self._get("ctrl")
            ctrl[i, self.scene.finger_actuators] = self.design.grip_finger_pos_m
            self._put("ctrl", ctrl)
            self._begin_run(i, None, self.grip_pose(i), self.design.grasp_close_time_s,
                            min_time_s=self.design.grasp_close_time_s)
            self.phase[i] = CLOSE
        elif phase == CLOSE:
            fault = self._check_grasp(i)
            if fault is not None:
                w.fault = fault
                self._finish(i)
            else:
                self._weld(i, True)
                self._start_main(i)
        elif phase == RETREAT:
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
        ctrl[i, self.scene.finger_actuators] = FINGER_OPEN_M
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
        self.phase[i] = IDLE
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
        return int(self.seats.engaged(np.array([i]), pos[None], quat[None])[0])
