"""Humans of the human protocol that only the tests define."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from hri_envs.humans import Human, preference_human
from hri_envs.task.actions import TAKE_OFF, WAIT
from hri_envs.task.graph import TaskGraph


class Copycat(Human):
    """A human who keeps state: it repeats the robot's last motion whenever that motion is
    valid in the current state, and otherwise does what its scripted preference does (so
    that episodes still end).
    """

    name = "copycat"

    def __init__(self, graph: TaskGraph) -> None:
        self.graph = graph
        self.script = preference_human(graph)
        self.last_robot = WAIT
        self.copied = 0  # how often it copied the robot, over all its episodes

    def begin_episode(self, start: int, intention: int) -> None:
        self.last_robot = WAIT

    def act(self, observation: Mapping[str, Any]) -> int:
        state = int(observation["state"])
        if self.last_robot >= TAKE_OFF and observation["action_mask"][self.last_robot]:
            self.copied += 1
            return self.last_robot
        return int(self.script.preferred_action(np.array(state),
                                                np.array(observation["start"]),
                                                np.array(observation["intention"])))

    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        self.last_robot = robot_action

    def expected(self, last_robot: int, state: int, start: int, intention: int) -> int:
        """What it does in ``state`` after the robot's ``last_robot`` (for the tests)."""
        if last_robot >= TAKE_OFF and self.graph.valid[state, last_robot]:
            return last_robot
        return int(self.script.preferred_action(np.array(state), np.array(start),
                                                np.array(intention)))
