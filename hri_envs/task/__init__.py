"""The task model: scenario geometry and registry, the abstract transition graph, features,
the episode rules and the planning math the scripted humans need.
"""

from hri_envs.task.features import initial_theta, state_features
from hri_envs.task.geometry import Scenario, Support
from hri_envs.task.graph import PUT_ON, ROTATE, TAKE_OFF, TOGGLE, WAIT, TaskGraph, build_graph
from hri_envs.task.scenarios.hanger import geometry as hanger_scenario
from hri_envs.task.scenarios.wheel import geometry as wheel_scenario
from hri_envs.task.scenarios.wheel import sample_layout as sample_wheel_layout

__all__ = [
    "PUT_ON",
    "ROTATE",
    "TAKE_OFF",
    "TOGGLE",
    "WAIT",
    "Scenario",
    "Support",
    "TaskGraph",
    "build_graph",
    "hanger_scenario",
    "initial_theta",
    "sample_wheel_layout",
    "state_features",
    "wheel_scenario",
]
