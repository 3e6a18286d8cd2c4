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
MOVED: dict[str, str | Scattered] = {
    "hri_envs.task.humans": Scattered(
        "hri_envs.humans.scripted",
        {"HANGER_PREFERENCES": "hri_envs.task.scenarios.hanger:PREFERENCES",
         "HANGER_DEFAULT_PREFERENCE": "hri_envs.task.scenarios.hanger:DEFAULT_PREFERENCE",
         "WHEEL_PREFERENCES": "hri_envs.task.scenarios.wheel:PREFERENCES"},
        ("HANGER_DEFAULT_PREFERENCE", "HANGER_PREFERENCES", "WHEEL_PREFERENCES",
         "PreferredActions", "ScriptedHuman", "boltzmann_human", "check_probability",
         "preference_human", "preferences_for")),
    # The physics by env family (hri_envs/physics/__init__.py). The old modules scene and
    # carry are packages now: their names are forwarded by the packages themselves.
    "hri_envs.physics.mjwarp": "hri_envs.physics.scene.warp",
    "hri_envs.physics.arm_control": "hri_envs.physics.carry.human.arm_control",
    "hri_envs.physics.assets": "hri_envs.physics.scene.assets",
    "hri_envs.physics.batch": "hri_envs.physics.panda.batch",
    "hri_envs.physics.body": "hri_envs.physics.carry.human.body",
    "hri_envs.physics.camera": "hri_envs.physics.scene.camera",
    "hri_envs.physics.carry_faults": "hri_envs.physics.carry.faults",
    "hri_envs.physics.carry_periods": "hri_envs.physics.carry.periods",
    "hri_envs.physics.carry_reward": "hri_envs.physics.carry.reward",
    "hri_envs.physics.carry_simulation": "hri_envs.physics.carry.simulation",
    "hri_envs.physics.carry_stages": "hri_envs.physics.carry.stages",
    "hri_envs.physics.carry_types": "hri_envs.physics.carry.types",
    "hri_envs.physics.contacts": "hri_envs.physics.scene.contacts",
    "hri_envs.physics.continuous": "hri_envs.physics.carry.env",
    "hri_envs.physics.continuous_parallel": "hri_envs.physics.carry.parallel",
    "hri_envs.physics.controller": "hri_envs.physics.scene.controller",
    "hri_envs.physics.design": "hri_envs.physics.scene.design",
    "hri_envs.physics.episode": "hri_envs.physics.panda.episode",
    "hri_envs.physics.families": "hri_envs.physics.carry.human.families",
    "hri_envs.physics.human": "hri_envs.physics.panda.human",
    "hri_envs.physics.human_arm": "hri_envs.physics.panda.human_arm",
    "hri_envs.physics.human_laws": "hri_envs.physics.carry.human.laws",
    "hri_envs.physics.ik": "hri_envs.physics.scene.ik",
    "hri_envs.physics.intention": "hri_envs.physics.carry.human.intention",
    "hri_envs.physics.interaction": "hri_envs.physics.carry.interaction",
    "hri_envs.physics.jit": "hri_envs.physics.scene.jit",
    "hri_envs.physics.kinematics": "hri_envs.physics.scene.kinematics",
    "hri_envs.physics.lawmath": "hri_envs.physics.scene.lawmath",
    "hri_envs.physics.laws": "hri_envs.physics.scene.laws",
    "hri_envs.physics.mjc": "hri_envs.physics.carry.mjc",
    "hri_envs.physics.mjwarp.batch": "hri_envs.physics.panda.warp.batch",
    "hri_envs.physics.mjwarp.batchmath": "hri_envs.physics.scene.warp.batchmath",
    "hri_envs.physics.mjwarp.build": "hri_envs.physics.panda.warp.build",
    "hri_envs.physics.mjwarp.carry": "hri_envs.physics.carry.warp.worlds",
    "hri_envs.physics.mjwarp.carry_human": "hri_envs.physics.carry.warp.human",
    "hri_envs.physics.mjwarp.carry_sim": "hri_envs.physics.carry.warp.sim",
    "hri_envs.physics.mjwarp.carry_vector": "hri_envs.physics.carry.warp.vector",
    "hri_envs.physics.mjwarp.control": "hri_envs.physics.scene.warp.control",
    "hri_envs.physics.mjwarp.device": "hri_envs.physics.scene.warp.device",
    "hri_envs.physics.mjwarp.episode": "hri_envs.physics.panda.warp.episode",
    "hri_envs.physics.mjwarp.events": "hri_envs.physics.panda.warp.events",
    "hri_envs.physics.mjwarp.handout": "hri_envs.physics.scene.warp.handout",
    "hri_envs.physics.mjwarp.ik": "hri_envs.physics.scene.warp.ik",
    "hri_envs.physics.mjwarp.model": "hri_envs.physics.scene.warp.model",
    "hri_envs.physics.mjwarp.period": "hri_envs.physics.panda.warp.period",
    "hri_envs.physics.mjwarp.speed": "hri_envs.physics.panda.warp.speed",
    "hri_envs.physics.mjwarp.vector": "hri_envs.physics.panda.warp.vector",
    "hri_envs.physics.mjwarp.worlds": "hri_envs.physics.panda.warp.worlds",
    "hri_envs.physics.muscles": "hri_envs.physics.carry.human.muscles",
    "hri_envs.physics.observer": "hri_envs.physics.scene.observer",
    "hri_envs.physics.options": "hri_envs.physics.panda.options",
    "hri_envs.physics.population": "hri_envs.physics.carry.human.population",
    "hri_envs.physics.population_build": "hri_envs.physics.carry.human.population_build",
    "hri_envs.physics.probe": "hri_envs.physics.carry.human.probe",
    "hri_envs.physics.rendering": "hri_envs.physics.scene.rendering",
    "hri_envs.physics.robot_view": "hri_envs.physics.carry.robot_view",
    "hri_envs.physics.seats": "hri_envs.physics.scene.seats",
    "hri_envs.physics.sensing": "hri_envs.physics.scene.sensing",
    "hri_envs.physics.shapes": "hri_envs.physics.scene.shapes",
    "hri_envs.physics.sim": "hri_envs.physics.panda.sim",
    "hri_envs.physics.speed": "hri_envs.physics.panda.speed",
    "hri_envs.physics.whole_arm": "hri_envs.physics.carry.human.whole_arm",
}
register_moved(MOVED)
