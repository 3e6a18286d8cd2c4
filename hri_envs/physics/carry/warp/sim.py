"""The ``"mjwarp"`` backend inside the continuous envs: one world of a
:class:`~hri_envs.physics.carry.warp.worlds.WarpCarryWorlds` with the interface of a
:class:`~hri_envs.physics.carry.sim.CarrySim` (:class:`WarpCarrySim`).

``gymnasium.make("hri_envs/HangerPandaContinuous-v0", backend="mjwarp")`` and the parallel
form with ``backend="mjwarp"`` own a one-world :class:`WarpCarryWorlds`; the vector env
(:class:`~hri_envs.physics.carry.warp.vector.CarryVectorEnv`) gives each of its envs one
world of a shared one (:data:`SHARED`) and steps them together.
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from hri_envs.physics.carry.human.intention import HumanParams, IntentionHuman
from hri_envs.physics.carry.sim import CarryStep, RobotCommand, grip_reference
from hri_envs.physics.carry.warp.worlds import Commands, WarpCarryWorlds
from hri_envs.physics.scene import laws
from hri_envs.physics.scene.build import Scene
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import Pose
from hri_envs.physics.scene.warp.control import host
from hri_envs.physics.scene.warp.handout import Handout
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph

__all__ = ["SHARED", "WarpCarrySim", "make_carry_sim"]

#: A vector env's worlds for the envs it builds (``with SHARED.sharing(sims):``).
SHARED: Handout[WarpCarrySim] = Handout()


def make_carry_sim(graph: TaskGraph, drive: str = "torque",
                   design: PhysicsDesign | None = None, max_step_m: float = 0.02,
                   max_step_rad: float = 0.06, sensor: Mapping[str, float] | None = None,
                   device: str | None = None) -> WarpCarrySim:
    """The continuous envs' simulation on MuJoCo Warp (the arguments of
    :class:`~hri_envs.physics.carry.sim.CarrySim`): a one-world :class:`WarpCarryWorlds` on
    Warp's default device, or a vector env's world handed out (:data:`SHARED`).
    """
    return SHARED.take() or WarpCarrySim(WarpCarryWorlds(graph, 1, drive, design, max_step_m,
                                                         max_step_rad, sensor, device), 0)


class WarpCarrySim:
    """World ``index`` of ``worlds``, used as a :class:`~hri_envs.physics.carry.sim.CarrySim`.

    Args:
        worlds: The worlds.
        index: This one's.
    """

    def __init__(self, worlds: WarpCarryWorlds, index: int) -> None:
        self.worlds, self.index = worlds, index
        self._row = np.array([index])
        tpl = worlds.template
        self.graph, self.design, self.drive_name = worlds.graph, worlds.design, tpl.drive_name
        self.scene: Scene = tpl.scene
        self.max_step_m, self.max_step_rad = worlds.max_step_m, worlds.max_step_rad
        self.dt_step = worlds.dt_step
        self.grip_in_object = tpl.grip_in_object

    # ------------------------------------------------------------------ state
    @property
    def model(self) -> mujoco.MjModel:
        """The C template's model (for pictures)."""
        return self.worlds.template.model

    @property
    def data(self) -> mujoco.MjData:
        """The C template's data set to this world's state and layout (for pictures)."""
        tpl, i = self.worlds.template, self.index
        if tpl.scenario is not self.worlds.scenarios[i]:
            tpl.set_scenario(self.worlds.scenarios[i])
        self.worlds._refresh()
        return self.worlds.sync_to(i, tpl.model, tpl.data)

    @property
    def sensed(self) -> np.ndarray:
        """(6,) the robot's last wrist reading."""
        return self.worlds.sensed[self.index]

    @property
    def params(self) -> HumanParams:
        """The human of this world."""
        return self.worlds.params[self.index]

    @property
    def human(self) -> IntentionHuman:
        """The intention human of this world (its clock brought up to date)."""
        route = self.worlds.route
        route.store(self.index)
        human = route.humans[self.index]
        if human is None:
            raise RuntimeError(f"world {self.index} was never reset")
        return human

    @property
    def time(self) -> float:
        """Simulated seconds since the reset."""
        return float(self.worlds.time[self.index])

    def seat_positions(self) -> np.ndarray:
        """(K, 3) the supports' seats in this world's layout."""
        return self.worlds.seats.pos[self.index]

    def object_pose(self) -> Pose:
        """The object's current pose."""
        pos, quat = self.worlds.object_poses(self._row)
        return Pose(pos[0], quat[0])

    def grip_pose(self) -> Pose:
        """The robot hand's grip frame now."""
        pos, quat = self.worlds.site_poses(self._row, self.scene.grip_site)
        return Pose(pos[0], quat[0])

    def object_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """The object's linear and angular velocity (world frame)."""
        w = self.worlds
        w._refresh()
        dof0 = int(self.scene.object_dofs[0])
        qv = host(w, "qvel", self._row, slice(dof0, dof0 + 6))
        angvel = np.empty((1, 3))
        laws.world_angvel(host(w, "xquat", self._row, self.scene.object_body),
                          np.ascontiguousarray(qv[:, 3:]), angvel)
        return qv[0, :3], angvel[0]

    def robot_joints(self) -> tuple[np.ndarray, np.ndarray]:
        """The robot's joint positions and velocities."""
        w, n = self.worlds, self.worlds.n_robot
        return (w._get("qpos")[self.index, :n].astype(float),
                w._get("qvel")[self.index, :n].astype(float))

    def progress(self) -> float:
        """The object's progress along the human's route now."""
        pos, quat = self.worlds.object_poses(self._row)
        return float(self.worlds.progress(self._row, pos, quat)[0])

    def human_grip_reference(self) -> Pose:
        """As :meth:`CarrySim.human_grip_reference`."""
        return grip_reference(self.human, self.grip_in_object)

    def max_lift_n(self) -> float:
        """As :meth:`CarrySim.max_lift_n`."""
        self.worlds._refresh()
        return float(self.worlds.arms.max_lift(self.worlds, self._row)[0])

    # ------------------------------------------------------------------ acting
    def reset(self, start: int, goal: int, rng: np.random.Generator,
              scenario: Scenario | None = None, human: HumanParams | None = None,
              robot_holds: bool = True) -> None:
        """As :meth:`CarrySim.reset` (:meth:`WarpCarryWorlds.reset_world`)."""
        self.worlds.reset_world(self.index, start, goal, rng, scenario, human, robot_holds)

    def command(self, action: np.ndarray) -> RobotCommand:
        """As :meth:`CarrySim.command`."""
        return self._command(action, human=False)

    def human_command(self, action: np.ndarray) -> RobotCommand:
        """As :meth:`CarrySim.human_command`."""
        return self._command(action, human=True)

    def _command(self, action: np.ndarray, human: bool) -> RobotCommand:
        c = self.worlds.commands(self._row, np.asarray(action, float)[None], human=human)
        i = self.index
        return RobotCommand(Pose(c.pos[i], c.quat[i]), float(c.stiffness[i]))

    def _commands(self, cmd: RobotCommand) -> Commands:
        n, i = self.worlds.n, self.index
        out = Commands(np.zeros((n, 3)), np.tile([1.0, 0, 0, 0], (n, 1)), np.zeros(n))
        out.pos[i], out.quat[i], out.stiffness[i] = cmd.target.pos, cmd.target.quat, \
            cmd.stiffness
        return out

    def step(self, cmd: RobotCommand, human_cmd: RobotCommand | None = None) -> CarryStep:
        """As :meth:`CarrySim.step`: this world alone (the others frozen)."""
        active = np.zeros(self.worlds.n, bool)
        active[self.index] = True
        human = None if human_cmd is None else self._commands(human_cmd)
        out = self.worlds.step(self._commands(cmd), active, human,
                               active if human is not None else None)[self.index]
        assert out is not None
        return out
