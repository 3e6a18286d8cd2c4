"""Physical robots of a user's own for the physical suite's tests (``module:Class`` names)."""

from __future__ import annotations

import dataclasses

import numpy as np

from agents.physical import PhysicalAgent
from baselines.physical.admittance import FixedAdmittance
from hri_envs.physics.carry.robot_view import RobotTask


class OwnAdmittance(FixedAdmittance):
    """The built-in fixed admittance under another name, made with the scenario (as a user's
    robot would be): in its own process it must score exactly as the built-in one.
    """

    name = "own-admittance"

    def __init__(self, scenario: str) -> None:
        super().__init__(scenario)


class Privileged(PhysicalAgent):
    """Declares itself a reference: the suite refuses it."""

    name = "claims-privilege"
    privileged = True

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Stands still."""
        return np.zeros(7)


class Nosy(PhysicalAgent):
    """Raises when what it is handed holds anything derived from the intention."""

    name = "nosy"

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def begin_episode(self, task: RobotTask) -> None:
        """Looks for the goal in the task it is given."""
        leaked = [f.name for f in dataclasses.fields(task)
                  if any(w in f.name for w in ("intention", "goal", "human"))]
        if leaked:
            raise RuntimeError(f"the task holds {leaked}")

    def act(self, observation: np.ndarray) -> np.ndarray:
        """A small random push: its own stream."""
        return self.rng.uniform(-0.05, 0.05, 7)


class Breaks(PhysicalAgent):
    """Raises on its third step."""

    name = "breaks"

    def __init__(self) -> None:
        self.steps = 0

    def act(self, observation: np.ndarray) -> np.ndarray:
        """Stands still, then raises."""
        self.steps += 1
        if self.steps == 3:
            raise ValueError("the robot's own bug")
        return np.zeros(7)
