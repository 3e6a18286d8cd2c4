"""The physics options of the mujoco backend (``physics={...}``) and their presets.

The keys are listed once, here (:data:`PHYSICS_PARAMETERS`, :data:`OPTION_KEYS`), and
checked by :func:`check_options` (which the envs reach through the backend registry,
:func:`hri_envs.envs.config.check_physics_options`); :class:`PhysicsSettings` turns checked
options into the parameters of each episode.

=====================  =======  ==========================================================
key                    unit     meaning (default: the scenario's design, docs/physics.md)
=====================  =======  ==========================================================
``human_stiffness``    N/m      the human's arm stiffness (rotational one scaled alike)
``human_force``        N        the most force the human applies per axis (torque alike)
``human_noise``        N        std of the human's band-limited force noise
``human_delay_s``      s        the human's reaction delay before a reach starts
``human_mass``         kg       effective mass of the human's forearm (the hand: +0.1 kg)
``sensor_noise_n``     N        std of the wrist sensor's white noise per control step
``sensor_bias_n``      N        magnitude of its constant bias (random direction)
``sensor_delay_s``     s        its delay
``object_mass``        kg       the object's true mass (the robot compensates the nominal)
``hold_force``         N        the supports' detent force (pull needed to take off)
``human_grip_force``   N        how hard the human's thumb squeezes the handle
``handle_noise_n``     N        std of the handle's touch sensor reading
=====================  =======  ==========================================================

``attempt_invalid`` (bool, default False): the robot physically tries an action the graph
calls invalid instead of refusing it (:meth:`hri_envs.physics.panda.sim.PandaSim.step`).
``preset`` names a set of values (the scenario design's ``presets``); explicit keys override
it.
``randomize`` maps keys to ``(low, high)`` ranges drawn uniformly at each episode's reset
(domain randomisation).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.humans.spec import HumanBody
from hri_envs.physics.scene.camera import check_camera
from hri_envs.physics.scene.design import PRESET_NAMES, PhysicsDesign

__all__ = ["BODY_KEYS", "BODY_PRESETS", "OPTION_KEYS", "PHYSICS_MAXIMA", "PHYSICS_PARAMETERS",
           "VIDEO_SUFFIXES", "PhysicsParams", "PhysicsSettings", "body_options",
           "check_options", "prepare_video_path"]

#: The numeric physics options: key -> (unit, must be > 0 rather than >= 0, meaning).
#: Their defaults are the scenario's design (docs/physics.md).
PHYSICS_PARAMETERS: dict[str, tuple[str, bool, str]] = {
    "human_stiffness": ("N/m", True, "the human's arm stiffness"),
    "human_force": ("N", True, "the most force the human applies"),
    "human_noise": ("N", False, "std of the human's force noise"),
    "human_delay_s": ("s", False, "the human's reaction delay"),
    "human_mass": ("kg", True, "effective mass of the human's embodied forearm"),
    "sensor_noise_n": ("N", False, "std of the wrist sensor's noise per control step"),
    "sensor_bias_n": ("N", False, "magnitude of the wrist sensor's bias"),
    "sensor_delay_s": ("s", False, "delay of the wrist sensor"),
    "object_mass": ("kg", True, "the object's true mass"),
    "hold_force": ("N", False, "the supports' detent force"),
    "human_grip_force": ("N", True, "how hard the human's thumb squeezes the handle"),
    "handle_noise_n": ("N", False, "std of the handle's touch sensor reading"),
}

#: Upper bounds of the physics options that have one: a thumb squeezing harder than this
#: goes through the handle's contact at the 2 ms physics step and misreads.
PHYSICS_MAXIMA: dict[str, float] = {"human_grip_force": 12.0}

#: The suffixes ``video_path`` may end in: ".gif" (written by imageio with Pillow) and the
#: video containers of imageio-ffmpeg (both installed by the ``mujoco`` extra).
VIDEO_SUFFIXES: tuple[str, ...] = (".gif", ".mp4", ".mkv", ".avi", ".mov", ".webm")

#: Every key ``physics={...}`` accepts.
OPTION_KEYS: tuple[str, ...] = ("video_path", "video_fps", "preset", "randomize",
                                "attempt_invalid", "camera", *PHYSICS_PARAMETERS)


#: The options that describe the physical human: what a
#: :class:`~hri_envs.humans.spec.HumanBody` may set on these backends (:func:`body_options`).
BODY_KEYS: tuple[str, ...] = tuple(k for k in PHYSICS_PARAMETERS if k.startswith("human_"))
#: The presets that describe the physical human (the others, "noisy-sensor", the sensor).
BODY_PRESETS: tuple[str, ...] = tuple(p for p in PRESET_NAMES if p.endswith("-human"))


def body_options(body: HumanBody) -> dict[str, Any]:
    """The physics options of a :class:`~hri_envs.humans.spec.HumanBody` (a
    ``HumanSpec(body=...)`` of the Panda envs): its ``preset`` as ``"preset"`` and its
    params, checked as :func:`check_options` checks them.

    Raises:
        ConfigError: (``field="human"``) A preset not in :data:`BODY_PRESETS`, a param not
            in :data:`BODY_KEYS`, or a value not allowed.
    """
    if body.preset is not None and body.preset not in BODY_PRESETS:
        raise ConfigError(f"unknown body preset {body.preset!r} of the Panda backends' human; "
                          f"allowed: {', '.join(BODY_PRESETS)}", field="human")
    unknown = sorted(map(repr, {k for k, _ in body.params} - set(BODY_KEYS)))
    if unknown:
        raise ConfigError(f"unknown body param(s) {', '.join(unknown)} of the Panda backends' "
                          f"human; allowed: {', '.join(BODY_KEYS)}", field="human")
    for key, value in body.params:
        _check_parameter(key, value, f"the body's {key!r}", field="human")
    return body.values()


def check_options(physics: Mapping[str, Any]) -> dict[str, Any]:
    """Validate ``physics`` options; a :class:`ConfigError` naming the key otherwise.

    The keys are :data:`OPTION_KEYS`: ``video_path`` (a ``str`` or path ending in one of
    :data:`VIDEO_SUFFIXES`, with at most an ``{episode}`` field; every suffix but ".gif"
    needs imageio-ffmpeg), ``video_fps`` (a positive number), ``camera`` (the pictures'
    camera: :func:`~hri_envs.physics.scene.camera.check_camera`), ``preset`` (one of the
    designs' presets), ``attempt_invalid`` (a bool), ``randomize`` (a mapping of numeric keys
    to ``(low, high)``) and the numeric :data:`PHYSICS_PARAMETERS`. Whether the video's
    folder can be written is checked when the episode is built
    (:func:`prepare_video_path`), so no episode is simulated for a video that cannot be
    saved.

    Raises:
        ConfigError: (``field="physics"``) An unknown key or a value not allowed.
        MissingExtraError: A video suffix whose writer is not installed.
    """
    unknown = sorted(map(repr, set(physics) - set(OPTION_KEYS)))
    if unknown:
        raise ConfigError(f"unknown physics option(s) {', '.join(unknown)}; "
                          f"allowed: {', '.join(OPTION_KEYS)}", field="physics")
    fps = physics.get("video_fps", 10.0)
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not fps > 0:
        raise ConfigError(f"physics option 'video_fps' must be a positive number, got {fps!r}",
                          field="physics")
    if physics.get("video_path") is not None:
        _video_name(physics["video_path"])
    check_camera(physics.get("camera"), field="physics")
    attempt = physics.get("attempt_invalid", False)
    if not isinstance(attempt, bool | np.bool_):
        raise ConfigError(f"physics option 'attempt_invalid' must be True or False, got "
                          f"{attempt!r}", field="physics")
    if physics.get("preset") is not None and (not isinstance(physics["preset"], str)
                                              or physics["preset"] not in PRESET_NAMES):
        raise ConfigError(f"unknown physics preset {physics['preset']!r}; allowed: "
                          f"{', '.join(PRESET_NAMES)}", field="physics")
    for key in PHYSICS_PARAMETERS:
        if key in physics:
            _check_parameter(key, physics[key], f"physics option {key!r}")
    randomize = physics.get("randomize")
    if randomize is not None:
        if not isinstance(randomize, Mapping):
            raise ConfigError(f"physics option 'randomize' must map option names to (low, "
                              f"high) ranges, got {randomize!r}", field="physics")
        bad = sorted(set(randomize) - set(PHYSICS_PARAMETERS))
        if bad:
            raise ConfigError(f"cannot randomize {', '.join(map(repr, bad))}; allowed: "
                              f"{', '.join(PHYSICS_PARAMETERS)}", field="physics")
        for key, span in randomize.items():
            if not isinstance(span, tuple | list) or len(span) != 2:
                raise ConfigError(f"randomize[{key!r}] must be a (low, high) pair, got "
                                  f"{span!r}", field="physics")
            lo = _check_parameter(key, span[0], f"randomize[{key!r}] low")
            hi = _check_parameter(key, span[1], f"randomize[{key!r}] high")
            if lo > hi:
                raise ConfigError(f"randomize[{key!r}] must have low <= high, got {span!r}",
                                  field="physics")
    return dict(physics)


def _video_name(path: Any) -> str:
    """``video_path`` as a ``str`` if its type, ``{episode}`` field and suffix are allowed."""
    if not isinstance(path, str | os.PathLike):
        raise ConfigError(f"physics option 'video_path' must be a file name (str or path), "
                          f"got {path!r}", field="physics")
    name = os.fspath(path)
    if not isinstance(name, str):  # a bytes path
        raise ConfigError(f"physics option 'video_path' must be a str path, got {path!r}",
                          field="physics")
    try:
        formatted = name.format(episode=1)
    except (KeyError, IndexError, ValueError, AttributeError, TypeError) as exc:
        raise ConfigError(f"physics option 'video_path' may hold one field, {{episode}} (write "
                          f"other braces as {{{{ and }}}}), got {name!r} ({exc!r})",
                          field="physics") from None
    suffix = Path(formatted).suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise ConfigError(f"physics option 'video_path' must end in one of "
                          f"{', '.join(VIDEO_SUFFIXES)}, got {name!r}", field="physics")
    MissingExtraError.require(["imageio"] + (["imageio_ffmpeg"] if suffix != ".gif" else []),
                              f"writing {suffix} videos")
    return name


def prepare_video_path(path: Any) -> str:
    """Check ``video_path`` (as :func:`check_options` does) and that its folder can be
    written, creating the folder (as writing the first video would); return it as a ``str``.

    Raises:
        ConfigError: (``field="physics"``) The path is not allowed, or its folder cannot be
            created or written.
    """
    name = _video_name(path)
    folder = Path(name.format(episode=1)).absolute().parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise ConfigError(f"physics option 'video_path' {name!r}: cannot write in "
                          f"{str(folder)!r} ({exc.strerror or exc}); give a path in a folder "
                          "you can write to", field="physics") from None
    return name


def _check_parameter(key: str, value: Any, label: str, field: str = "physics") -> float:
    """A numeric physics parameter: finite, > 0 or >= 0 as its entry says, and at most its
    maximum (:data:`PHYSICS_MAXIMA`) if it has one.
    """
    unit, positive, _ = PHYSICS_PARAMETERS[key]
    top = PHYSICS_MAXIMA.get(key, math.inf)
    ok = isinstance(value, int | float | np.floating) and not isinstance(value, bool)
    number = float(value) if ok else math.nan
    if not (math.isfinite(number) and (number > 0.0 if positive else number >= 0.0)
            and number <= top):
        bound = ("> 0" if positive else ">= 0") + (f" and <= {top:g}" if top < math.inf else "")
        raise ConfigError(f"{label} must be a number {bound} [{unit}], got {value!r}",
                          field=field)
    return number



@dataclass(frozen=True)
class PhysicsParams:
    """The configurable physical parameters of one episode (units as in the module table)."""

    human_stiffness: float
    human_force: float
    human_noise: float
    human_delay_s: float
    human_mass: float
    sensor_noise_n: float
    sensor_bias_n: float
    sensor_delay_s: float
    object_mass: float
    hold_force: float
    human_grip_force: float
    handle_noise_n: float

    @classmethod
    def of(cls, design: PhysicsDesign) -> PhysicsParams:
        """The defaults of a design."""
        return cls(design.human_stiffness, design.human_force, design.human_noise,
                   design.human_delay_s, design.human_mass, design.sensor_noise_n,
                   design.sensor_bias_n, design.sensor_delay_s, design.object_mass,
                   design.seat_hold, design.human_grip_force, design.handle_noise_n)

    def true_design(self, nominal: PhysicsDesign) -> PhysicsDesign:
        """The nominal design with these parameters (the human's, the seats', the mass)."""
        k = self.human_stiffness / nominal.human_stiffness
        f = self.human_force / nominal.human_force
        return replace(nominal, human_stiffness=self.human_stiffness,
                       human_rot_stiffness=nominal.human_rot_stiffness * k,
                       human_force=self.human_force, human_torque=nominal.human_torque * f,
                       human_noise=self.human_noise, human_delay_s=self.human_delay_s,
                       human_mass=self.human_mass, human_grip_force=self.human_grip_force,
                       seat_hold=self.hold_force, object_mass=self.object_mass,
                       object_inertia=nominal.object_inertia * (self.object_mass
                                                                / nominal.object_mass))


PARAMETER_KEYS: tuple[str, ...] = tuple(f.name for f in fields(PhysicsParams))


class PhysicsSettings:
    """Validated ``physics`` options of one scenario, resolved into episode parameters.

    Args:
        design: The scenario's nominal design.
        options: Options checked by :func:`check_options`
            (``video_*`` keys are ignored here).
    """

    def __init__(self, design: PhysicsDesign, options: Mapping[str, Any] | None = None) -> None:
        options = dict(options or {})
        values: dict[str, float] = {}
        preset = options.get("preset")
        if preset is not None:
            values.update(design.presets[preset])
        values.update({k: float(v) for k, v in options.items() if k in PARAMETER_KEYS})
        self.preset: str | None = preset
        #: The robot physically tries actions the graph calls invalid (docs/physics.md).
        self.attempt_invalid = bool(options.get("attempt_invalid", False))
        self.base = replace(PhysicsParams.of(design), **values)
        self.ranges: dict[str, tuple[float, float]] = {
            k: (float(lo), float(hi)) for k, (lo, hi) in dict(options.get("randomize")
                                                              or {}).items()}

    def draw(self, rng: np.random.Generator) -> PhysicsParams:
        """The parameters of a new episode (randomised keys drawn from ``rng``)."""
        if not self.ranges:
            return self.base
        drawn = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in sorted(self.ranges.items())}
        return replace(self.base, **drawn)
