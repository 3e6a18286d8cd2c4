"""Issue 42, item 3: a HumanSpec is what ``human=`` means in every env (the graph, Panda,
parallel, vector and continuous envs here; the JAX env in tests/test_jax_human_spec.py).
The physical envs read its body; the old forms (flat keywords, the continuous envs' mapping
and ``population=``, the Panda backend's ``physics={"preset": ...}``) are its shorthand and
give the same episodes; a field an env cannot honour is refused, naming it and the env.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs import hanger_continuous_v1, hanger_v0, wheel_v0
from hri_envs.errors import ConfigError
from hri_envs.humans.spec import HumanBody, HumanSpec

ROUTE = "rotate-over-down/over-up-rotate"
WEAK = HumanSpec(body=HumanBody("weak", {"strength": 0.7, "reaction_s": 0.1}))


def _trace(env, seed: int, steps: int, action) -> bytes:
    """Everything an episode shows, as bytes: observations, rewards, ends and infos."""
    out = [repr(env.reset(seed=seed)).encode()]
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(action)
        out.append(repr((obs, reward, terminated, truncated, sorted(info.items()))).encode())
        if np.all(terminated | truncated):
            break
    return b"".join(out)


# ----------------------------------------------------------------- the graph envs
def test_the_graph_env_and_the_vector_env_take_a_spec_as_their_keywords():
    spec = HumanSpec(preference="detour", passive=0.3, turn_back=0.5, rationality=8.0)
    keywords = {"preference": "detour", "human_passive": 0.3, "turn_back": 0.5,
                "human_rationality": 8.0}
    one = [gym.make("hri_envs/Wheel-v0", **given).unwrapped for given in ({"human": spec},
                                                                          keywords)]
    assert _trace(one[0], 4, 60, 0) == _trace(one[1], 4, 60, 0)
    vec = [gym.make_vec("hri_envs/Wheel-v0", num_envs=3, vectorization_mode="vector_entry_point",
                        **given) for given in ({"human": spec}, keywords)]
    assert _trace(vec[0], 4, 30, np.zeros(3, dtype=np.int64)) == _trace(
        vec[1], 4, 30, np.zeros(3, dtype=np.int64))


@pytest.mark.parametrize("make, where", [
    (lambda spec: gym.make("hri_envs/Hanger-v0", human=spec), "backend='graph'"),
    (lambda spec: hanger_v0.parallel_env(human=spec), "backend='graph'"),
    (lambda spec: gym.make_vec("hri_envs/Hanger-v0", num_envs=2,
                               vectorization_mode="vector_entry_point", human=spec),
     "the numpy vector env"),
])
def test_an_env_without_a_physical_human_refuses_a_body(make, where):
    with pytest.raises(ConfigError, match=f"{where}.*(has no physical human|HumanSpec.body)"
                       ) as err:
        make(HumanSpec(body=HumanBody("weak-human")))
    assert err.value.field == "human"


def test_a_seat_assigned_later_refuses_a_body():
    env = gym.make("hri_envs/Hanger-v0").unwrapped
    with pytest.raises(ConfigError, match="cannot honour HumanSpec.body") as err:
        env.human = HumanSpec(body=HumanBody(params={"human_force": 3.0}))
    assert err.value.field == "human"


def test_the_parallel_env_takes_a_spec_as_its_keywords_and_names_what_it_cannot_honour():
    spec = HumanSpec(preference="detour", turn_back=1.0)
    by_spec = wheel_v0.parallel_env(human=spec)
    by_keywords = wheel_v0.parallel_env(preference="detour", turn_back=1.0)
    assert by_spec.turn_back == by_keywords.turn_back == 1.0
    assert by_spec._episode._turn == by_keywords._episode._turn
    for field, value in (("passive", 0.2), ("rationality", 3.0), ("population", "test"),
                         ("params", (("k", 3),))):
        with pytest.raises(ConfigError, match=f"the parallel env cannot honour HumanSpec."
                                              f"{field}=") as err:
            hanger_v0.parallel_env(human=HumanSpec(**{field: value}))
        assert err.value.field == "human"


# ----------------------------------------------------------------- the Panda backend
def test_the_panda_envs_body_is_the_physics_options_of_the_human():
    pytest.importorskip("mujoco")
    body = HumanSpec(preference="straight", body=HumanBody("weak-human", {"human_force": 3.0}))
    envs = [gym.make("hri_envs/WheelPanda-v0", human=body).unwrapped,
            gym.make("hri_envs/WheelPanda-v0", preference="straight",
                     physics={"preset": "weak-human", "human_force": 3.0}).unwrapped]
    assert envs[0]._episode.sim.settings.base == envs[1]._episode.sim.settings.base
    assert envs[0]._episode.sim.settings.base != gym.make("hri_envs/WheelPanda-v0"
                                                 ).unwrapped._episode.sim.settings.base
    assert _trace(envs[0], 2, 3, 0) == _trace(envs[1], 2, 3, 0)
    pz = wheel_v0.parallel_env(backend="mujoco", human=HumanSpec(body=body.body))
    assert pz._episode.sim.settings.base == envs[0]._episode.sim.settings.base


@pytest.mark.parametrize("body, text", [
    (HumanBody("noisy-sensor"), "unknown body preset 'noisy-sensor'.*allowed: weak-human"),
    (HumanBody(params={"sensor_noise_n": 1.0}), r"unknown body param\(s\) 'sensor_noise_n'"),
    (HumanBody(params={"human_force": -1.0}), "the body's 'human_force' must be a number > 0"),
])
def test_the_panda_backend_refuses_a_body_that_is_not_its_human(body, text):
    pytest.importorskip("mujoco")
    with pytest.raises(ConfigError, match=text) as err:
        gym.make("hri_envs/HangerPanda-v0", human=HumanSpec(body=body))
    assert err.value.field == "human"


def test_a_panda_option_given_by_the_body_and_in_physics_is_refused():
    pytest.importorskip("mujoco")
    with pytest.raises(ConfigError, match="'human_force' given both") as err:
        gym.make("hri_envs/HangerPanda-v0", physics={"human_force": 3.0},
                 human=HumanSpec(body={"human_force": 4.0}))
    assert err.value.field == "human"


# ----------------------------------------------------------------- the continuous envs
def _carry(version: int = 1, **kwargs):
    pytest.importorskip("mujoco")
    with warnings.catch_warnings():  # gymnasium says v0 is out of date: it is, on purpose
        warnings.simplefilter("ignore", DeprecationWarning)
        return gym.make(f"hri_envs/HangerPandaContinuous-v{version}", **kwargs).unwrapped


def _carry_trace(env, seed: int = 3, steps: int = 15) -> bytes:
    rng = np.random.default_rng(seed)
    out = [env.reset(seed=seed)[0].tobytes()]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(
            rng.uniform(-1, 1, 7).astype(np.float32))
        out.append(obs.tobytes() + np.float64(reward).tobytes())
        if terminated or truncated:
            break
    return b"".join(out)


def test_the_continuous_envs_mapping_is_the_specs_body():
    mapping = {"preset": "weak", "strength": 0.7, "reaction_s": 0.1}
    by_spec, by_mapping = _carry(human=WEAK), _carry(human=mapping)
    assert by_spec.human == by_mapping.human == WEAK
    assert by_spec.human_params == by_mapping.human_params != _carry().human_params
    assert _carry_trace(by_spec) == _carry_trace(by_mapping)
    preference = _carry(human=HumanSpec(preference=ROUTE))
    assert preference.human_params == _carry(human={"preference": ROUTE}).human_params
    assert preference.human_params.preference == ROUTE


def test_the_continuous_envs_population_is_the_specs():
    by_spec, by_keyword = _carry(human=HumanSpec(population="test-weak")), _carry(
        population="test-weak")
    assert by_spec.population.content_hash() == by_keyword.population.content_hash()
    assert by_spec.human == by_keyword.human == HumanSpec(population="test-weak")
    assert _carry_trace(by_spec, 5, 5) == _carry_trace(by_keyword, 5, 5)


def test_the_continuous_parallel_env_takes_a_spec():
    pytest.importorskip("mujoco")
    env = hanger_continuous_v1.parallel_env(human=WEAK)
    assert env.env.human_params == _carry(human=WEAK).human_params


@pytest.mark.parametrize("field, value, keyword", [
    ("rationality", 5.0, "human_rationality"),
    ("passive", 0.2, "human_passive"),
    ("turn_back", 0.5, "turn_back"),
    ("params", (("k", 3),), "human_params"),
])
def test_the_continuous_env_refuses_a_scripted_field(field, value, keyword):
    with pytest.raises(ConfigError, match=f"the continuous env cannot honour HumanSpec."
                                          f"{field}=") as err:
        _carry(human=HumanSpec(**{field: value}))
    assert err.value.field == keyword


@pytest.mark.parametrize("version, kwargs, field, text", [
    (1, {"human": HumanSpec(population="train"), "population": "train"}, "population",
     "either as population= or as human=HumanSpec"),
    (0, {"human": HumanSpec(population="train")}, "population", "needs the v1 ids"),
    (1, {"human": HumanSpec(preference=ROUTE, body={"preference": ROUTE})}, "human",
     "preference either as HumanSpec.preference or in its body"),
    (1, {"human": HumanSpec(body={"strenght": 2.0})}, "human",
     r"unknown human parameter\(s\) 'strenght'"),
    (1, {"human": HumanSpec(body=HumanBody("weak-human"))}, "human",
     "unknown human preset 'weak-human'"),
    (1, {"human": HumanSpec(population="nobody")}, "population", "nobody"),
])
def test_a_continuous_spec_that_does_not_fit_is_refused(version, kwargs, field, text):
    with pytest.raises(ConfigError, match=text) as err:
        _carry(version, **kwargs)
    assert err.value.field == field


# ----------------------------------------------------------------- the spec itself
def test_a_body_is_plain_data_and_a_spec_without_one_reads_as_before():
    assert HumanSpec(body={"preset": "weak", "strength": 0.7}).body == HumanBody(
        "weak", (("strength", 0.7),))
    assert "body" not in HumanSpec().info()
    assert WEAK.info()["body"] == {"preset": "weak",
                                   "params": [["reaction_s", 0.1], ["strength", 0.7]]}
    with pytest.raises(ConfigError, match="body must be a HumanBody"):
        HumanSpec(body="weak")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="a human body's params must be a mapping"):
        HumanBody(params={1: 2})  # type: ignore[dict-item]


def test_a_v1_episodes_human_may_be_a_spec_without_a_population():
    env = _carry()
    traces = []
    for human in (WEAK, {"preset": "weak", "strength": 0.7, "reaction_s": 0.1}, None):
        out = [env.reset(seed=1, options={"human": human})[0].tobytes()]
        out += [env.step(np.full(7, 0.5, np.float32))[0].tobytes() for _ in range(40)]
        traces.append(b"".join(out))
    assert traces[0] == traces[1] != traces[2]
    with pytest.raises(ConfigError, match="reset option 'human' cannot honour HumanSpec"
                                          ".population") as err:
        env.reset(seed=1, options={"human": HumanSpec(population="train")})
    assert err.value.field == "population"


# ----------------------------------------------------------------- a backend's body
def _unknown_option(body: HumanBody) -> dict:
    """A broken body converter: an option no checker knows."""
    return {"human_height": 2.0}


def test_a_backends_body_converter_needs_an_options_checker_and_must_suit_it():
    from hri_envs.conformance import check_backend
    from hri_envs.envs.backends import BACKENDS, BackendSpec, register_backend

    graph = ("hri_envs.envs.episode:Episode", "hri_envs.envs.backends:GraphBatch")
    with pytest.raises(ConfigError, match="names body but no options checker") as err:
        register_backend(BackendSpec("own-body", *graph, body=f"{__name__}:_unknown_option"))
    assert err.value.field == "backend"
    register_backend(BackendSpec("own-body", *graph, body=f"{__name__}:_unknown_option",
                                 options="hri_envs.physics.panda.options:check_options"))
    try:
        with pytest.raises(ConfigError, match="options checker refuses.*human_height"):
            check_backend("own-body")
    finally:
        BACKENDS.unregister("own-body")
