"""hri-envs: physical human-robot cooperation with a hidden human intention.

Importing the package registers the Gymnasium ids (see :mod:`hri_envs.registration`). The
library's exceptions (:mod:`hri_envs.errors`) all derive from :class:`HriEnvsError`. Module
names that moved still import, with a ``DeprecationWarning``, until the next release
(:mod:`hri_envs.moved`; CHANGELOG.md, "Deprecated").
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
from hri_envs.moved import Scattered
from hri_envs.moved import register as register_moved
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

#: Old module names and where their names are now (named by strings: importing hri_envs
#: imports none of them).
MOVED = {
    "hri_envs.task.humans": Scattered(
        "hri_envs.humans.scripted",
        {"HANGER_PREFERENCES": "hri_envs.task.scenarios.hanger:PREFERENCES",
         "HANGER_DEFAULT_PREFERENCE": "hri_envs.task.scenarios.hanger:DEFAULT_PREFERENCE",
         "WHEEL_PREFERENCES": "hri_envs.task.scenarios.wheel:PREFERENCES"},
        ("HANGER_DEFAULT_PREFERENCE", "HANGER_PREFERENCES", "WHEEL_PREFERENCES",
         "PreferredActions", "ScriptedHuman", "boltzmann_human", "check_probability",
         "preference_human", "preferences_for")),
}
register_moved(MOVED)
