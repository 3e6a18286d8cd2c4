"""Speed of the physics backend: real-time factor and wall seconds per abstract step.

Used by ``benchmarks/physics_speed.py``. The first two measurements run one scenario on one
core: the Panda, the object welded to its hand and the human's, the control loop at 125 Hz
over 2 ms physics steps and the mink IK at 25 Hz. The third runs whole env steps (random
valid robot actions against the scripted human) in Gymnasium's ``AsyncVectorEnv``, one
process per env.
"""

from __future__ import annotations

import functools
import time
from typing import NamedTuple

import numpy as np

from hri_envs.physics.panda.sim import PandaSim
from hri_envs.task.graph import TOGGLE, WAIT, TaskGraph

__all__ = ["SpeedResult", "async_steps_per_second", "physics_realtime_factor",
           "seconds_per_abstract_step"]


class SpeedResult(NamedTuple):
    """Simulated and wall seconds of a measurement, and how many abstract steps it ran.

    ``cpu_seconds`` is this process's CPU time over the same span (0 where not measured):
    on a loaded machine it shows what one core would do alone.
    """

    sim_seconds: float
    wall_seconds: float
    abstract_steps: int
    cpu_seconds: float = 0.0

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall second."""
        return self.sim_seconds / self.wall_seconds

    @property
    def cpu_realtime_factor(self) -> float:
        """Simulated seconds per CPU second of this process (nan if not measured)."""
        return self.sim_seconds / self.cpu_seconds if self.cpu_seconds > 0 else float("nan")

    @property
    def seconds_per_step(self) -> float:
        """Wall seconds per abstract step."""
        return self.wall_seconds / max(self.abstract_steps, 1)


def physics_realtime_factor(g: TaskGraph, repeats: int = 3) -> SpeedResult:
    """Real-time factor of the robot tracking straight lines with the object in hand.

    The robot carries the object back and forth between the mounting points of supports
    A and B (column moves, the human following passively), ``repeats`` times, on ``g``.
    """
    sim = PandaSim(g)
    start = int(g.mounting_state[0])
    s = sim.reset(0, state=start)
    over_b, over_a = g.move_over(1), g.move_over(0)
    sim_t = wall = cpu = 0.0
    steps = 0
    for _ in range(repeats):
        for action in (over_b, over_a):
            t0, c0 = time.perf_counter(), time.process_time()
            res = sim.step(s, action, WAIT)
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
            sim_t += res.duration
            steps += 1
            s = res.state
    return SpeedResult(sim_t, wall, steps, cpu)


def seconds_per_abstract_step(g: TaskGraph, episodes: int = 2) -> SpeedResult:
    """Wall seconds per abstract step over whole episodes (B to A and back to B).

    The human follows the user study's most frequent preference and the robot waits
    except for grasping and letting go: the slowest case, since the human alone drives.
    """
    from hri_envs.humans.scripted import preference_human

    human = preference_human(g)
    sim = PandaSim(g)
    sim_t = wall = cpu = 0.0
    steps = 0
    for e in range(episodes):
        start, goal = (1, 0) if e % 2 == 0 else (0, 1)
        s = sim.reset(start)
        for _ in range(40):
            a_h = int(human.preferred_action(np.array(s), np.array(start), np.array(goal)))
            a_r = TOGGLE if g.support[s] >= 0 and a_h == TOGGLE else WAIT
            t0, c0 = time.perf_counter(), time.process_time()
            res = sim.step(s, a_r, a_h)
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
            sim_t += res.duration
            steps += 1
            s = res.state
            if g.support[s] == goal and g.grasp[s] == 0:
                break
    return SpeedResult(sim_t, wall, steps, cpu)


def async_steps_per_second(g: TaskGraph, num_envs: int = 2, seconds: float = 30.0,
                           seed: int = 0) -> SpeedResult:
    """Abstract steps of ``num_envs`` Panda envs in an ``AsyncVectorEnv``, over ``seconds``.

    Each worker holds a :class:`~hri_envs.envs.robot.RobotEnv` with ``backend="mujoco"``
    (what ``gym.make_vec(<the scenario's Panda id>, num_envs, vectorization_mode="async")``
    makes, without Gymnasium's checking wrappers); every env plays random valid robot
    actions (from the observation's action mask, seeded) and resets itself when its episode
    ends. The clock starts after the first reset (the
    workers' start-up and the scene compilation are not counted); ``abstract_steps`` is the
    sum over the envs, ``sim_seconds`` their simulated time summed.
    """
    from gymnasium.vector import AsyncVectorEnv

    from hri_envs.envs.robot import RobotEnv

    envs = AsyncVectorEnv([functools.partial(RobotEnv, g.name, backend="mujoco")] * num_envs)
    try:
        rng = np.random.default_rng(seed)
        obs, _ = envs.reset(seed=seed)
        steps, sim_t = 0, 0.0
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            mask = np.asarray(obs["action_mask"], dtype=bool)
            actions = np.array([rng.choice(np.flatnonzero(row)) for row in mask])
            obs, _, _, _, info = envs.step(actions)
            steps += num_envs
            sim_t += float(np.sum(info.get("duration_s", 0.0)))
        wall = time.perf_counter() - t0
    finally:
        envs.close()
    return SpeedResult(sim_t, wall, steps)
