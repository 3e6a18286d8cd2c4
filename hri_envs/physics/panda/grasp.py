"""The discrete Panda backend's robot grasp: the weld on the object's grip and the fingers.

:class:`PandaGrasp`, the base of :class:`~hri_envs.physics.panda.sim.PandaSim`: the robot's
grasp toggle (approach the grip where the object is and close the fingers, welded only once
both press on the grip, else ``grasp_failed``; or let go and retreat to the pregrasp pose) and
the weld that carries the held object. The motions run in ``PandaSim``'s physics loop.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.panda.steps import StepFault, StepTotals
from hri_envs.physics.scene.build import FINGER_HOLD_STIFFENING, FINGER_ON_GRIP_M, FINGER_OPEN_M
from hri_envs.physics.scene.contacts import finger_forces
from hri_envs.physics.scene.kinematics import Pose, StraightLine, compose, rotation_error
from hri_envs.physics.scene.rig import SceneRig

__all__ = ["PandaGrasp"]


class PandaGrasp(SceneRig):
    """The robot's grasp on the object's grip (:meth:`init_grasp` sets it up).

    Attributes:
        finger_contype: The robot fingers' geoms' contact types (restored when the weld
            lets go).
        grip_in_object: The grip frame in the object's frame.
        holding: The robot's grasp weld is on.
    """

    finger_contype: np.ndarray
    grip_in_object: Pose
    holding: bool

    def init_grasp(self) -> None:
        """The fingers' contact types and gains, the grip site and the grip in the object."""
        m, design = self.model, self.design
        self.finger_contype = m.geom_contype[self.scene.finger_geoms.ravel()].copy()
        self._finger_kp = m.actuator_gainprm[self.scene.finger_actuators, 0].copy()
        self._site_pos = m.site_pos[self.scene.grip_site].copy()
        self._site_quat = m.site_quat[self.scene.grip_site].copy()
        self.grip_in_object = Pose(design.grip_pos, design.grip_quat)

    def _run(self, line: StraightLine | None, hold: Pose | None, totals: StepTotals,
             limit_s: float, min_time_s: float | None = None) -> tuple[bool, bool]:
        """The physics loop (:class:`~hri_envs.physics.panda.sim.PandaSim`'s)."""
        raise NotImplementedError

    def pregrasp(self, grip: Pose) -> Pose:
        """The pose ``pregrasp_distance_m`` back from the grip pose ``grip`` along its z."""
        return compose(grip, np.array([0.0, 0.0, -self.design.pregrasp_distance_m]),
                       np.array([1.0, 0, 0, 0]))

    def weld(self, on: bool) -> None:
        """The robot's grasp weld on (at the grip pose now, the fingers held on the grip,
        their contacts off) or off (the fingers' contacts on again).
        """
        sc, m = self.scene, self.model
        if on:
            # Pose of the hand body (link 7) in the object frame: grip ∘ site⁻¹.
            inv_q = np.array([self._site_quat[0], *-self._site_quat[1:]])
            rel = compose(self.grip_in_object, -self._rotate(inv_q, self._site_pos), inv_q)
            m.eq_data[sc.weld, 0:3] = 0.0
            m.eq_data[sc.weld, 3:6] = rel.pos
            m.eq_data[sc.weld, 6:10] = rel.quat
        data = self.data
        data.eq_active[sc.weld] = int(on)
        # While the weld holds, the finger contacts are off: the weld carries the object, and
        # the four finger contacts were a third to half of MuJoCo's time per step (docs/physics.md,
        # Robot). The weld holds the object at the nominal grip, so the fingers are servoed
        # to where they meet the grip block there, 10x stiffer: without the block to stop
        # them, their weight would slide them into it.
        acts = sc.finger_actuators
        data.ctrl[acts] = FINGER_ON_GRIP_M if on else FINGER_OPEN_M
        kp = self._finger_kp * (FINGER_HOLD_STIFFENING if on else 1.0)
        m.actuator_gainprm[acts, 0] = kp
        m.actuator_biasprm[acts, 1] = -kp
        m.geom_contype[sc.finger_geoms.ravel()] = 0 if on else self.finger_contype
        self.holding = on

    @staticmethod
    def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
        out = np.empty(3)
        mujoco.mju_rotVecQuat(out, v, q)
        return out

    def _robot_toggle(self, totals: StepTotals) -> None:
        design = self.design
        if not self.holding:  # approach the grip where the object actually is, then close
            site = self.scene.object_grip_site
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, self.data.site_xmat[site])
            line = StraightLine(self.grip_pose(), Pose(self.data.site_xpos[site].copy(), quat),
                                design.linear_speed, design.angular_speed,
                                min_duration=design.grasp_approach_min_duration_s)
            self._run(line, None, totals, design.grasp_approach_time_limit_s)
            self._close_on_grip(totals)
        else:
            self.weld(False)
            grip = self.grip_pose()
            line = StraightLine(grip, self.pregrasp(grip), design.linear_speed,
                                design.angular_speed, design.motion_min_duration_s)
            self._run(line, None, totals, design.release_retreat_time_limit_s)

    def _close_on_grip(self, totals: StepTotals) -> None:
        """Close the fingers where the hand is; weld only if both press on the grip.

        Raises:
            StepFault: ``grasp_failed`` when a finger's contact force on the object's grip
                geometry stays below ``grasp_contact_force_n`` (it closed on nothing).
        """
        design, sc = self.design, self.scene
        self.data.ctrl[sc.finger_actuators] = design.grip_finger_pos_m
        self._run(None, self.grip_pose(), totals, design.grasp_close_time_s,
                  min_time_s=design.grasp_close_time_s)
        forces = finger_forces(self.model, self.data, sc.finger_geoms, sc.grip_geom)
        if forces.min() < design.grasp_contact_force_n:
            self.data.ctrl[sc.finger_actuators] = FINGER_OPEN_M
            raise StepFault(f"grasp_failed: the fingers press on the grip with {forces[0]:.1f} N "
                            f"and {forces[1]:.1f} N (a hold needs "
                            f"{design.grasp_contact_force_n:g} N each)")
        # Fingers on the grip block but the hand off the grip (e.g. beside it along the
        # block): a weld would snap the object into the hand, so the grasp fails.
        block, grip = sc.grip_geom, self.grip_pose()  # the grip block is the true grip frame
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, self.data.geom_xmat[block])
        miss_m = float(np.linalg.norm(grip.pos - self.data.geom_xpos[block]))
        miss_rad = float(np.linalg.norm(rotation_error(quat, grip.quat)))
        if miss_m > design.grasp_tolerance_m or miss_rad > design.grasp_tolerance_rad:
            self.data.ctrl[sc.finger_actuators] = FINGER_OPEN_M
            raise StepFault(f"grasp_failed: the hand closed {miss_m * 100:.1f} cm, "
                            f"{np.rad2deg(miss_rad):.0f}° from the grip (a hold needs "
                            f"{design.grasp_tolerance_m * 100:g} cm, "
                            f"{np.rad2deg(design.grasp_tolerance_rad):.0f}°)")
        self.weld(True)
