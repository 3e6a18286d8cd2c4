"""Speed of the physics backend: real-time factor and wall seconds per abstract step.

Used by ``benchmarks/physics_speed.py``. Both measurements run the hanger scenario on one
core: the Panda (7 torque-controlled joints), the object welded to its hand, the Cartesian
impedance controller at every 2 ms physics step and the mink IK at 50 Hz.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from hri_envs.physics.sim import PandaSim
from hri_envs.task.graph import TOGGLE, WAIT, TaskGraph

__all__ = ["SpeedResult", "physics_realtime_factor", "seconds_per_abstract_step"]


class SpeedResult(NamedTuple):
    """Simulated and wall seconds of a measurement, and how many abstract steps it ran."""

    sim_seconds: float
    wall_seconds: float
    abstract_steps: int

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall second."""
        return self.sim_seconds / self.wall_seconds

    @property
    def seconds_per_step(self) -> float:
        """Wall seconds per abstract step."""
        return self.wall_seconds / max(self.abstract_steps, 1)


def _graph(scenario: str) -> TaskGraph:
    from hri_envs.envs.config import scenario_graph

    return scenario_graph(scenario)


def physics_realtime_factor(scenario: str = "hanger", repeats: int = 3) -> SpeedResult:
    """Real-time factor of the robot tracking straight lines with the object in hand.

    The robot carries the object back and forth between the mounting points of supports
    A and B (column moves, the human following passively), ``repeats`` times.
    """
    g = _graph(scenario)
    sim = PandaSim(g)
    start = int(g.mounting_state[0])
    s = sim.reset(0, state=start)
    over_b, over_a = g.move_over(1), g.move_over(0)
    sim_t = wall = 0.0
    steps = 0
    for _ in range(repeats):
        for action in (over_b, over_a):
            t0 = time.perf_counter()
            res = sim.step(s, action, WAIT)
            wall += time.perf_counter() - t0
            sim_t += res.duration
            steps += 1
            s = res.state
    return SpeedResult(sim_t, wall, steps)


def seconds_per_abstract_step(scenario: str = "hanger", episodes: int = 2) -> SpeedResult:
    """Wall seconds per abstract step over whole episodes (B to A and back to B).

    The human follows the user study's most frequent preference and the robot waits
    except for grasping and letting go: the slowest case, since the human alone drives.
    """
    from hri_envs.task.humans import preference_human

    g = _graph(scenario)
    human = preference_human(g)
    sim = PandaSim(g)
    sim_t = wall = 0.0
    steps = 0
    for e in range(episodes):
        start, goal = (1, 0) if e % 2 == 0 else (0, 1)
        s = sim.reset(start)
        for _ in range(40):
            a_h = int(human.preferred_action(np.array(s), np.array(start), np.array(goal)))
            a_r = TOGGLE if g.support[s] >= 0 and a_h == TOGGLE else WAIT
            t0 = time.perf_counter()
            res = sim.step(s, a_r, a_h)
            wall += time.perf_counter() - t0
            sim_t += res.duration
            steps += 1
            s = res.state
            if g.support[s] == goal and g.grasp[s] == 0:
                break
    return SpeedResult(sim_t, wall, steps)
