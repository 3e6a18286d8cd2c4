"""A human who conveys their intention by force: a route, a minimum-jerk reference along it
and an impedance around it (the continuous envs' human, :mod:`hri_envs.physics.carry.sim`).

The human knows their goal support (the hidden intention ι) and their preference. Their
*route* is the scripted human's path through the task graph from the start support to the
goal (take off, the preference's moves and rotation, put on: :func:`route_states`), as
physical object poses. Their *reference* travels along it one straight line after another,
each with minimum-jerk timing (:class:`~hri_envs.physics.scene.kinematics.StraightLine`), after a
reaction delay and a hesitation before each line. Their arm tracks the reference with an
impedance (a spring and damper on the hand, :mod:`~hri_envs.physics.carry.human.arm_control`), so

* a robot going the wrong way is pushed against: the farther the object strays from the
  reference, the harder the hand pulls it back (up to the arm's strength);
* a robot going the human's way is *yielded to*: when the object is ahead of the reference
  along the current line, the reference jumps ahead to it (:meth:`IntentionHuman.advance`),
  so the human does not hold a helpful robot back.

:class:`HumanParams` are the human's physical parameters (strength, stiffness, hesitation,
reaction, grip); :data:`HUMAN_PRESETS` names sets of them and docs/physics.md maps them to
the abstract benchmark's human families.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from hri_envs.humans.spec import HumanBody, HumanSpec
from hri_envs.physics.carry.human.body import SEXES, BodySize
from hri_envs.physics.scene.design import PhysicsDesign
from hri_envs.physics.scene.kinematics import Pose, StraightLine, TrajectorySample, rotation_error
from hri_envs.task.graph import BOTH, TaskGraph

__all__ = ["CARRY_SPEC_FIELDS", "HUMAN_DRIVES", "HUMAN_PRESETS", "HumanParams",
           "IntentionHuman", "carry_human_spec", "route_states"]

#: The arm's drives: joint torque motors, or MyoSuite's muscles (the "arm" extra).
HUMAN_DRIVES: tuple[str, ...] = ("torque", "muscle")


@dataclass(frozen=True)
class HumanParams:
    """The physical human of the continuous envs.

    Attributes:
        strength: Scale of the adult joint torque limits (1: the cited adult means,
            docs/physics.md); the finger pad's grip force is not scaled by it.
        stiffness: Scale of the scenario's hand impedance (stiffness and damping).
        hesitation_s: Pause [s] before each straight line of the route after the first.
        reaction_s: Delay [s] before the first line starts.
        grip_force_n: How hard [N] the fingers squeeze the handle (None: the scenario's).
        preference: The route's preference (None: the scenario's default).
        speed: Scale of the reference's speed (1: 1.2 x the robot's planned speeds).
        sex: "male" or "female": de Leva's segment tables of that sex (:mod:`~hri_envs.
            physics.carry.human.body`).
        stature_m: Standing height [m] (1.741: de Leva's male reference subject); scales
            the arm's segments, the torso, the shoulder's height and the strength.
        body_mass_kg: Body mass [kg]; the segments' and the torso's masses.
        drive: The arm's drive, "torque" or "muscle" (MyoSuite's arm: one anatomy, the
            default body only), or None: the sim's; a :class:`~hri_envs.physics.carry.sim.
            CarrySim` of another drive refuses the human.

    ``strength`` scales the torque limits of the body (its sex and stature, :meth:`~hri_envs.
    physics.carry.human.body.BodySize.strength_scale`): 1 is the typical strength of such a body.

    A :class:`~hri_envs.humans.spec.HumanSpec`'s body names them (:meth:`of_spec`).
    """

    strength: float = 1.0
    stiffness: float = 1.0
    hesitation_s: float = 0.2
    reaction_s: float = 0.3
    grip_force_n: float | None = None
    preference: str | None = None
    speed: float = 1.0
    sex: str = "male"
    stature_m: float = 1.741
    body_mass_kg: float = 75.0
    drive: str | None = None

    @property
    def body(self) -> BodySize:
        """The human's body size."""
        return BodySize(self.sex, self.stature_m, self.body_mass_kg)

    @classmethod
    def of(cls, values: Mapping[str, Any] | HumanParams | None) -> HumanParams:
        """Parameters from a mapping (``preset`` names a base, :data:`HUMAN_PRESETS`).

        Raises:
            ConfigError: (``field="human"``) An unknown key or preset, or a value that is
                not allowed (strength, stiffness and speed > 0; times >= 0; grip > 0; sex
                "male" or "female"; stature 1.3-2.2 m; body mass 35-180 kg; drive
                "torque" or "muscle").
        """
        if isinstance(values, HumanParams):
            return values
        if values is not None and not isinstance(values, Mapping):
            raise ConfigError(f"human must be None or a mapping of human parameters (e.g. "
                              f"{{'preset': 'weak'}}; presets {', '.join(HUMAN_PRESETS)}), got "
                              f"{values!r}", field="human")
        values = dict(values or {})
        preset = values.pop("preset", None)
        if preset is not None and (not isinstance(preset, str) or preset not in HUMAN_PRESETS):
            raise ConfigError(f"unknown human preset {preset!r}; allowed: "
                              f"{', '.join(HUMAN_PRESETS)}", field="human")
        base = HUMAN_PRESETS[preset] if preset is not None else cls()
        allowed = [f.name for f in fields(cls)]
        unknown = sorted(map(repr, set(values) - set(allowed)))
        if unknown:
            raise ConfigError(f"unknown human parameter(s) {', '.join(unknown)}; "
                              f"allowed: preset, {', '.join(allowed)}", field="human")
        for key, value in values.items():
            if key in _CHOICES:
                chosen = isinstance(value, str) and value in _CHOICES[key]
                if not chosen and not (key == "drive" and value is None):
                    raise ConfigError(f"human {key!r} must be one of "
                                      f"{', '.join(_CHOICES[key])}, got {value!r}",
                                      field="human")
                continue
            if key == "preference":
                if value is not None and not isinstance(value, str):
                    raise ConfigError(f"human 'preference' must be a str, got {value!r}",
                                      field="human")
                continue
            if value is None and key == "grip_force_n":
                continue
            positive = key in ("strength", "stiffness", "speed", "grip_force_n")
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if key in _RANGES:
                lo, hi = _RANGES[key]
                if not (ok and lo <= value <= hi):
                    raise ConfigError(f"human {key!r} must be a number in [{lo}, {hi}], got "
                                      f"{value!r}", field="human")
                continue
            if not (ok and math.isfinite(value) and (value > 0 if positive else value >= 0)):
                raise ConfigError(f"human {key!r} must be a number {'> 0' if positive else '>= 0'}"
                                  f", got {value!r}", field="human")
        return replace(base, **values)

    @classmethod
    def of_spec(cls, spec: HumanSpec) -> HumanParams:
        """The human of a spec's body (its preset and params) and preference.

        Raises:
            ConfigError: (``field="human"``) As :meth:`of`, or a preference given both as the
                spec's and in its body.
        """
        values = {} if spec.body is None else spec.body.values()
        if spec.preference is not None:
            if "preference" in values:
                raise ConfigError("give the human's preference either as HumanSpec.preference "
                                  "or in its body, not both", field="human")
            values["preference"] = spec.preference
        return cls.of(values)


#: The human parameters that take one of a few names.
_CHOICES: dict[str, tuple[str, ...]] = {"sex": SEXES, "drive": HUMAN_DRIVES}
#: The body's plausible adult range (stature [m], mass [kg]).
_RANGES: dict[str, tuple[float, float]] = {"stature_m": (1.3, 2.2), "body_mass_kg": (35.0, 180.0)}


#: Named humans. ``weak``: a quarter of the adult's strength and 40 % of the stiffness (the
#: physical counterpart of the v0 ``weak-human`` preset); ``hesitant``: long pauses (the
#: counterpart of the abstract benchmark's passive humans); ``firm``: twice as stiff.
HUMAN_PRESETS: dict[str, HumanParams] = {
    "default": HumanParams(),
    "weak": HumanParams(strength=0.25, stiffness=0.4, reaction_s=0.4),
    "hesitant": HumanParams(hesitation_s=1.0, reaction_s=0.6),
    "firm": HumanParams(stiffness=2.0, hesitation_s=0.1, reaction_s=0.2),
}


#: The :class:`~hri_envs.humans.spec.HumanSpec` fields the continuous envs honour.
CARRY_SPEC_FIELDS: tuple[str, ...] = ("preference", "population", "body")


def carry_human_spec(human: Any, population: Any = None, episode: bool = False) -> HumanSpec:
    """The continuous envs' human as a :class:`~hri_envs.humans.spec.HumanSpec`: ``human``
    if it is one, else the spec of the shorthand (``human=`` a mapping of
    :class:`HumanParams` fields and/or ``preset``, or a :class:`HumanParams`: the body;
    ``population=`` a physical population's name). ``episode``: one episode's human (the
    v1 reset option ``human``), which a population cannot be.

    Raises:
        ConfigError: A spec that sets a field the continuous envs cannot honour
            (:data:`CARRY_SPEC_FIELDS` only: the human is a physical arm following a route,
            not the graph's scripted policy), a population given both ways or for one
            episode, or the shorthand's errors (:meth:`HumanParams.of`; a population that
            is not a name).
    """
    if isinstance(human, HumanSpec):
        if population is not None:
            raise ConfigError("give the population either as population= or as "
                              "human=HumanSpec(population=...), not both", field="population")
        if episode:
            return human.refuse("the continuous env's reset option 'human'",
                                ("preference", "body"), " (one episode's human)")
        return human.refuse("the continuous env", CARRY_SPEC_FIELDS,
                            " (its human is a physical arm along a route, not the graph's "
                            "scripted policy)")
    params = HumanParams.of(human)  # the shorthand's own errors
    if population is not None and not isinstance(population, str):
        raise ConfigError(f"population must be a population's name, got {population!r}",
                          field="population")
    body = None
    if isinstance(human, HumanParams):
        body = HumanBody.of(asdict(params))
    elif human is not None:
        body = HumanBody.of(human)
    return HumanSpec(population=population, body=body)


def route_states(graph: TaskGraph, start: int, goal: int,
                 preference: str | None = None) -> list[int]:
    """The abstract states the scripted human passes from support ``start`` (both holding)
    to support ``goal``: the support state, the mounting waypoints, ..., the goal's support
    state (both holding).

    Raises:
        ConfigError: ``start == goal`` or an unknown preference.
    """
    if start == goal:
        raise ConfigError(f"the goal must differ from the start support, both {start}",
                          field="intention")
    human = preference_human(graph, preference)
    s = graph.support_state(start, BOTH)
    states = [s]
    end = graph.support_state(goal, BOTH)
    from hri_envs.task.actions import WAIT  # noqa: PLC0415

    while s != end and len(states) <= graph.n_states:
        a = int(human.route_table[start, goal, s])
        s = int(graph.next_state[s, WAIT, a])
        states.append(s)
    if s != end:
        raise AssertionError(f"the route from {start} to {goal} does not reach the goal")
    return states


class IntentionHuman:
    """The human's reference along their route, yielding to a robot that leads their way.

    Args:
        design: Speeds and the human's impedance (scaled by ``params.stiffness``).
        params: The human.
        lever_m: Metres per radian when a line mixes translation and rotation.

    Attributes:
        lines: The route's straight lines (object poses).
        index: The current line; t its time [s] (negative while pausing before it).
        done: The reference reached the goal.
    """

    def __init__(self, design: PhysicsDesign, params: HumanParams, lever_m: float) -> None:
        self.design, self.params, self.lever = design, params, lever_m
        self.lines: list[StraightLine] = []
        self.index, self.t, self.done = 0, 0.0, True
        # The minimum-jerk phase s(τ) on a grid, to invert it when the human yields.
        self._tau = np.linspace(0.0, 1.0, 129)
        self._phase = self._tau**3 * (10.0 - 15.0 * self._tau + 6.0 * self._tau**2)

    def plan(self, poses: list[Pose]) -> None:
        """Start a new route through ``poses`` (object poses), after the reaction delay."""
        d, p = self.design, self.params
        speed = (p.speed * d.human_speed_factor * d.linear_speed,
                 p.speed * d.human_speed_factor * d.angular_speed)
        self.lines = [StraightLine(a, b, *speed, min_duration=d.motion_min_duration_s)
                      for a, b in zip(poses, poses[1:], strict=False)]
        self.index, self.t, self.done = 0, -p.reaction_s, not self.lines

    @property
    def goal(self) -> Pose:
        """The route's final object pose."""
        return self.lines[-1].goal

    def _progress(self, line: StraightLine, pos: np.ndarray, quat: np.ndarray,
                  clamp: bool = True) -> float:
        """How far (0-1) along ``line`` the object at (``pos``, ``quat``) is (unclamped
        below 0 if not ``clamp``).
        """
        lv = self.lever
        dp = pos - line.start.pos
        dr = rotation_error(quat, line.start.quat)
        num = float(dp.dot(line.delta) + lv * lv * dr.dot(line.rotvec))
        den = float(line.delta.dot(line.delta) + lv * lv * line.rotvec.dot(line.rotvec))
        if den <= 1e-12:
            return 1.0
        return min(max(num / den, 0.0), 1.0) if clamp else min(num / den, 1.0)

    def advance(self, dt: float, pos: np.ndarray, quat: np.ndarray) -> TrajectorySample:
        """The object reference for the next ``dt`` [s], given the object's pose now.

        The reference time runs on; when the object is ahead of the reference along the
        current line (a robot leads the human's way), the reference jumps to the object's
        progress. A finished line is followed by the next one after ``hesitation_s``.
        """
        if self.done:
            return self.lines[-1].sample(math.inf)
        line = self.lines[self.index]
        if self.t >= line.duration:
            if self.index + 1 < len(self.lines):
                self.index += 1
                line = self.lines[self.index]
                self.t = -self.params.hesitation_s
            else:
                self.done = True
                return line.sample(math.inf)
        if self.t >= 0.0:
            s_obj = self._progress(line, pos, quat)
            tau = self.t / line.duration
            s_ref = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
            if s_obj > s_ref:  # the object leads: yield (the reference catches up)
                self.t = max(self.t, float(np.interp(s_obj, self._phase, self._tau))
                             * line.duration)
        sample = line.sample(max(self.t, 0.0))
        self.t += dt
        return sample

    def progress(self, pos: np.ndarray, quat: np.ndarray, tolerance_m: float = 0.05) -> float:
        """The object's progress along the whole route (0 at the start, 1 at the goal), by
        path length (m + lever x rad): the farthest point of the route within
        ``tolerance_m`` (same measure) of the object, else the route's nearest point.
        """
        lengths = [float(np.linalg.norm(ln.delta) + self.lever * np.linalg.norm(ln.rotvec))
                   for ln in self.lines]
        total = sum(lengths)
        best, nearest, nearest_d = -1.0, 0.0, math.inf
        done = 0.0
        for line, length in zip(self.lines, lengths, strict=True):
            s = self._progress(line, pos, quat)
            p = line.start.pos + s * line.delta
            e = rotation_error(quat, line.start.quat) - s * line.rotvec
            d = float(np.linalg.norm(pos - p) + self.lever * np.linalg.norm(e))
            value = (done + s * length) / total
            if d < tolerance_m:
                best = max(best, value)
            if d < nearest_d:
                nearest, nearest_d = value, d
            done += length
        return best if best >= 0.0 else nearest
