"""hri-envs: physical human-robot cooperation with a hidden human intention.

Importing the package registers the Gymnasium ids (see :mod:`hri_envs.registration`). The
library's exceptions (:mod:`hri_envs.errors`) all derive from :class:`HriEnvsError`.
"""

from hri_envs.errors import (
    ActionError,
    BackendUnavailableError,
    ConfigError,
    DisplayUnavailableError,
    HriEnvsError,
    LearnerStateError,
    MissingExtraError,
    PhysicsFault,
    ResetNeeded,
)
from hri_envs.registration import register_envs
from hri_envs.task import TaskGraph, build_graph, hanger_scenario, wheel_scenario

__version__ = "0.1.0"

__all__ = [
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "DisplayUnavailableError",
    "HriEnvsError",
    "LearnerStateError",
    "MissingExtraError",
    "PhysicsFault",
    "ResetNeeded",
    "TaskGraph",
    "__version__",
    "build_graph",
    "hanger_scenario",
    "wheel_scenario",
]

register_envs()
