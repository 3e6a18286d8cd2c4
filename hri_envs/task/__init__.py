"""The task model: scenario geometry, the abstract transition graph, features, scripted humans."""

from hri_envs.task.features import initial_theta, state_features
from hri_envs.task.geometry import (
    Scenario,
    Support,
    hanger_scenario,
    sample_wheel_layout,
    wheel_scenario,
)
from hri_envs.task.graph import PUT_ON, ROTATE, TAKE_OFF, TOGGLE, WAIT, TaskGraph, build_graph

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
