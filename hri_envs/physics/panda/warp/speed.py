"""Speed of the physics on MuJoCo Warp: world-steps per second and real-time factor.

Used by ``hri-bench speed --physics``. The workload is the C backend's
(:func:`hri_envs.physics.panda.speed.physics_realtime_factor`): the robot carries the object from
support A's mounting point towards B's with the human following, in every world, with
everything on (contacts, the wrist and handle sensors, the controller, the seat law, the
human's arm, the IK reference from mink-warp at 25 Hz). A *world-step* is one 2 ms physics
step of one world; the real-time factor is the simulated seconds of all worlds per wall
second.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from hri_envs.physics.panda.warp.worlds import WarpWorlds
from hri_envs.task.graph import WAIT, TaskGraph

__all__ = ["WorldSpeed", "warp_world_steps"]


class WorldSpeed(NamedTuple):
    """One measurement: ``n_worlds`` worlds, ``world_steps`` physics steps in all.

    Attributes:
        n_worlds: Worlds stepped together.
        world_steps: Physics steps summed over the worlds.
        wall_s: Wall seconds of the timed control periods.
        dt: The physics step [s].
        device: Warp's device.
        setup_s: Wall seconds to build the worlds, place them and run a first control period
            (the first run on a machine compiles Warp's kernels here; later runs load them
            from the kernel cache).
    """

    n_worlds: int
    world_steps: int
    wall_s: float
    dt: float
    device: str
    setup_s: float

    @property
    def world_steps_per_s(self) -> float:
        """Physics steps of all worlds per wall second."""
        return self.world_steps / self.wall_s

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds of all worlds per wall second."""
        return self.world_steps_per_s * self.dt


def warp_world_steps(n_worlds: int, g: TaskGraph, periods: int = 25,
                     device: str | None = None) -> WorldSpeed:
    """Time ``periods`` control periods of ``n_worlds`` worlds carrying the object.

    The worlds are copies of one placed world (a reset places the arm by a C IK solve, which
    would take longer than the measurement). The clock runs over the ``periods`` periods
    after the first one.
    """
    t0 = time.perf_counter()
    worlds = WarpWorlds(g, n_worlds, device=device)
    s = int(g.mounting_state[0])
    worlds.reset_world(0, 0, state=s)
    if n_worlds > 1:
        worlds.copy_world(0, np.arange(1, n_worlds))
    for i in range(n_worlds):
        worlds.begin_step(i, s, g.move_over(1), WAIT)
    worlds.run_period()
    setup = time.perf_counter() - t0
    t1 = time.perf_counter()
    for _ in range(periods):
        worlds.run_period()
    wall = time.perf_counter() - t1
    return WorldSpeed(n_worlds, n_worlds * periods * worlds.k, wall, worlds.dt, worlds.device,
                      setup)
