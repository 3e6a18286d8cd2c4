"""The human's body size: sex, stature and body mass turned into the whole arm's segments.

:class:`BodySize` is a body (sex, stature [m], body mass [kg]); :meth:`BodySize.segments`
gives its arm's segment lengths and masses from de Leva's tables, :meth:`BodySize.scale`
its torso's size and :meth:`BodySize.strength_scale` its strength relative to the adult of
the torque limits (:data:`~hri_envs.physics.carry.human.whole_arm.TORQUE_LIMITS`). :class:`ArmBody`
writes a body into a compiled scene with the torque-driven arm (MjModel fields, then
``mj_setConst`` for the quantities MuJoCo derives from them: about 0.1 ms, no rebuild).

Sources:

* **Segments**: P. de Leva, *Adjustments to Zatsiorsky-Seluyanov's segment inertia
  parameters*, J. Biomech. 29(9):1223-1230, 1996, Table 4 (:data:`DE_LEVA`): per sex, the
  reference subjects' stature and each segment's length (upper arm: shoulder to elbow joint
  centre; forearm: elbow to wrist joint centre; hand: wrist joint centre to the third
  metacarpal's head, where the grip is) and mass as a fraction of the body mass. A body's
  segment is its sex's length scaled by stature / the reference stature, and its fraction
  of the body mass. The segment's centre of mass stays at its middle and its inertia is a
  solid cylinder's whose radius keeps the default arm's density (radius ∝ √(mass /
  length)), as for the default arm (de Leva's centres of mass and radii of gyration are not
  used, so that the default human stays exactly as it was).
* **Stature percentiles**: C. C. Gordon et al., *2012 Anthropometric Survey of U.S. Army
  Personnel: Methods and Summary Statistics*, NATICK/TR-15/007, 2014 (ANSUR II; 4,082 men,
  1,986 women): stature mean and standard deviation per sex (:data:`STATURE_SURVEY`),
  a percentile read from the normal distribution with them (:func:`stature_at`).
* **Body mass** from the body mass index: mass = BMI × stature². BMI (Quetelet's index)
  is nearly independent of stature in adults (A. Keys et al., *Indices of relative weight
  and obesity*, J. Chronic Dis. 25(6):329-343, 1972), so stature and BMI are drawn
  independently; the WHO's bands (*Obesity: preventing and managing the global epidemic*,
  WHO Technical Report Series 894, 2000): 18.5-25 normal, 25-30 overweight, ≥ 30 obese.
* **Strength**: joint torque grows with body size as body mass for geometrically similar
  bodies (S. Jaric, *Muscle strength testing: use of normalisation for body size*, Sports
  Med. 32(10):615-631, 2002); here with the mass typical of the stature (the default's
  BMI × stature², so ∝ stature²), not the actual mass, so that a higher BMI does not make
  the arm stronger. Women: 52 % of men's upper-body strength (A. E. J. Miller et al.,
  *Gender differences in strength and muscle fiber characteristics*, Eur. J. Appl.
  Physiol. 66(3):254-262, 1993).

The default body is the arm the continuous envs always had: a man of de Leva's reference
stature (1.741 m) and 75 kg; :class:`ArmBody` leaves the model untouched for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import mujoco
import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.whole_arm import SEGMENTS, Segment, WholeArm, segment_inertia

__all__ = ["BODY_FIELDS", "DE_LEVA", "SEXES", "STATURE_SURVEY", "WARP_BODY_FIELDS", "ArmBody",
           "BodySize", "bmi_mass", "stature_at"]

SEXES: tuple[str, ...] = ("male", "female")
#: de Leva (1996), Table 4, per sex: (reference stature [m], {segment: (length [m], fraction
#: of the body mass)}).
DE_LEVA: dict[str, tuple[float, dict[str, tuple[float, float]]]] = {
    "male": (1.741, {"upper_arm": (0.2817, 0.0271), "forearm": (0.2689, 0.0162),
                     "hand": (0.0862, 0.0061)}),
    "female": (1.735, {"upper_arm": (0.2751, 0.0255), "forearm": (0.2643, 0.0138),
                       "hand": (0.0780, 0.0056)}),
}
#: ANSUR II (Gordon et al. 2014): stature mean and standard deviation [m] per sex.
STATURE_SURVEY: dict[str, tuple[float, float]] = {"male": (1.7562, 0.0686),
                                                  "female": (1.6285, 0.0642)}
#: Women's strength over men's (upper body, Miller et al. 1993).
FEMALE_STRENGTH = 0.52
_REF_STATURE_M, _REF_MASS_KG = 1.741, 75.0  # the default body
_TORSO_MASS_KG, _TORSO_INERTIA = 40.0, np.array([2.0, 2.0, 1.0])
_ARM_BODIES = ("human_upper_arm", "human_forearm", "human_hand")
#: The MjModel fields :meth:`ArmBody.apply` writes or ``mj_setConst`` derives (restored
#: exactly for the default body). ``mj_setConst`` also recomputes the bodies' collision
#: masks from their geoms' (the robot's fingers, switched off at a reset) and the grasp
#: weld's relative pose (set again by every reset that welds).
BODY_FIELDS: tuple[str, ...] = (
    "body_pos", "body_ipos", "body_mass", "body_inertia", "geom_pos", "geom_size",
    "geom_rbound", "geom_aabb", "body_subtreemass", "body_invweight0", "dof_invweight0",
    "dof_M0", "dof_length", "actuator_acc0", "light_poscom0", "body_contype",
    "body_conaffinity", "eq_data")
#: The ones of :data:`BODY_FIELDS` that MuJoCo Warp's physics reads, per world there (the
#: pictures' geoms do not collide, and the torque drive has no muscles).
WARP_BODY_FIELDS: tuple[str, ...] = (
    "body_pos", "body_ipos", "body_mass", "body_inertia", "body_subtreemass",
    "body_invweight0", "dof_invweight0")


def stature_at(sex: str, percentile: float) -> float:
    """The stature [m] of ``sex`` at ``percentile`` (0-100, exclusive) of ANSUR II."""
    _check_sex(sex)
    mean, sd = STATURE_SURVEY[sex]
    return mean + sd * NormalDist().inv_cdf(percentile / 100.0)


def bmi_mass(stature_m: float, bmi: float) -> float:
    """The body mass [kg] of a body of ``stature_m`` with body mass index ``bmi``."""
    return bmi * stature_m * stature_m


def _check_sex(sex: str) -> None:
    if sex not in SEXES:
        raise ConfigError(f"unknown sex {sex!r}; allowed: {', '.join(SEXES)}", field="human")


@dataclass(frozen=True)
class BodySize:
    """A human body.

    Attributes:
        sex: "male" or "female" (de Leva's tables of that sex).
        stature_m: Standing height [m].
        mass_kg: Body mass [kg].
    """

    sex: str = "male"
    stature_m: float = _REF_STATURE_M
    mass_kg: float = _REF_MASS_KG

    @property
    def is_default(self) -> bool:
        """The continuous envs' original arm (a 75 kg man of de Leva's stature)."""
        return self == BodySize()

    @property
    def scale(self) -> float:
        """The torso's size over the default's: stature / 1.741 m."""
        return self.stature_m / _REF_STATURE_M

    @property
    def bmi(self) -> float:
        """Body mass index [kg/m²]."""
        return self.mass_kg / (self.stature_m * self.stature_m)

    def segments(self) -> dict[str, Segment]:
        """The arm's segments (de Leva's, scaled; radii at the default arm's density)."""
        ref, table = DE_LEVA[self.sex]
        out = {}
        for name, (length, fraction) in table.items():
            seg0 = SEGMENTS[name]
            length_m = length * self.stature_m / ref
            mass = fraction * self.mass_kg
            radius = seg0.radius * math.sqrt((mass / seg0.mass) / (length_m / seg0.length))
            out[name] = Segment(length_m, mass, radius)
        return out

    def strength_scale(self) -> float:
        """The torque limits' scale for this body: (stature / 1.741 m)², times 0.52 for a
        woman (module docstring).
        """
        return self.scale**2 * (FEMALE_STRENGTH if self.sex == "female" else 1.0)

    def reach_scale(self) -> float:
        """The arm's length (shoulder to grip) over the default arm's."""
        segs = self.segments()
        return sum(s.length for s in segs.values()) / sum(s.length for s in SEGMENTS.values())


class ArmBody:
    """Puts a :class:`BodySize` into a compiled scene with the torque-driven whole arm.

    Writes the torso's height, mass and inertia and the shoulder's place on it (scaled by
    :attr:`BodySize.scale`), each arm segment's length (the next body's position, the
    grip frame's on the hand), mass, centre of mass and inertia, the pictures' sizes, and
    the arm's comfortable hand position and torso height (:class:`~hri_envs.physics.
    carry.human.whole_arm.WholeArm`); then ``mj_setConst``. The default body restores the compiled
    values exactly.

    Args:
        model: The compiled scene.
        arm: Its whole arm's indices (updated in place).
    """

    def __init__(self, model: mujoco.MjModel, arm: WholeArm) -> None:
        def bid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)

        self.model, self.arm = model, arm
        self.torso = bid("human_torso")
        self.segs = [bid(n) for n in _ARM_BODIES]
        self.grip_frame = bid("human_grip_frame")
        visual = (model.geom_contype == 0) & (model.geom_conaffinity == 0)
        self.torso_geoms = np.flatnonzero(visual & (model.geom_bodyid == self.torso))
        self.seg_geoms = [np.flatnonzero(visual & (model.geom_bodyid == b)) for b in self.segs]
        self._saved = {name: getattr(model, name).copy() for name in BODY_FIELDS}
        self._arm0 = (arm.shoulder_in_torso.copy(), arm.hand_in_torso.copy(),
                      arm.torso_height_m)
        self.current = BodySize()

    def apply(self, body: BodySize, data: mujoco.MjData) -> None:
        """Make the arm ``body``'s (nothing to do if it already is); ``data`` is scratch
        space for ``mj_setConst`` (reset it afterwards).
        """
        if body == self.current:
            return
        m = self.model
        for name, value in self._saved.items():
            getattr(m, name)[:] = value
        shoulder0, hand0, height0 = self._arm0
        self.arm.shoulder_in_torso, self.arm.hand_in_torso = shoulder0.copy(), hand0.copy()
        self.arm.torso_height_m = height0
        self.current = body
        if body.is_default:
            return
        k, w = body.scale, body.mass_kg / _REF_MASS_KG
        t = self.torso
        m.body_pos[t] *= k
        m.body_mass[t] = _TORSO_MASS_KG * w
        m.body_inertia[t] = _TORSO_INERTIA * w * k * k
        m.geom_pos[self.torso_geoms] *= k
        m.geom_size[self.torso_geoms] *= k
        m.geom_rbound[self.torso_geoms] *= k
        m.body_pos[self.segs[0]] *= k  # the shoulder on the torso
        segs = body.segments()
        children = [*self.segs[1:], self.grip_frame]
        for b, geoms, child, name in zip(self.segs, self.seg_geoms, children, SEGMENTS,
                                         strict=True):
            seg, seg0 = segs[name], SEGMENTS[name]
            m.body_mass[b], m.body_inertia[b] = seg.mass, segment_inertia(seg)
            m.body_ipos[b] = (0.0, 0.0, -seg.length / 2)
            m.body_pos[child] = (0.0, 0.0, -seg.length)
            along, across = seg.length / seg0.length, seg.radius / seg0.radius
            m.geom_pos[geoms] *= along
            m.geom_size[geoms, 0] *= across
            m.geom_size[geoms, 1] *= along
            m.geom_rbound[geoms] = m.geom_size[geoms, 0] + m.geom_size[geoms, 1]
        mujoco.mj_setConst(m, data)
        self.arm.shoulder_in_torso = shoulder0 * k
        self.arm.hand_in_torso = shoulder0 * k + (hand0 - shoulder0) * body.reach_scale()
        self.arm.torso_height_m = height0 * k
