"""What a simulation of the scene does alike in both env families: :class:`SceneRig`.

The base of :class:`~hri_envs.physics.panda.sim.PandaSim` (the discrete Panda backend) and
:class:`~hri_envs.physics.carry.sim.CarrySim` (the continuous envs): the compiled model's
data and timing, the poses they read from MuJoCo's data, the supports moved to a layout,
and the mobile base's mount offset. Each subclass builds the attributes below in its
constructor.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.ik import ReferenceIK
from hri_envs.physics.scene.kinematics import Pose
from hri_envs.physics.scene.observer import StateObserver
from hri_envs.physics.scene.seats import Seats
from hri_envs.task.geometry import Scenario

__all__ = ["SceneRig"]


class SceneRig:
    """Poses, layout and mount offset of a simulated scene.

    Attributes:
        scene: The compiled scene and its ids.
        data: Its MuJoCo data.
        design: The physical design.
        scenario: The current layout of the supports.
        seats: The supports' seats.
        observer: The observer of abstract states.
        ik: The robot's IK reference.
        home: The robot's home posture (its joints).
        lowest_z: The lowest support's height [m] (below it by a margin, the object fell).
        dt: The physics step [s] (:meth:`init_data`).
        control_every: Physics steps per control period.
        dt_control: The control period [s].
    """

    scene: Scene
    model: mujoco.MjModel
    data: mujoco.MjData
    design: PhysicsDesign
    scenario: Scenario
    seats: Seats
    observer: StateObserver
    ik: ReferenceIK
    home: np.ndarray
    lowest_z: float
    dt: float
    control_every: int
    dt_control: float

    def init_data(self) -> None:
        """The model's data and timing: MuJoCo's data, the physics step ``dt``, the control
        period (``control_every`` steps of ``dt``, ``dt_control`` s) of the design.

        No mid-phase (per-body BVH) collision culling: the scene's bodies carry a few geoms
        each, so it only costs time (≈ 5 % of the control loop); the contacts, and the
        trajectories, are the same bit for bit (docs/physics.md, "Speed").
        """
        self.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MIDPHASE
        self.data = mujoco.MjData(self.model)
        self.dt = float(self.model.opt.timestep)
        self.control_every = max(1, int(self.design.control_every_steps))
        self.dt_control = self.control_every * self.dt

    def grip_pose(self) -> Pose:
        """The robot hand's grip frame now."""
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, self.data.site_xmat[self.scene.grip_site])
        return Pose(self.data.site_xpos[self.scene.grip_site].copy(), q)

    def object_pose(self) -> Pose:
        """The object's current pose."""
        b = self.scene.object_body
        return Pose(self.data.xpos[b].copy(), self.data.xquat[b].copy())

    def set_scenario(self, scenario: Scenario) -> None:
        """Move the supports (the wheel's stands) to ``scenario``'s layout."""
        self.scenario = scenario
        for k, sup in enumerate(scenario.supports):
            self.data.mocap_pos[self.scene.support_mocap[k]] = sup.position
        self.seats.set_scenario(scenario)
        self.observer.set_scenario(scenario)
        self.lowest_z = float(self.observer.pos[:, 2].min())

    def mount_offset(self) -> np.ndarray:
        """The mobile base's mount position relative to the grip in the home posture."""
        m = self.ik.model
        data = mujoco.MjData(m)
        data.qpos[: len(self.home)] = self.home
        mujoco.mj_kinematics(m, data)
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "grip")
        return self.design.base_pos - data.site_xpos[site]
