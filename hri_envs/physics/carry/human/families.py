"""Families of physical humans: ranges of the whole arm's parameters, with what they model.

A :class:`Family` draws :class:`~hri_envs.physics.carry.human.intention.HumanParams` uniformly
within
its ranges: the sex (both alike), the stature's percentile (ANSUR II, :func:`~hri_envs.
physics.carry.human.body.stature_at`) and the body mass index
(:func:`~hri_envs.physics.carry.human.body.bmi_mass`),
the strength (a scale of the body's typical strength, :meth:`~hri_envs.physics.carry.human.body.
BodySize.strength_scale`), the hand's stiffness, the reaction delay, the hesitation before
each line of the route, the speed, the grip force (a multiple of the scenario's default,
max(20 N, 8 × the object's weight)) and the preference (any of the scenario's). Values are
rounded (times to ms, scales to 0.01, stature to mm, mass to 0.1 kg, grip to 0.1 N) so that
a member's parameters read and compare exactly.

============  ==========  ===============================================================
family        group       humans
============  ==========  ===============================================================
``nominal``   nominal     able adults: both sexes, stature 5th-95th percentile, BMI
                          18.5-30, strength 0.8-1.2, stiffness 0.7-1.4, reaction 0.2-0.4 s,
                          hesitation 0.1-0.35 s, speed 0.85-1.15, grip 1-1.5 x
``firm``      nominal     decisive, stiff and fast: stiffness 1.6-2.5, strength 1-1.3,
                          reaction 0.15-0.25 s, hesitation 0.05-0.15 s, speed 1.05-1.3
``loose``     nominal     a loose grip: 0.45-0.7 x the default grip force, else nominal
``weak``      weak        older adults (65-85): strength 0.45-0.8, stiffness 0.4-0.8,
                          reaction 0.35-0.6 s, hesitation 0.2-0.5 s, speed 0.6-0.85, grip
                          0.7-1 x, BMI 20-30
``hesitant``  hesitant    slow to start and pausing: reaction 0.5-0.9 s, hesitation
                          0.6-1.5 s, speed 0.6-0.9, else nominal
``extremes``  heldout     body-size extremes, **held out of train and validation**: stature
                          0.5th-5th or 95th-99.5th percentile, BMI 16.5-18.5 or 30-37,
                          else nominal
============  ==========  ===============================================================

Sources and reasons are in each family's ``description`` (:data:`FAMILIES`) and in
docs/physical-humans.md. The torque drive only: the muscle-driven arm (MyoSuite's
``myoarm_r``) has one anatomy, cannot hold the hanger's handle at the peg's orientation and
runs at about 3x real time, so no family carries it (docs/physical-humans.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hri_envs.physics.carry.human.body import SEXES, bmi_mass, stature_at
from hri_envs.physics.carry.human.intention import HumanParams

__all__ = ["FAMILIES", "GROUPS", "Family"]

Range = tuple[float, float]


@dataclass(frozen=True)
class Family:
    """A family of physical humans: uniform ranges of their parameters.

    Attributes:
        name: The family's name; group: the test track it belongs to.
        description: What it models and why, with sources.
        stature_pct: Bands of the stature's percentile (ANSUR II, per sex); one band drawn
            uniformly, then a percentile in it.
        bmi: Bands of the body mass index [kg/m²], drawn likewise.
        strength, stiffness, reaction_s, hesitation_s, speed: Uniform ranges of those
            :class:`~hri_envs.physics.carry.human.intention.HumanParams`.
        grip: Range of the grip force as a multiple of the scenario's default.
        train: Whether the family is in the train and validation splits.
    """

    name: str
    group: str
    description: str
    stature_pct: tuple[Range, ...] = ((5.0, 95.0),)
    bmi: tuple[Range, ...] = ((18.5, 30.0),)
    strength: Range = (0.8, 1.2)
    stiffness: Range = (0.7, 1.4)
    reaction_s: Range = (0.2, 0.4)
    hesitation_s: Range = (0.1, 0.35)
    speed: Range = (0.85, 1.15)
    grip: Range = (1.0, 1.5)
    train: bool = True

    def draw(self, rng: np.random.Generator, default_grip_n: float,
             preferences: tuple[str, ...]) -> HumanParams:
        """One member: every parameter uniform in its range (a fixed number of draws from
        ``rng`` in a fixed order), rounded.
        """
        sex = SEXES[int(rng.integers(len(SEXES)))]
        lo, hi = self.stature_pct[int(rng.integers(len(self.stature_pct)))]
        stature = round(stature_at(sex, float(rng.uniform(lo, hi))), 3)
        lo, hi = self.bmi[int(rng.integers(len(self.bmi)))]
        mass = round(bmi_mass(stature, float(rng.uniform(lo, hi))), 1)
        u = {name: float(rng.uniform(*getattr(self, name)))
             for name in ("strength", "stiffness", "reaction_s", "hesitation_s", "speed",
                          "grip")}
        preference = preferences[int(rng.integers(len(preferences)))]
        return HumanParams(
            strength=round(u["strength"], 2), stiffness=round(u["stiffness"], 2),
            hesitation_s=round(u["hesitation_s"], 3), reaction_s=round(u["reaction_s"], 3),
            grip_force_n=round(u["grip"] * default_grip_n, 1), preference=preference,
            speed=round(u["speed"], 2), sex=sex, stature_m=stature, body_mass_kg=mass,
            drive="torque")


_NOMINAL = (
    "Able adults of working age, both sexes alike. Body: stature from the 5th to the 95th "
    "percentile of ANSUR II (Gordon et al. 2014) per sex, BMI 18.5-30 (the WHO's normal and "
    "overweight bands), segments from de Leva (1996). Strength 0.8-1.2 of the body's "
    "typical strength (people of one size differ in strength; a design choice), hand "
    "stiffness 0.7-1.4 of the scenario's (arm stiffness varies several-fold with "
    "co-contraction between people and tasks: Perreault, Kirsch & Crago, Exp. Brain Res. "
    "141(3):312-323, 2001), a reaction of 0.2-0.4 s (young adults' simple reaction times "
    "are of the order of 0.3 s: Der & Deary, Psychol. Aging 21(1):62-73, 2006), short "
    "hesitations, speeds within 15 % of the default, a grip 1-1.5 times the default (a "
    "safety margin over the slip force: Westling & Johansson, Exp. Brain Res. "
    "53(2):277-284, 1984), any preference.")
_FIRM = (
    "Decisive humans who hold their course: stiff (1.6-2.5 of the scenario's stiffness, "
    "co-contracted arms), strong (1-1.3), quick to start (0.15-0.25 s) and to go on "
    "(0.05-0.15 s) and fast (1.05-1.3). They resist a robot that goes elsewhere harder; "
    "the counterpart of the abstract benchmark's wary and impatient humans.")
_LOOSE = (
    "A loose grip: 0.45-0.7 times the scenario's default grip force (a small safety "
    "margin over the slip force, as when the hand is tired or the handle is slippery: "
    "Westling & Johansson 1984), otherwise nominal. A robot that twists or drags the "
    "object makes the handle slip out of their hand.")
_WEAK = (
    "Older adults (65-85 years). Strength 0.45-0.8 of a young adult's of their size "
    "(strength falls by 20-40 % from the third decade to the seventh and eighth and more "
    "beyond: Doherty, J. Appl. Physiol. 95(4):1717-1727, 2003), a softer arm (stiffness "
    "0.4-0.8), slower reactions (0.35-0.6 s; reaction time grows with age: Der & Deary "
    "2006), longer hesitations (0.2-0.5 s), slower movements (0.6-0.85), a weaker grip "
    "(0.7-1 times the default; grip strength falls with age: Dodds et al., PLoS One "
    "9(12):e113637, 2014), BMI 20-30. The physical counterpart of the v0 weak-human preset.")
_HESITANT = (
    "Humans slow to start and who pause between the moves of their route: a reaction of "
    "0.5-0.9 s, a hesitation of 0.6-1.5 s before each line, speed 0.6-0.9, otherwise "
    "nominal. The counterpart of the abstract benchmark's passive humans (a step in which "
    "the human waits becomes a pause); a robot that reads a pause as agreement goes its "
    "own way.")
_EXTREMES = (
    "Body-size extremes, held out of train and validation to measure generalisation: "
    "stature below the 5th (0.5th-5th) or above the 95th (95th-99.5th) percentile of "
    "ANSUR II, BMI 16.5-18.5 (underweight) or 30-37 (obese classes I-II, WHO 2000), so "
    "segment lengths, masses and strength (which scales with stature², 0.52 for women) "
    "outside the train bodies; otherwise nominal.")
#: The families (:data:`GROUPS` maps the test tracks to them).
FAMILIES: dict[str, Family] = {f.name: f for f in (
    Family("nominal", "nominal", _NOMINAL),
    Family("firm", "nominal", _FIRM, strength=(1.0, 1.3), stiffness=(1.6, 2.5),
           reaction_s=(0.15, 0.25), hesitation_s=(0.05, 0.15), speed=(1.05, 1.3)),
    Family("loose", "nominal", _LOOSE, grip=(0.45, 0.7)),
    Family("weak", "weak", _WEAK, bmi=((20.0, 30.0),), strength=(0.45, 0.8),
           stiffness=(0.4, 0.8), reaction_s=(0.35, 0.6), hesitation_s=(0.2, 0.5),
           speed=(0.6, 0.85), grip=(0.7, 1.0)),
    Family("hesitant", "hesitant", _HESITANT, reaction_s=(0.5, 0.9),
           hesitation_s=(0.6, 1.5), speed=(0.6, 0.9)),
    Family("extremes", "heldout", _EXTREMES, stature_pct=((0.5, 5.0), (95.0, 99.5)),
           bmi=((16.5, 18.5), (30.0, 37.0)), train=False),
)}
#: The test tracks' family groups: {group: its families}.
GROUPS: dict[str, tuple[str, ...]] = {
    g: tuple(f.name for f in FAMILIES.values() if f.group == g)
    for g in dict.fromkeys(f.group for f in FAMILIES.values())}
