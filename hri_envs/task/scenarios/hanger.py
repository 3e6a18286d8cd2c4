"""The clothes hanger (the paper's user study, Sect. 5.1): peg A, rail points B and C.

24 abstract states. A scripted human's preference is the order in which it changes column
("over"), height and orientation between the peg and the rail: 6 orders each way, 36
preferences; rail-to-rail moves (B↔C) have one natural path.
"""

from __future__ import annotations

import itertools

import numpy as np

from hri_envs.task.geometry import Scenario, Support, unit_quaternion
from hri_envs.task.scenarios.spec import Op, ScenarioSpec, ScheduleRow, natural_route

__all__ = ["DEFAULT_PREFERENCE", "PREFERENCES", "SPEC", "TABLE2", "geometry"]

_Q_PEG = unit_quaternion((0.05, -0.7, -0.05, -0.7))
_Q_RAIL = unit_quaternion((0.5, -0.5, -0.5, -0.5))
_PEG_STEPS = ("down", "over", "rotate")
_RAIL_STEPS = ("over", "up", "rotate")
#: The 36 preferences, "to-peg order/to-rail order", e.g. "down-over-rotate/over-rotate-up".
PREFERENCES: tuple[str, ...] = tuple(
    "-".join(p) + "/" + "-".join(r)
    for p in itertools.permutations(_PEG_STEPS)
    for r in itertools.permutations(_RAIL_STEPS)
)
#: The user study's most frequent preference (paper Sect. 6.3, Fig. 8).
DEFAULT_PREFERENCE = "down-over-rotate/over-rotate-up"
#: The user study's episodes (paper Table 2): (start, goal, turns back halfway).
TABLE2: tuple[ScheduleRow, ...] = (
    ("B", "A", False), ("A", "B", False), ("B", "A", False), ("A", "C", False),
    ("C", "B", False), ("B", "C", False), ("C", "A", False), ("A", "B", True),
    ("A", "B", False),
)


def geometry() -> Scenario:
    """The clothes-hanger scenario: peg A, rail points B and C (24 abstract states)."""
    supports = (
        Support("A", np.array([0.71, -0.525, 0.535]), 0, np.array([0.6787, -0.3072, 0.585])),
        Support("B", np.array([0.46, 0.61, 0.82]), 1, np.array([0.46, 0.39, 0.87])),
        Support("C", np.array([0.20, 0.625, 0.82]), 1, np.array([0.20, 0.405, 0.87])),
    )
    return Scenario(
        name="hanger",
        object_name="clothes hanger",
        supports=supports,
        orientations=np.stack([_Q_PEG, _Q_RAIL]),
        orientation_names=("peg-facing", "rail-facing"),
        comfort_height=0.585,
        object_radius=0.2,
    )


_STEP_WORDS = {"down": "move down", "up": "move up", "over": "move over", "rotate": "rotate"}


def wording(preference: str) -> str | None:
    """How a preference reads to a participant: its order of steps to the peg and to the
    rail (None for a name without the "/" of the hanger's preferences).
    """
    if "/" not in preference:
        return None
    to_peg, to_rail = (part.split("-") for part in preference.split("/"))

    def order(steps: list[str]) -> str:
        return ", then ".join(_STEP_WORDS.get(s, s) for s in steps)

    return (f"Between the rail and the peg, carry it this way: to the peg A, "
            f"{order(to_peg)}; to the rail (B, C), {order(to_rail)}.")


def route(scenario: Scenario, preference: str, start: int, goal: int) -> list[Op]:
    """Between the peg and the rail the preference's order; along the rail the natural one."""
    natural = natural_route(scenario, goal)
    to_peg, to_rail = (part.split("-") for part in preference.split("/"))
    rail = scenario.supports[1].orientation
    peg = [k for k, s in enumerate(scenario.supports) if s.orientation != rail]
    if (goal in peg) == (start in peg):
        return natural
    over, height, rotate = natural
    table = {"over": over, "rotate": rotate, "down": height, "up": height}
    return [table[step] for step in (to_peg if goal in peg else to_rail)]


SPEC = ScenarioSpec(
    "hanger", geometry, r0=-0.33, gamma=0.9, episodes=8, preferences=PREFERENCES,
    default_preference=DEFAULT_PREFERENCE, route=route, n_actions=10,
    gym_id="hri_envs/Hanger-v0", panda_id="hri_envs/HangerPanda-v0",
    continuous_id="hri_envs/HangerPandaContinuous-v0",
    pettingzoo_module="hri_envs.hanger_v0",
    physics_design="hri_envs.physics.scene.design:hanger_design", schedules={"table2": TABLE2},
    preference_wording=wording,
)
