"""Physical human populations (hri_envs.physics.carry.human.population): frozen splits, distinct by
behaviour, families within their ranges, and a body size that changes the simulated arm.
"""

import copy
import dataclasses

import gymnasium as gym
import mujoco
import numpy as np
import pytest

from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.body import BodySize, bmi_mass, stature_at
from hri_envs.physics.carry.human.families import FAMILIES, GROUPS
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.human.population import (
    SCENARIOS,
    SPLITS,
    physical_population,
    population_names,
)
from hri_envs.physics.carry.human.population_build import fingerprint, nearest
from hri_envs.physics.carry.human.probe import distance, distances, signature
from hri_envs.physics.carry.sim import CarrySim, default_grip_force
from hri_envs.task.scenarios import scenario_graph, scenario_spec

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

#: SHA-256 content hashes of the frozen splits (benchmarks/physical_populations.py --report).
HASHES = {
    ("hanger", "train"): "344678ad4206ab95c65d12844a1fcde77b0bf78a75c596d00c0e012691887aab",
    ("hanger", "validation"): "28c0de2c7b8244dcfbd2640a3c7975135bf525951c9f6afeed77a2b0df35942b",
    ("hanger", "test"): "1fa01b8ac8bc15b0c2a14fe3911238840c065ea3a418b99bac8077c7d8f6c131",
    ("wheel", "train"): "44a2fd63a1123f2a26bafb7c61925f276a4ef69be50c55b571f0e4e909a66f23",
    ("wheel", "validation"): "ea611e6d36e53381d4ae15cd6f47852090c6c1f99a0ddf58fe25505fccbdf0ea",
    ("wheel", "test"): "273e1f1569f6b6c554ce3d0fc28312c40fba8392df289d81891ceb57bea3e148",
}


@pytest.fixture(scope="module")
def sims():
    return {s: CarrySim(scenario_graph(s)) for s in SCENARIOS}


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_the_splits_are_frozen_and_sized(scenario):
    """Every split's content hash is pinned; sizes and make-up as documented; the test split
    has four tracks of 32 (at most 160 humans); the held-out family is in test only."""
    for split, makeup in SPLITS.items():
        pop = physical_population(split, scenario)
        assert pop.content_hash() == HASHES[scenario, split], split
        assert len(pop) == sum(makeup.values()) == len(set(pop.fingerprints))
        assert {f: pop.families.count(f) for f in makeup} == makeup
        assert pop.fingerprints == tuple(fingerprint(m) for m in pop.members)
    test = physical_population("test", scenario)
    groups = test.groups()
    assert list(groups) == ["nominal", "weak", "hesitant", "heldout"]
    assert all(len(v) == 32 for v in groups.values()) and len(test) <= 160
    for split in ("train", "validation"):
        assert "extremes" not in physical_population(split, scenario).families
    for group, rows in groups.items():
        sub = physical_population(f"test-{group}", scenario)
        assert sub.members == tuple(test.members[i] for i in rows)
        assert set(sub.families) <= set(GROUPS[group])


def test_unknown_names_and_scenarios_are_refused():
    with pytest.raises(ConfigError, match="allowed: train, validation, test, test-nominal"):
        physical_population("tset", "hanger")
    with pytest.raises(ConfigError, match="allowed: hanger, wheel"):
        physical_population("train", "kitchen")
    assert population_names() == ("train", "validation", "test", "test-nominal",
                                  "test-weak", "test-hesitant", "test-heldout")


def test_runs_meet_members_in_balanced_blocks():
    pop = physical_population("test-weak", "wheel")
    n = len(pop)
    block = [pop.member_index(5, r) for r in range(n, 2 * n)]
    assert sorted(block) == list(range(n))
    assert block == np.random.default_rng([5, 1, 7]).permutation(n).tolist()  # the rule
    assert block != [pop.member_index(6, r) for r in range(n, 2 * n)]
    assert pop.draw(np.random.default_rng(1)) in pop.members


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_members_are_distinct_by_behaviour(scenario):
    """No two members of a scenario (within a split, and test against train and
    validation) are within the tolerance of each other's signature."""
    sizes = {s: len(physical_population(s, scenario)) for s in SPLITS}
    sigs = np.concatenate([physical_population(s, scenario).signatures() for s in SPLITS])
    near = nearest(sigs, sizes)
    assert min(near.values()) >= 1.0, near


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_committed_signatures_are_this_simulation(scenario, sims):
    """A sample of members probed again: their signatures are the committed ones."""
    for split, family in (("train", "weak"), ("test", "extremes")):
        pop = physical_population(split, scenario)
        i = pop.families.index(family)
        sig = signature(sims[scenario], pop.members[i])
        assert distance(sig, pop.signatures()[i]) < 0.05


def test_the_distance_is_a_metric_of_the_signatures():
    sigs = physical_population("test-nominal", "hanger").signatures()[:4]
    d = distances(sigs)
    assert np.allclose(np.diag(d), 0.0, atol=1e-6) and np.allclose(d, d.T)
    shifted = sigs[0].copy()
    shifted[..., 0] += 0.6  # 0.6 N more force along x in every window
    assert distance(sigs[0], shifted) == pytest.approx(1.2)


def _within(value, lo, hi, tol):
    return lo - tol <= value <= hi + tol


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_members_are_within_their_familys_ranges(scenario, sims):
    grip = default_grip_force(sims[scenario].design)
    prefs = scenario_spec(scenario).preferences
    for split in SPLITS:
        for h, name in zip(*[(p := physical_population(split, scenario)).members,
                             p.families], strict=True):
            f = FAMILIES[name]
            for key in ("strength", "stiffness", "reaction_s", "hesitation_s", "speed"):
                assert _within(getattr(h, key), *getattr(f, key), 0.005), (name, key)
            assert _within(h.grip_force_n / grip, *f.grip, 0.06 / grip), name
            assert any(_within(h.stature_m, stature_at(h.sex, lo), stature_at(h.sex, hi),
                               0.0005) for lo, hi in f.stature_pct), name
            assert any(_within(h.body.bmi, lo, hi, 0.05 / h.stature_m**2)
                       for lo, hi in f.bmi), name
            assert h.preference in prefs and h.drive == "torque"


def test_the_body_changes_the_arm():
    """A small woman's arm: de Leva's female segments scaled by stature, the masses her body
    mass's fractions, the torso lower, the strength 0.52 x stature²; she lifts less at the
    handle than the default man; the default body restores the model exactly (every array as
    after the sim's first reset, a fresh sim's)."""
    sim = CarrySim(scenario_graph("hanger"))
    m = sim.model
    fore = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "human_forearm")
    hand = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "human_hand")
    torso = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "human_torso")
    sim.reset(1, 0, np.random.default_rng(0))
    fresh = copy.copy(m)
    lift_man = sim.max_lift_n()
    stature = stature_at("female", 5)
    woman = HumanParams(sex="female", stature_m=stature, body_mass_kg=bmi_mass(stature, 21))
    sim.reset(1, 0, np.random.default_rng(0), human=woman)
    assert m.body_pos[fore, 2] == pytest.approx(-0.2751 * stature / 1.735)  # upper arm
    assert m.body_pos[hand, 2] == pytest.approx(-0.2643 * stature / 1.735)  # forearm
    assert m.body_mass[fore] == pytest.approx(0.0138 * woman.body_mass_kg)
    assert m.body_pos[torso, 2] == pytest.approx(stature / 1.741)
    assert sim.arm_drive.hi[3] == pytest.approx(58.5 * 0.52 * (stature / 1.741) ** 2)
    assert sim.max_lift_n() < 0.6 * lift_man
    assert BodySize("female", stature).strength_scale() < 0.5
    sim.reset(1, 0, np.random.default_rng(0))
    for name in dir(fresh):
        value = getattr(fresh, name)
        if isinstance(value, np.ndarray):
            assert np.array_equal(getattr(m, name), value), name
    assert sim.max_lift_n() == lift_man


def test_human_params_refuse_bodies_and_drives_that_do_not_exist(sims):
    for bad in ({"sex": "other"}, {"stature_m": 2.5}, {"body_mass_kg": 20},
                {"drive": "hydraulic"}):
        with pytest.raises(ConfigError, match="human"):
            HumanParams.of(bad)
    with pytest.raises(ConfigError, match="drive 'muscle' cannot be simulated by a "
                                          "CarrySim of drive 'torque'"):
        sims["wheel"].reset(1, 0, np.random.default_rng(0), human=HumanParams(drive="muscle"))
    assert dataclasses.replace(HumanParams(), sex="female").body.sex == "female"


#: A seeded v0 episode (seed 7, 60 steps of uniform actions from default_rng(1)): its return
#: and the sum of its observations' magnitudes, as before the body became a parameter (the
#: SHA-256 of the observations was 14f11b4d052054fc, e5898e44250ce1e0). The compiled
#: control periods (hri_envs/physics/carry/stages.py) change the last bits, not the episode:
#: both within 1e-9 relative (tests/test_physics_continuous_reference.py for whole episodes).
V0 = {"hri_envs/HangerPandaContinuous-v0": (3.046585557250564, 2194.1294150214962),
      "hri_envs/WheelPandaContinuous-v0": (0.4711824582222092, 3437.5762569670296)}


@pytest.mark.parametrize("env_id", list(V0))
def test_the_v0_default_human_is_unchanged(env_id):
    env = gym.make(env_id)
    env.reset(seed=7)
    rng = np.random.default_rng(1)
    total, size = 0.0, 0.0
    for _ in range(60):
        obs, r, term, trunc, _ = env.step(rng.uniform(-1, 1, 7).astype(np.float32))
        total += r
        size += float(np.abs(np.asarray(obs, np.float64)).sum())
        assert not (term or trunc)
    assert total == pytest.approx(V0[env_id][0], rel=1e-9)
    assert size == pytest.approx(V0[env_id][1], rel=1e-9)


def test_the_muscle_arm_takes_its_own_anatomy_only():
    """MyoSuite's arm has one anatomy: its sim takes a muscle human of the default body (or
    a human whose drive is the sim's) and refuses another body or a torque human."""
    pytest.importorskip("myo_sim")
    pytest.importorskip("scipy")
    sim = CarrySim(scenario_graph("wheel"), drive="muscle")
    sim.reset(1, 0, np.random.default_rng(0), human=HumanParams(drive="muscle"))
    with pytest.raises(ConfigError, match="one anatomy"):
        sim.reset(1, 0, np.random.default_rng(0), human=HumanParams(stature_m=1.6))
    with pytest.raises(ConfigError, match="drive 'torque' cannot be simulated"):
        sim.reset(1, 0, np.random.default_rng(0), human=HumanParams(drive="torque"))
