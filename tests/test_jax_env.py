"""The JAX env equals the numpy vector env step for step on the same draws.

The numpy env (same-step autoreset, as the JAX env) is run as it is; the draws it consumed
are read back and handed to :meth:`JaxRobotEnv.step_given`: the human's two uniforms per
step (a copy of the human's generator, which draws ``(2, N)`` per step), and for every
episode that starts its start, intention, whether it turns back and (for a population) the
member drawn (a :class:`PopulationHumans` that records its draws). Both run in float64
(``jax.enable_x64``), so a Boltzmann human's inverse CDF compares the same numbers.
"""

import math
import subprocess
import sys

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

jax = pytest.importorskip("jax")
import jax.numpy as jnp  # noqa: E402

from hri_envs.envs.config import check_r0, scenario_graph  # noqa: E402
from hri_envs.envs.vector import RobotVectorEnv  # noqa: E402
from hri_envs.errors import ActionError, ConfigError  # noqa: E402
from hri_envs.humans.populations import (  # noqa: E402
    POPULATIONS,
    PopulationHumans,
    build_human,
)
from hri_envs.humans.protocol import all_rows  # noqa: E402
from hri_envs.humans.scripted import boltzmann_human, preferences_for  # noqa: E402
from hri_envs.humans.splits import population as named_population  # noqa: E402
from hri_envs.jax import JaxRobotEnv, Member, ResetDraws, StepDraws  # noqa: E402
from hri_envs.jax.tables import (  # noqa: E402
    OUTCOME_BITS,
    SUPPORTED_POPULATIONS,
    SUPPORTED_SPLITS,
    outcome_words,
    step_arrays,
)
from hri_envs.task.features import initial_theta  # noqa: E402
from hri_envs.task.scenarios import spec_of  # noqa: E402

SAME = AutoresetMode.SAME_STEP


class RecordingPopulation(PopulationHumans):
    """A population seat that keeps the members it drew (PopulationHumans.draw's recipe)."""

    def draw(self, rng, rows=None):
        idx = all_rows(rows, self.n_runs)
        draws = [self.spec.sample(self.graph, rng) for _ in idx]
        self.drawn = dict(zip(idx.tolist(), draws, strict=True))
        self.assign(idx, [build_human(self.graph, d) for d in draws])


class RecordingMixture(RecordingPopulation):
    """A split's members (:meth:`MixtureSpec.sample`) as scripted humans in a table seat.

    The numpy envs seat a split as :class:`MixtureHumans`, which draws three uniforms per
    step from one CDF (passive folded in), the JAX env two (passive, choice), as the
    scripted seats; so the equality is checked on the members, each built as the split
    builds it (:func:`build_human`), in the scripted humans' seat.
    """

    def __init__(self, graph, spec, n_runs):
        super().__init__(graph, "preferences", n_runs)
        self.mixture = spec

    def draw(self, rng, rows=None):
        idx = all_rows(rows, self.n_runs)
        draws = [self.mixture.sample(self.graph, rng) for _ in idx]
        self.history = [*getattr(self, "history", []), *draws]
        self.drawn = dict(zip(idx.tolist(), draws, strict=True))
        self.assign(idx, [build_human(self.graph, d) for d in draws])


def _as_plain(draw, scenario):
    """A split member (family "preference") as the fields of a plain HumanDraw."""
    if draw.family is None:
        return draw
    p = dict(draw.params)
    return type(draw)(p["preference"], rationality=p.get("rationality", math.inf),
                      passive=p.get("passive", 0.0))


def _members(jenv, params, vec, rows, n):
    """(n,) Member arrays: the recorded draws of ``rows`` (others: the fixed human)."""
    fixed = params.fixed
    entry = np.full(n, int(fixed.entry), np.int32)
    beta = np.full(n, math.inf)
    passive = np.full(n, float(fixed.passive))
    turn = np.full(n, float(fixed.turn_back))
    if isinstance(vec.human, RecordingPopulation | RecordingMixture):
        prefs = preferences_for(jenv.scenario)
        for i in rows:
            d = _as_plain(vec.human.drawn[int(i)], jenv.scenario)
            entry[i], beta[i] = prefs.index(d.preference), d.rationality
            passive[i], turn[i] = d.passive, d.turn_back
    return Member(jnp.asarray(entry), jnp.asarray(beta), jnp.asarray(passive),
                  jnp.asarray(turn), jnp.asarray(entry))


def _reset_draws(jenv, params, vec, obs, rows, n):
    """What the numpy env drew for the episodes of ``rows`` (the others' are unused)."""
    turning = vec._turn_at != -1
    return ResetDraws(jnp.asarray(obs["start"], jnp.int32),
                      jnp.asarray(vec.intention, jnp.int32),
                      jnp.asarray(np.where(turning, 0.0, 1.0)),
                      _members(jenv, params, vec, rows, n))


def _same(name, got, want):
    got, want = np.asarray(got), np.asarray(want)
    bad = np.argwhere(got != want.astype(got.dtype))
    assert bad.size == 0, f"{name} differs at (step, env) {bad[:5].tolist()}"


def _stack(items):
    return jax.tree.map(lambda *xs: jnp.stack(xs), *items)


def run_pair(scenario, n=48, steps=80, seed=0, population=None, human=None, **kwargs):
    """Step both envs with the same robot actions and draws; compare every output.

    The numpy env runs first and its draws are recorded; the JAX env then replays them in
    one ``lax.scan`` (one compilation per setting).
    """
    graph = scenario_graph(scenario)
    with jax.enable_x64(True):
        if population in SUPPORTED_SPLITS:
            seat = RecordingMixture(graph, named_population(population, scenario), n)
            vec = RobotVectorEnv(n, scenario, human=seat, autoreset_mode=SAME, **kwargs)
        elif population is not None:
            seat = RecordingPopulation(graph, population, n)
            vec = RobotVectorEnv(n, scenario, human=seat, autoreset_mode=SAME, **kwargs)
        else:
            vec = RobotVectorEnv(n, scenario, human=human, autoreset_mode=SAME, **kwargs)
        jenv = JaxRobotEnv(scenario, population=population, human=human, **kwargs)
        params = jenv.default_params
        obs, _ = vec.reset(seed=seed)
        mirror = np.random.Generator(type(vec.human.rng.bit_generator)())
        mirror.bit_generator.state = vec.human.rng.bit_generator.state
        first = _reset_draws(jenv, params, vec, obs, np.arange(n), n)
        rng = np.random.default_rng(seed + 1)
        n_a = graph.n_actions
        want = {k: [] for k in ("obs", "intention", "reward", "terminated", "truncated",
                                "aborted", "invalid_action")}
        actions, draws = [], []
        for _ in range(steps):
            want["obs"].append(obs)
            want["intention"].append(vec.intention)
            # the robot: a random valid action, sometimes any action (aborted steps)
            valid = obs["action_mask"].astype(bool)
            pick = np.argmax(rng.random((n, n_a)) * valid, axis=1)
            action = np.where(rng.random(n) < 0.15, rng.integers(n_a, size=n), pick)
            u = mirror.random((2, n))  # what the numpy human draws (unused if greedy)
            obs, reward, term, trunc, info = vec.step(action)
            ended = np.flatnonzero(term | trunc)
            actions.append(jnp.asarray(action))
            draws.append(StepDraws(jnp.asarray(u[0]), jnp.asarray(u[1]),
                                   _reset_draws(jenv, params, vec, obs, ended, n)))
            for key, value in (("reward", reward), ("terminated", term),
                               ("truncated", trunc), ("aborted", info["aborted"]),
                               ("invalid_action", info["invalid_action"])):
                want[key].append(value)

        step = jax.vmap(jenv.step_given, in_axes=(0, 0, 0, None))

        @jax.jit
        def replay(first, actions, draws):
            obs0, state0 = jax.vmap(jenv.reset_given, in_axes=(0, None))(first, params)

            def body(carry, x):
                obs, state = carry
                out = (obs, state.intention)
                obs, state, reward, _, info = step(state, x[0], x[1], params)
                return (obs, state), (out, reward, info)

            _, (seen, reward, info) = jax.lax.scan(body, (obs0, state0), (actions, draws))
            return seen, reward, info

        (jobs, jintention), jreward, jinfo = replay(first, jnp.stack(actions), _stack(draws))
        for key in want["obs"][0]:
            _same(key, jobs[key], np.stack([o[key] for o in want["obs"]]))
        _same("intention", jintention, np.stack(want["intention"]))
        np.testing.assert_array_equal(np.asarray(jreward), np.stack(want["reward"]))
        for key in ("terminated", "truncated", "aborted", "invalid_action"):
            _same(key, jinfo[key], np.stack(want[key]))
        return vec


CASES = [
    ("hanger", {}),
    ("hanger", {"r0": -0.5, "reward": "no-free-toggle", "max_cycles": 7}),
    ("hanger", {"preference": "over-rotate-down/up-over-rotate", "turn_back": 0.6,
                "human_passive": 0.3}),
    ("wheel", {"preference": "straight", "human_passive": 0.2, "turn_back": 0.5}),
    ("wheel", {"preference": "detour", "human_rationality": 3.0, "max_cycles": 15}),
    ("wheel", {"reward": "no-free-toggle", "turn_back": 1.0}),
]


@pytest.mark.parametrize(("scenario", "kwargs"), CASES)
def test_equals_the_numpy_env_with_one_human(scenario, kwargs):
    run_pair(scenario, seed=3, **kwargs)


@pytest.mark.parametrize(("scenario", "population"), [
    (scenario, name) for name in SUPPORTED_POPULATIONS
    for scenario in ("hanger", "wheel") if scenario in POPULATIONS[name].scenarios])
def test_equals_the_numpy_env_with_a_population(scenario, population):
    run_pair(scenario, seed=11, population=population, max_cycles=25,
             reward="no-free-toggle" if population == "heldout" else "paper")


@pytest.mark.parametrize("split", SUPPORTED_SPLITS)
@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_equals_the_numpy_env_with_a_split(scenario, split):
    """The frozen member lists (passive and Boltzmann members among them) step alike."""
    vec = run_pair(scenario, seed=13, population=split, max_cycles=25)
    kinds = {(d.rationality < math.inf, d.passive > 0)
             for d in (_as_plain(x, scenario) for x in vec.human.history)}
    assert len(kinds) == 3, kinds  # it met deterministic, passive and Boltzmann members


def test_the_human_spec_is_taken_as_the_numpy_env_takes_it():
    """The JAX env takes a HumanSpec (the envs' flat keywords are its shorthand) and
    refuses what it cannot hold as tables, naming it."""
    from hri_envs.humans.spec import HumanSpec

    by_spec = JaxRobotEnv("wheel", human=HumanSpec(preference="detour", passive=0.2))
    by_keywords = JaxRobotEnv("wheel", preference="detour", human_passive=0.2)
    assert by_spec._fixed == by_keywords._fixed and by_spec._passive
    assert JaxRobotEnv("hanger", human=HumanSpec(population="train")).population is not None
    for spec in (HumanSpec(population="impatient", params=(("k", 3),)),
                 HumanSpec(population="tests.helpers_humans:Copycat")):
        with pytest.raises(ConfigError) as exc:
            JaxRobotEnv("hanger", human=spec)
        assert exc.value.field == "population"


def test_a_split_with_stateful_families_is_refused():
    with pytest.raises(ConfigError) as exc:
        JaxRobotEnv("hanger", population="test")
    assert exc.value.field == "population" and "train" in str(exc.value)


def test_equals_the_numpy_env_with_a_boltzmann_theta_human():
    graph = scenario_graph("hanger")
    theta = initial_theta(graph.n_features) + np.random.default_rng(0).uniform(
        -0.5, 0.5, graph.n_features)
    human = boltzmann_human(graph, theta, temperature=8.0, passive=0.1)
    run_pair("hanger", seed=5, human=human)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenario=st.sampled_from(["hanger", "wheel"]), seed=st.integers(0, 2**31),
       reward=st.sampled_from(["paper", "no-free-toggle"]),
       r0=st.sampled_from([-0.1, -0.25, -0.33, -0.9]), max_cycles=st.integers(1, 60),
       population=st.sampled_from([None, "preferences", "heldout", "mixed-rationality",
                                   "train"]),
       passive=st.sampled_from([0.0, 0.25]), turn=st.sampled_from([0.0, 0.7]))
def test_equals_the_numpy_env_property(scenario, seed, reward, r0, max_cycles, population,
                                       passive, turn):
    """Generated settings and seeds: states, rewards, masks and episode ends agree."""
    kwargs = {"reward": reward, "r0": r0, "max_cycles": max_cycles}
    if population is None:
        kwargs.update(human_passive=passive, turn_back=turn)
    run_pair(scenario, n=24, steps=60, seed=seed, population=population, **kwargs)


# --------------------------------------------------------------------------- key mode
@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_keys_jit_and_vmap(scenario):
    """reset/step from keys under jit + vmap, and the batched path with one key."""
    env = JaxRobotEnv(scenario, population="heldout", episodes_per_human=3, drift=2)
    params = env.default_params
    n = 256
    keys = jax.random.split(jax.random.key(0), n)
    obs, state = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    step_batch = jax.jit(env.step_batch)
    obs_b, state_b = env.reset_batch(jax.random.key(0), n, params)
    valid = np.asarray(env.steps.action_mask, bool)
    ends = {"keys": 0, "batch": 0}
    mixed = []  # steps where many batch envs began an episode: did they draw alike?
    for t in range(30):
        for path, o, now in (("keys", obs, state), ("batch", obs_b, state_b)):
            mask = np.asarray(o["action_mask"]).astype(bool)
            assert np.array_equal(mask, valid[np.asarray(now.state)]), path
            action = jnp.asarray(np.argmax(mask * np.random.default_rng(t).random(mask.shape),
                                           1))
            if path == "keys":
                obs, state, reward, done, _ = step(jax.random.split(jax.random.key(t), n),
                                                   state, action, params)
            else:
                obs_b, state_b, reward, done, _ = step_batch(jax.random.key(t), state_b,
                                                             action, params)
                began = np.asarray(state_b.start)[np.asarray(done)]
                if began.size >= 10:
                    mixed.append(np.unique(began).size > 1)
            ends[path] += int(done.sum())
            r = np.asarray(reward, dtype=float)[:, None]
            assert np.isclose(r, [-1.0, env.r0, 0.0], atol=1e-6).any(axis=1).all(), path
            assert np.all(np.asarray((state if path == "keys" else state_b).episode) < 3)
    assert ends["keys"] > 0 and ends["batch"] > 0
    assert mixed and all(mixed)  # one key per batch step, yet a draw of its own per env


def test_same_key_same_trajectory():
    env = JaxRobotEnv("wheel", population="heldout")
    params = env.default_params
    out = []
    step = jax.jit(env.step_batch)
    for _ in range(2):
        obs, state = env.reset_batch(jax.random.key(7), 64, params)
        for t in range(20):
            obs, state, reward, done, _ = step(jax.random.key(t), state,
                                               jnp.zeros(64, jnp.int32), params)
        out.append(np.asarray(state.state))
    assert np.array_equal(out[0], out[1])
    obs, state = env.reset_batch(jax.random.key(8), 64, params)
    for t in range(20):
        obs, state, reward, done, _ = step(jax.random.key(100 + t), state,
                                           jnp.zeros(64, jnp.int32), params)
    assert not np.array_equal(out[0], np.asarray(state.state))  # the key matters


def test_population_draw_matches_the_recipe():
    """member_from_uniforms applies PopulationSpec.sample's recipe to the same uniforms."""
    with jax.enable_x64(True):
        env = JaxRobotEnv("hanger", population="heldout")
        params = env.default_params
        prefs = preferences_for("hanger")
        for seed in range(20):
            rng = np.random.default_rng(seed)
            u = np.random.default_rng(seed).random(4)
            d = POPULATIONS["heldout"].sample(scenario_graph("hanger"), rng)
            m = env.member_from_uniforms(jnp.asarray(np.r_[u, 0.5]), params)
            assert int(m.entry) == prefs.index(d.preference)
            np.testing.assert_allclose(float(m.beta), d.rationality, rtol=1e-12)
            np.testing.assert_allclose(float(m.passive), d.passive, rtol=1e-12)
            np.testing.assert_allclose(float(m.turn_back), d.turn_back, rtol=1e-12)


def test_drift_switches_to_another_preference():
    env = JaxRobotEnv("hanger", population="preferences", episodes_per_human=6, drift=3)
    params = env.default_params
    for i in range(50):
        u = jax.random.uniform(jax.random.key(i), (5,))
        m = env.member_from_uniforms(u, params)
        assert int(m.drift_entry) != int(m.entry)
        assert int(env._entry(m, jnp.int32(2))) == int(m.entry)
        assert int(env._entry(m, jnp.int32(3))) == int(m.drift_entry)


def test_bad_settings_name_the_field():
    with pytest.raises(ConfigError) as exc:
        JaxRobotEnv("hanger", population="theta")
    assert exc.value.field == "population"
    with pytest.raises(ConfigError) as exc:
        JaxRobotEnv("hanger", episodes_per_human=0)
    assert exc.value.field == "episodes_per_human"
    with pytest.raises(ConfigError) as exc:
        JaxRobotEnv("hanger", drift=True)
    assert exc.value.field == "drift"
    with pytest.raises(ConfigError) as exc:
        JaxRobotEnv("hanger", r0=0.5)
    assert exc.value.field == "r0"


def test_hri_envs_does_not_import_jax():
    code = "import sys, hri_envs, hri_envs.envs; assert 'jax' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_without_jax_one_line_says_how_to_install():
    code = ("import sys; sys.modules['jax'] = None\n"
            "try:\n    import hri_envs.jax\nexcept ImportError as e:\n    print(e)")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True).stdout.strip()
    assert out.count("\n") == 0 and "pip install" in out and "[jax]" in out, out


@pytest.mark.parametrize(("scenario", "reward", "r0"), [("hanger", "paper", None),
                                                        ("wheel", "no-free-toggle", -0.4)])
def test_outcome_words_unpack_to_the_step_table(scenario, reward, r0):
    """One word per joint step holds every field of the step table, bit for bit."""
    graph = scenario_graph(scenario)
    steps = step_arrays(graph, check_r0(r0, spec_of(graph)), reward)
    words, rewards = outcome_words(steps)
    b = OUTCOME_BITS
    assert words.dtype == np.int32 and words.shape == steps.next_state.shape
    assert np.array_equal(words >> b["next_state"] & 255, steps.next_state)
    for flag in ("terminated", "lifted", "aborted", "robot_invalid"):
        assert np.array_equal((words >> b[flag] & 1).astype(bool), getattr(steps, flag)), flag
    assert np.array_equal(rewards[words >> b["reward"]], steps.reward)


def test_a_fixed_human_draws_a_new_drift_each_trial():
    """Without a population the human is fixed, but each trial drifts to a new draw."""
    env = JaxRobotEnv("hanger", episodes_per_human=2, drift=1)
    params = env.default_params
    n = 64
    obs, state = env.reset_batch(jax.random.key(0), n, params)
    step = jax.jit(env.step_batch)
    seen = [set() for _ in range(n)]
    for t in range(300):
        mask = np.asarray(obs["action_mask"]).astype(bool)
        action = jnp.asarray(np.argmax(mask * np.random.default_rng(t).random(mask.shape), 1))
        obs, state, _, _, _ = step(jax.random.key(t), state, action, params)
        for i, d in enumerate(np.asarray(state.member.drift_entry)):
            seen[i].add(int(d))
        assert np.all(np.asarray(state.member.entry) == int(params.fixed.entry))
    assert np.mean([len(s) > 1 for s in seen]) > 0.5


# --------------------------------------------------------------------------- bad inputs
@pytest.fixture(scope="module")
def hanger_env():
    env = JaxRobotEnv("hanger")
    params = env.default_params
    _, state = env.reset(jax.random.key(0), params)
    _, batch = env.reset_batch(jax.random.key(0), 4, params)
    return env, params, state, batch


@pytest.mark.parametrize("action", [0.5, 1.7, True, np.True_, "1", None, [1],
                                    np.float32(2.0), jnp.float32(0.5), jnp.bool_(True)])
def test_a_non_integer_action_is_refused_not_truncated(hanger_env, action):
    env, params, state, _ = hanger_env
    with pytest.raises(ActionError, match=r"step: action must be an integer in 0\.\.9"):
        env.step(jax.random.key(1), state, action, params)


@pytest.mark.parametrize("action", [-1, 10, 99, np.int64(10), jnp.int32(-5)])
def test_an_action_out_of_range_is_refused_when_concrete(hanger_env, action):
    env, params, state, _ = hanger_env
    with pytest.raises(ActionError, match=f"got {int(action)}"):
        env.step(jax.random.key(1), state, action, params)


@pytest.mark.parametrize(("action", "what"), [
    (jnp.array([0.5, 0.0, 0.0, 0.0]), "float32"), (jnp.array([True] * 4), "bool"),
    (jnp.array([1, 2, 3]), r"shape \(3,\)"), (jnp.array([0, 1, 10, 2]), r"got \[10\]"),
    (np.array([[0, 1, 2, 3]]), r"shape \(1, 4\)"), ([0, 1, 2, 3], "list")])
def test_step_batch_refuses_bad_actions(hanger_env, action, what):
    env, params, _, batch = hanger_env
    with pytest.raises(ActionError, match=f"step_batch: action must be .*{what}"):
        env.step_batch(jax.random.key(1), batch, action, params)


def test_under_jit_a_float_action_is_refused_while_tracing(hanger_env):
    """Dtypes and shapes are static: checked once when tracing, nothing in the step."""
    env, params, _, batch = hanger_env
    step = jax.jit(env.step_batch)
    with pytest.raises(ActionError, match="float32"):
        step(jax.random.key(1), batch, jnp.zeros(4, jnp.float32), params)
    with pytest.raises(ActionError, match="float32"):
        jax.jit(jax.vmap(env.step, in_axes=(None, 0, 0, None)))(
            jax.random.key(1), batch, jnp.zeros(4, jnp.float32), params)
    obs, _, _, _, _ = step(jax.random.key(1), batch, jnp.zeros(4, jnp.int32), params)
    assert obs["state"].shape == (4,)


@pytest.mark.parametrize(("field", "value"), [
    ("state", 10000), ("state", -5), ("start", 3), ("intention", -1), ("steps", 100),
    ("turn_at", -2), ("last_human", 10), ("episode", 1)])
def test_a_state_no_step_makes_is_refused(hanger_env, field, value):
    env, params, state, batch = hanger_env
    bad = state._replace(**{field: jnp.int32(value)})
    with pytest.raises(ConfigError, match=f"state.{field} must be in .*got {value}") as exc:
        env.step(jax.random.key(1), bad, 0, params)
    assert exc.value.field == "state"
    bad = batch._replace(**{field: getattr(batch, field).at[2].set(value)})
    with pytest.raises(ConfigError, match=f"state.{field} must be in .*got \\[{value}\\]"):
        env.step_batch(jax.random.key(1), bad, jnp.zeros(4, jnp.int32), params)


@pytest.mark.parametrize(("field", "value"), [("entry", 99), ("passive", 1.5),
                                              ("turn_back", -0.1), ("beta", math.nan),
                                              ("beta", 0.0)])
def test_a_member_no_draw_makes_is_refused(hanger_env, field, value):
    env, params, state, _ = hanger_env
    old = getattr(state.member, field)
    bad = state._replace(member=state.member._replace(
        **{field: jnp.asarray(value, old.dtype)}))
    with pytest.raises(ConfigError, match=f"state.member.{field} must be"):
        env.step(jax.random.key(1), bad, 0, params)


def test_a_state_of_the_wrong_dtype_or_shape_is_refused(hanger_env):
    env, params, state, batch = hanger_env
    with pytest.raises(ConfigError, match=r"state.state must be an integer array of shape \(\)"):
        env.step(jax.random.key(1), state._replace(state=jnp.float32(3)), 0, params)
    with pytest.raises(ConfigError, match=r"state.start must be an integer array of shape"):
        env.step_batch(jax.random.key(1), batch._replace(start=batch.start[:3]),
                       jnp.zeros(4, jnp.int32), params)
    with pytest.raises(ConfigError, match="EnvState"):
        env.step(jax.random.key(1), {"state": 0}, 0, params)
    with pytest.raises(ConfigError, match=r"shape \(N,\)"):
        env.step_batch(jax.random.key(1), state, jnp.zeros((), jnp.int32), params)


def test_another_scenarios_params_are_refused(hanger_env):
    env, _, state, batch = hanger_env
    wheel = JaxRobotEnv("wheel").default_params
    with pytest.raises(ConfigError, match=r"params.outcome has shape .*\(the hanger") as exc:
        env.step(jax.random.key(1), state, 0, wheel)
    assert exc.value.field == "params"
    for call in (lambda: env.reset(jax.random.key(0), wheel),
                 lambda: env.reset_batch(jax.random.key(0), 4, wheel),
                 lambda: jax.jit(env.step_batch)(jax.random.key(1), batch,
                                                 jnp.zeros(4, jnp.int32), wheel)):
        with pytest.raises(ConfigError, match="another scenario"):
            call()
    with pytest.raises(ConfigError, match="another scenario"):  # another population's
        env.reset(jax.random.key(0), JaxRobotEnv("hanger", population="train").default_params)
    with pytest.raises(ConfigError, match="EnvParams"):
        env.reset(jax.random.key(0), {"outcome": 0})


@pytest.mark.parametrize("n", [1.5, -1, 0, True, "2", 2**28 + 1, None])
def test_reset_batch_refuses_a_count_that_is_not_a_whole_number_of_envs(hanger_env, n):
    env, params, _, _ = hanger_env
    with pytest.raises(ConfigError, match="reset_batch's n must be a whole number") as exc:
        env.reset_batch(jax.random.key(0), n, params)
    assert exc.value.field == "n"


def test_checked_inputs_step_as_before(hanger_env):
    """The checks change nothing for good inputs: eager, jit and numpy integer actions."""
    env, params, state, batch = hanger_env
    action = jnp.array([0, 3, 5, 9], jnp.int32)
    eager = env.step_batch(jax.random.key(3), batch, action, params)
    jitted = jax.jit(env.step_batch)(jax.random.key(3), batch, action, params)
    numpy_int = env.step_batch(jax.random.key(3), batch, np.asarray(action, np.int64), params)
    for got in (jitted, numpy_int):
        for a, b in zip(jax.tree.leaves(eager), jax.tree.leaves(got), strict=True):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    one = env.step(jax.random.key(3), state, np.int64(4), params)
    assert int(one[1].steps) in (0, 1)


@pytest.mark.parametrize("index", [2**28, 2**28 + 5, -1, 1.5, True, np.array([0, 2**28]),
                                   2**70])
def test_an_env_index_that_would_wrap_to_another_envs_numbers_is_refused(hanger_env, index):
    """Issue 43: index 2**28 drew env 0's numbers (16 index + stream wraps in 32 bits)."""
    from hri_envs.jax.env import uniform

    env, params, _, _ = hanger_env
    key = jax.random.key(0)
    seed = jax.random.bits(key, (2,), jnp.uint32)
    for draw in (lambda: env.draws(key, params, index), lambda: uniform(seed, index, 1)):
        with pytest.raises(ConfigError, match=r"an env's index must be a whole number in "
                                              r"0\.\.268,435,455") as exc:
            draw()
        assert exc.value.field == "index"


def test_the_last_index_of_the_largest_batch_draws_its_own_numbers(hanger_env):
    from hri_envs.jax.env import MAX_BATCH, uniform

    env, params, _, _ = hanger_env
    seed = jax.random.bits(jax.random.key(0), (2,), jnp.uint32)
    last = jnp.arange(MAX_BATCH - 2, MAX_BATCH, dtype=jnp.uint32)
    assert len({float(uniform(seed, i, s)) for i in (0, *last.tolist()) for s in (0, 15)}) == 6
    jitted = jax.jit(lambda i: uniform(seed, i, 0))(jnp.uint32(3))  # traced: not checked
    assert float(jitted) == float(uniform(seed, 3, 0))
