"""A third scenario that lives only in the tests: a box carried between a table, a shelf and
a cart. It proves that a scenario is data (docs/scenarios.md): registering this module's
spec is all it takes for the graph envs, the Learner and a study to run it."""

from __future__ import annotations

import numpy as np

from hri_envs.task.geometry import Scenario, Support
from hri_envs.task.scenarios import Op, ScenarioSpec, natural_route, register_scenario

_FLAT = np.array([1.0, 0.0, 0.0, 0.0])
_TURNED = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # 90° about z


def geometry() -> Scenario:
    """Table A and cart C take the box flat, shelf B turned; mounting points 10 cm above."""
    supports = (
        Support("A", np.array([0.0, 0.0, 0.7]), 0, np.array([0.0, 0.25, 0.8])),
        Support("B", np.array([0.9, 0.1, 1.1]), 1, np.array([0.9, 0.35, 1.2])),
        Support("C", np.array([0.4, -0.6, 0.5]), 0, np.array([0.4, -0.35, 0.6])),
    )
    return Scenario(name="box", object_name="box", supports=supports,
                    orientations=np.stack([_FLAT, _TURNED]), orientation_names=("flat", "turned"),
                    comfort_height=0.9, object_radius=0.15)


def route(scenario: Scenario, preference: str, start: int, goal: int) -> list[Op]:
    """"over-first": the natural route; "height-first": change height before moving over."""
    over, height, rotate = natural_route(scenario, goal)
    return [over, height, rotate] if preference == "over-first" else [height, over, rotate]


SPEC = ScenarioSpec("box", geometry, r0=-0.3, gamma=0.8, episodes=6,
                    preferences=("over-first", "height-first"), default_preference="over-first",
                    route=route, n_actions=5 + 3 + 4, gym_id="hri_envs/Box-v0")


def register() -> None:
    """Register the scenario and its Gymnasium id (both idempotent)."""
    from hri_envs.registration import register_envs

    register_scenario(SPEC)
    register_envs()
