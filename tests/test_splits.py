"""Frozen population splits: content hashes, what each split holds, balanced runs, seats."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from hri_bench.run.study import StudyConfig, run_study, summarize
from hri_envs.envs.vector import RobotVectorEnv
from hri_envs.errors import ConfigError
from hri_envs.humans.families import FAMILIES, GROUPS
from hri_envs.humans.splits import (
    ALL_PREFERENCES,
    MIXTURES,
    Component,
    MixtureHumans,
    MixtureSpec,
    population,
    population_hash,
    population_seat,
)
from hri_envs.task.scenarios import scenario_graph

#: The frozen content hashes (version 1 of every split): a change to any split's generator,
#: seeds or members must come with a new version, and a new hash here.
FROZEN = {
    ("train", "hanger"):
        "34e1d8f3dc658fe130017ffd3f992592e9f98d2ab4ec108facc5bd2d0fa1395a",
    ("validation", "hanger"):
        "9c2c98745be66af543fb9e843ba165d0e0170d096d9659f8624f7fadd580c72d",
    ("test", "hanger"):
        "bfc2c6d74ecc4b63e04bd2b7d0f3412a2cb0185cf6ca87283d3025a0fb5b17df",
    ("test-scripted", "hanger"):
        "6a3296799bfcd04407cfbeff9f6a9533305fb8acad7bdbf5307c7ded236edbf5",
    ("test-misspecified", "hanger"):
        "d999c942c12d956425fdbdf526e9b43f18fc41ae4852c7c17590ccc4f2982b83",
    ("test-adaptive", "hanger"):
        "9dc4ed920886e4b52d558e89cd983c0af585808f41626b9f204d18c2d54c66a1",
    ("test-inconsistent", "hanger"):
        "feb8ff89c56c49cc39c457d9ec4e6faeca5a3e742769e8bf01d35eaa31def2b4",
    ("train", "wheel"):
        "75b197c78ec4e41718c5429f0802fb240859b44b7d2a80d27b936cf1bdb7dbba",
    ("validation", "wheel"):
        "c2dcf0905b2eaa8c3a3c82019e622145c8a94049feae6d7b0da575d8c8a2293f",
    ("test", "wheel"):
        "dd6f96542d79536d5277e3e4945bbaf0c7f30ec000d71d6b22db6990a67caabf",
    ("test-scripted", "wheel"):
        "f33d8a1479a73823e4a8762d045fb837675123a877438124148fc324e2278cb3",
    ("test-misspecified", "wheel"):
        "ca8b044feb4f0a96c7fc62f4489f207fa33f441482c77da1baa2205e1cdd5409",
    ("test-adaptive", "wheel"):
        "39ba199962c709e02acb3fb75519872e8144668d8ca0a170afd4ab90c5d8447b",
    ("test-inconsistent", "wheel"):
        "57006b5c244d62d162832067fe6f764c8b30a18707ddbb524e1b7d849fdc00fa",
}


#: Split version 2 (suite v3's humans), frozen likewise.
FROZEN_V2 = {
    ("validation-v2", "hanger"):
        "0150f4654bb3a67a26c0f55c3a91e1ece7dd2767c0943ad93d8f48fe17dc7c12",
    ("test-v2", "hanger"):
        "46eedc75fed7d6a013eecf37c2315fb25e1c89e7699be20a4feeb84e2a923c05",
    ("test-v2-scripted", "hanger"):
        "abde116e4b31181f98d4b7e42d2872d12e782ea2b00a53e3551c0d6a3c77a25f",
    ("test-v2-misspecified", "hanger"):
        "5d50f0689ba48a4c16b99bbad23693cf9c21de2bbad133521740265555fd78e6",
    ("test-v2-adaptive", "hanger"):
        "aa3fe094c6d3edeadab0d4081c7024c7c1d545b4961bae3d73b963ebb09ed508",
    ("test-v2-inconsistent", "hanger"):
        "55c36bce834e78c507fe8476652e80672ae887d7fd4af1af0e8dbacb4df299da",
    ("validation-v2", "wheel"):
        "68461fbc374778db1b4b5cceb9d00732fa0b4482622a56c2e688775e7c43226a",
    ("test-v2", "wheel"):
        "41f5f67394514f8d85fa7118b367c3d788073df35216092b3b607a9e23137e00",
    ("test-v2-scripted", "wheel"):
        "496b6f0f41edd63cceb1c15870a80eda8cc06980ab9592bbf46bd39aa073bc44",
    ("test-v2-misspecified", "wheel"):
        "72bdd362da2de3cd0982d80bcb39684383d46470ceb3694d808de1d2626619dc",
    ("test-v2-adaptive", "wheel"):
        "d65ebb2ec9345d3ca1d879831f773e97c6adcafc9f0d113be7dea1fade98c873",
    ("test-v2-inconsistent", "wheel"):
        "3c95560ac052447c51fa5e59c9a40b779bf8e6331892d3b477999afbb96d8802",
}


#: Split version 3 (suite v4): its members distinct by behaviour (tests/test_splits_v3.py).
FROZEN_V3 = {
    ('validation-v3', 'hanger'):
        "42dd8308712eb503d3a4dffd9a9f6fe6324b4f657d1061dcbf7e37d28b573721",
    ('validation-v3-scripted', 'hanger'):
        "5b47de909b312e3ad750c89cec56ddf569c728c0be8cf12ea75426e949ba5833",
    ('validation-v3-misspecified', 'hanger'):
        "5f684d76b848e8979c43d77dfe7e61176cf0e92c21088cda8b3bb5016b71a305",
    ('validation-v3-adaptive', 'hanger'):
        "9f225e0e16e56ced955912f11a8310364ba10046d5757039e79bcfa66c571abe",
    ('validation-v3-inconsistent', 'hanger'):
        "d6c482319073b8bd3bbd5c2806c853cc20aaa0ab0d96f0988211b9217116d2aa",
    ('test-v3', 'hanger'):
        "af177658543a1af3869a14c845621502444f33113c57203be86006398967e318",
    ('test-v3-scripted', 'hanger'):
        "32bf52dfcf5639fbdad46154c869166338eac8043076316d3bc6d2b9befb38a5",
    ('test-v3-misspecified', 'hanger'):
        "3b5da4039a0643f89e2da15855d80c39eb97e857294c39a1d7293a1e5194d796",
    ('test-v3-adaptive', 'hanger'):
        "179bdded62f58f7288133b3a1f2fb429ad6cfc5293337971caa7a471eb91b5a6",
    ('test-v3-inconsistent', 'hanger'):
        "33209fa0e5d73bb7a40a39c549ea7727260ce273a482b732028c663751a172fa",
    ('validation-v3', 'wheel'):
        "536c4e45f4b8fa72b7d9c6cdf33cf27e892694b0fc724726d0a1d1d89f282071",
    ('validation-v3-scripted', 'wheel'):
        "7836b36f7d53dc82d27a29031c105633d044208e97a4947114417db8f0aed5b7",
    ('validation-v3-misspecified', 'wheel'):
        "bba244ede4672ae4cfdc4b51e475e4d758ac7b7438a9c2f6a66cea4fdfb77506",
    ('validation-v3-adaptive', 'wheel'):
        "951eab42affbc55b86116c34f4e5a7279234c1571f3eab154f5f25471d377b0b",
    ('validation-v3-inconsistent', 'wheel'):
        "3bb03b66d8c0c6ee38f1295ae42f530be6a66e57f847d4522b136c185370f8f9",
    ('test-v3', 'wheel'):
        "68d0f1033d91411996393f3bd1c7956a0f8d9e96f9c2f585281cfd76c23a12fd",
    ('test-v3-scripted', 'wheel'):
        "f655f6904323ad5d57d9b6e4fd49f2084dbb8c2450089434df69b838742e4fa9",
    ('test-v3-misspecified', 'wheel'):
        "37d6d5fc63583845832dfd9ea44d848be29349c6ceb7535339a0ec2a016d86b5",
    ('test-v3-adaptive', 'wheel'):
        "2119d9e4a595a62a9ec87520891cc84ed8fc7840b1a944710d4e558650235585",
    ('test-v3-inconsistent', 'wheel'):
        "fda185d5e11f8219e9d976e5593c42894eacbf5c98d2af15517c5650ef6a4501",
}

def test_every_split_is_frozen_under_its_hash():
    hashes = {key: spec.content_hash() for key, spec in MIXTURES.items()}
    assert {k: h for k, h in hashes.items() if k in FROZEN} == FROZEN
    assert {k: h for k, h in hashes.items() if k in FROZEN_V2} == FROZEN_V2
    assert {k: h for k, h in hashes.items() if k in FROZEN_V3} == FROZEN_V3
    assert set(hashes) - set(FROZEN) - set(FROZEN_V2) - set(FROZEN_V3) == {
        (f"validation-v2-{g}", sc) for g in GROUPS for sc in ("hanger", "wheel")}
    spec = MIXTURES[("test", "wheel")]
    for change in ({"generator_seed": 1}, {"members": 63}, {"version": "2"}):
        assert dataclasses.replace(spec, **change).content_hash() != FROZEN[("test", "wheel")]
    # The wording of the description is not content.
    assert dataclasses.replace(spec, description="x").content_hash() == FROZEN[("test", "wheel")]


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_the_test_split_holds_families_absent_from_train(scenario):
    def groups(name):
        return {FAMILIES[d.family].group for d in MIXTURES[(name, scenario)].member_draws}

    assert groups("train") == groups("validation") == {"scripted"}
    assert groups("test") == {"scripted", "misspecified", "adaptive", "inconsistent"}
    test = MIXTURES[("test", scenario)]
    assert test.held_out and not MIXTURES[("train", scenario)].held_out
    families = {d.family for d in test.member_draws}
    # Every family the split's mixture names, the rare rotate-low included (the built-in
    # families, as they were when the split was frozen: a family registered since is in none).
    assert families == {c.family for c in test.components} == {
        "preference", "low", "avoid", "rotate-low", "impatient", "follower", "trust", "wary",
        "fickle", "moody"}
    # The parts are the test split's own members, filtered.
    parts = [MIXTURES[(f"test-{g}", scenario)] for g in
             ("scripted", "misspecified", "adaptive", "inconsistent")]
    assert sum(p.size for p in parts) == test.size == 64
    assert sorted(d.label() for p in parts for d in p.member_draws) == sorted(
        d.label() for d in test.member_draws)


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_test_v2_holds_no_train_or_validation_human_and_enough_different_ones(scenario):
    """Suite v3's humans: compared by content (each member's model fingerprint)."""
    def models(name):
        return MIXTURES[(name, scenario)].fingerprints()

    tuning = {*models("train"), *models("validation"), *models("validation-v2")}
    test = models("test-v2")
    assert not tuning & set(test)
    assert len(set(test)) == len(test) == 160
    assert not set(models("validation-v2")) & {*models("train"), *models("validation")}
    parts = [models(f"test-v2-{g}") for g in GROUPS]
    assert all(len(set(p)) >= 32 for p in parts)
    assert sorted(f for p in parts for f in p) == sorted(test)  # the groups partition it


def test_a_distinct_split_draws_again_and_refuses_what_it_cannot_fill():
    train = MIXTURES[("train", "wheel")]
    # The wheel's deterministic preference humans are all train members: none is left.
    spec = MixtureSpec("x", "wheel", "2", "", 2, 0, (Component("preference", 1.0, (
        ("preference", (ALL_PREFERENCES,)),)),), distinct=True, exclude=("train",))
    with pytest.raises(ConfigError, match="gave 0 different humans"):
        spec.member_draws  # noqa: B018
    twice = dataclasses.replace(spec, exclude=())
    assert len(set(twice.fingerprints())) == 2  # both preferences, each once
    assert set(twice.fingerprints()) <= set(train.fingerprints())



def test_a_study_of_a_split_that_cannot_fill_is_refused_before_it_simulates(monkeypatch):
    """Issue 42: the study's check draws its split's members (once: forked workers inherit
    them), so a split that cannot give them all is bad input, not a failure mid-study."""
    spec = MixtureSpec("x", "wheel", "2", "", 2, 0, (Component("preference", 1.0, (
        ("preference", (ALL_PREFERENCES,)),)),), distinct=True, exclude=("train",))
    monkeypatch.setitem(MIXTURES, ("x", "wheel"), spec)
    with pytest.raises(ConfigError, match="gave 0 different humans") as err:
        StudyConfig(scenario="wheel", agents=("passive",), runs=2, episodes=1, population="x")
    assert err.value.field == "population"
    fine = dataclasses.replace(spec, exclude=())
    monkeypatch.setitem(MIXTURES, ("x", "wheel"), fine)
    StudyConfig(scenario="wheel", agents=("passive",), runs=2, episodes=1, population="x")
    assert "member_draws" in vars(fine)  # drawn by the check, before any unit runs

def test_a_studys_runs_meet_the_members_in_balanced_blocks():
    spec = MIXTURES[("test-adaptive", "wheel")]
    n = spec.size
    wheel = scenario_graph("wheel")
    first = [spec.draw(wheel, 3, r) for r in range(n)]
    assert sorted(map(str, first)) == sorted(map(str, spec.member_draws))
    second = [spec.draw(wheel, 3, r) for r in range(n, 2 * n)]
    assert sorted(map(str, second)) == sorted(map(str, spec.member_draws))
    assert first != second  # another order per block
    assert [spec.draw(wheel, 3, r) for r in reversed(range(n))][::-1] == first
    assert first != [spec.draw(wheel, 4, r) for r in range(n)]  # the seed orders them


def test_unknown_names_and_impossible_parameters_fail_naming_the_field():
    with pytest.raises(ConfigError, match="unknown population 'tset'.*allowed:.*test") as err:
        population("tset", "wheel")
    assert err.value.field == "population"
    with pytest.raises(ConfigError, match="not for 'wheel'") as err:
        population("hanger-all", "wheel")
    assert err.value.field == "population"
    with pytest.raises(ConfigError, match="k must be") as err:
        population("impatient", "wheel", {"k": 0})
    assert err.value.field == "human_params"
    with pytest.raises(ConfigError, match="has no parameter 'speed'") as err:
        StudyConfig("wheel", population="trust", human_params=(("speed", 2),))
    assert err.value.field == "human_params"
    with pytest.raises(ConfigError) as err:
        StudyConfig("wheel", population="test", human_passive=0.2)
    assert err.value.field == "human_passive"


def test_a_study_records_the_populations_version_and_hash(tmp_path):
    result = run_study(StudyConfig("hanger", agents=("passive",), runs=4, episodes=2,
                                   population="test-inconsistent"))
    doc = summarize(result)
    info = doc["population_info"]
    spec = MIXTURES[("test-inconsistent", "hanger")]
    assert info == {"name": "test-inconsistent", "version": "1", "hash": spec.content_hash(),
                    "held_out": True, "members": spec.size}
    family = summarize(run_study(StudyConfig("hanger", agents=("passive",), runs=2, episodes=1,
                                             population="impatient",
                                             human_params=(("k", 3),))))
    assert family["population_info"]["hash"] == population_hash(
        population("impatient", "hanger", {"k": 3}))
    assert family["settings"]["human_params"] == [["k", 3]]
    replay = StudyConfig.from_settings(json.loads(json.dumps(family["settings"])))
    assert replay.human_params == (("k", 3),)
    # A study without the later field reads as before: it is not written at its default.
    assert "human_params" not in StudyConfig("hanger").settings()


def test_a_split_draws_a_member_at_every_reset_in_the_vector_env():
    vec = RobotVectorEnv(16, "wheel", population="test")
    assert isinstance(vec.human, MixtureHumans)
    obs, _ = vec.reset(seed=5)
    first = [m.name for m in vec.human.models]
    assert len(set(first)) > 6
    for _ in range(150):
        obs, *_ = vec.step(np.array([np.flatnonzero(m)[-1] for m in obs["action_mask"]]))
    assert [m.name for m in vec.human.models] != first
    again = RobotVectorEnv(16, "wheel", population="test")
    again.reset(seed=5)
    assert [m.name for m in again.human.models] == first
    single = population_seat(vec.graph, "fickle")
    assert isinstance(single, MixtureHumans) and single.n_runs == 1
