"""The robot against a scripted human as pure JAX functions: ``reset`` and ``step``.

:class:`JaxRobotEnv` is :class:`~hri_envs.envs.vector.RobotVectorEnv`'s task written as
functions of an env state and a PRNG key, for ``jax.jit``, ``jax.vmap`` and ``lax.scan``
(gymnax's API: ``obs, state = env.reset(key, params)``, ``obs, state, reward, done, info =
env.step(key, state, action, params)``, autoreset in the same step). Its arrays are the
numpy env's own tables (:mod:`hri_envs.jax.tables`), so no rule is written twice, and on
the same draws it equals the numpy env step for step (``tests/test_jax_env.py``).

Randomness is split from the rules: :meth:`JaxRobotEnv.step_given` takes the step's draws
(:class:`StepDraws`: the human's two uniforms, a new episode's start, intention and
turning-back uniform, a new human) as inputs; :meth:`~JaxRobotEnv.step` makes them from a
key. A key's draws are a counter-based hash (lowbias32) of one threefry draw per call, so
:meth:`step_batch`, which takes one key for a whole batch, draws once per step, not once
per env. What a step costs on a CPU, and why it is written as it is (one gather for the
whole outcome, short tables as selects): docs/rl.md, "What a step of the JAX env costs".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces

from hri_envs.checks import check_whole
from hri_envs.envs.config import check_env_settings, scenario_graph
from hri_envs.envs.spaces import robot_observation_space
from hri_envs.errors import ActionError, ConfigError
from hri_envs.humans.populations import PopulationSpec, validate_drift
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.seat import human_spec
from hri_envs.humans.spec import HumanSpec
from hri_envs.humans.splits import MixtureSpec
from hri_envs.jax.tables import (
    OUTCOME_BITS,
    HumanBank,
    PopulationArrays,
    StepArrays,
    human_bank,
    is_plain,
    outcome_words,
    population_arrays,
    step_arrays,
)
from hri_envs.task.actions import WAIT
from hri_envs.task.scenarios import spec_of

__all__ = ["OUTCOME_BITS", "EnvParams", "EnvState", "JaxRobotEnv", "Member", "ResetDraws",
           "StepDraws", "uniform", "uniforms"]

Array = jax.Array
#: Draw streams of one env step (see :func:`uniforms`).
N_STREAMS = 10
#: The most envs of one batch (:func:`uniform` hashes ``16 index + stream`` in 32 bits).
MAX_BATCH = 2**28


class Member(NamedTuple):
    """One env's human: a bank entry with its rates (scalars; a leading axis when batched).

    Attributes:
        entry: int32, the bank entry (:class:`~hri_envs.jax.tables.HumanBank`).
        beta: float, rationality β of a Boltzmann member (``inf``: the entry's own policy).
        passive: float, probability of waiting in a step.
        turn_back: float, probability per episode of turning back halfway.
        drift_entry: int32, the entry after the human drifts (the env's ``drift``).
    """

    entry: Array
    beta: Array
    passive: Array
    turn_back: Array
    drift_entry: Array


class EnvState(NamedTuple):
    """The state of one env (scalars; a leading axis (N,) when batched).

    Attributes:
        state: int32, the task state s.
        start: int32, the episode's start support.
        intention: int32, the human's current goal ι (the start after turning back).
        lifted: bool, the object has left the start support.
        steps: int32, steps taken in the episode.
        turn_at: int32, the state where the human turns back in this episode (-1: never).
        last_human: int32, the human's last action (wait at the start).
        member: The human (:class:`Member`).
        episode: int32, the episode's index among those with this human (a trial).
    """

    state: Array
    start: Array
    intention: Array
    lifted: Array
    steps: Array
    turn_at: Array
    last_human: Array
    member: Member
    episode: Array


class ResetDraws(NamedTuple):
    """What starting an episode draws (per env).

    Attributes:
        start: int32, the start support.
        intention: int32, the intention ι (≠ start).
        u_turn: float in [0, 1), the episode turns back when ``u_turn < turn_back``.
        member: The new human, used when the episode begins a new trial.
    """

    start: Array
    intention: Array
    u_turn: Array
    member: Member


class StepDraws(NamedTuple):
    """What one step of one env draws.

    Attributes:
        u_passive: float in [0, 1), the human waits when ``u_passive < passive``.
        u_choice: float in [0, 1), samples a stochastic human's action (inverse CDF).
        reset: The draws of the episode that starts if this step ends one (autoreset).
    """

    u_passive: Array
    u_choice: Array
    reset: ResetDraws


class EnvParams(NamedTuple):
    """The env's arrays (gymnax's ``params``): the step table, the humans, the step limit.

    Attributes:
        outcome: (2 K S A A,) int32, the step table, one word per joint step: the next
            state, the terminated, lifted, aborted and robot-invalid flags and the reward's
            index (:func:`~hri_envs.jax.tables.outcome_words`, :data:`OUTCOME_BITS`).
        reward_values: (R,) float, the distinct rewards the words index.
        state0: (K,) int32, the start state of each support.
        action_mask: (S,) uint32, each state's action mask as bits (bit a: action a is
            valid; unpacked in :meth:`JaxRobotEnv.observation`, cheaper than a row gather).
        support: (S,) int32.
        greedy: (P', K, K, S) int32; cum, q: (P', K, K, S, A) float; stochastic: (P',) bool;
            turn_state: (P', K, K) int32: the human bank.
        pop_entries: (n,) int32, the entries a population draws from (the fixed entry
            without a population).
        pop_log_beta, pop_passive, pop_turn_back: (2,) float, the population's ranges.
        pop_members: (M, 3) float, a member list's β, passive and turning-back rates
            (:attr:`~hri_envs.jax.tables.PopulationArrays.members`; (1, 3) unused otherwise).
        fixed: The env's fixed human (without a population).
        max_cycles: int32, the step limit per episode.
    """

    outcome: Array
    reward_values: Array
    state0: Array
    action_mask: Array
    support: Array
    greedy: Array
    cum: Array
    stochastic: Array
    q: Array
    turn_state: Array
    pop_entries: Array
    pop_log_beta: Array
    pop_passive: Array
    pop_turn_back: Array
    pop_members: Array
    fixed: Member
    max_cycles: Array


# --------------------------------------------------------------------------- draws
def _mix(x: Array) -> Array:
    """lowbias32 (C. Wellons): a bijective avalanche hash of uint32."""
    x = x ^ (x >> 16)
    x = x * jnp.uint32(0x7FEB352D)
    x = x ^ (x >> 15)
    x = x * jnp.uint32(0x846CA68B)
    return x ^ (x >> 16)


def uniform(seed: Array, index: Array, stream: int) -> Array:
    """A uniform in [0, 1) for one env and stream: a hash of ``(seed, index, stream)``.

    Args:
        seed: (2,) uint32, one threefry draw (``jax.random.bits(key, (2,), jnp.uint32)``).
        index: uint32, the env's index in its batch (< 2²⁸).
        stream: Which of the step's draws (< 16).

    Distinct ``(index, stream)`` give distinct hashes for one seed (the hash is a bijection
    of ``16 index + stream``); 24 bits each, so every value is exact in float32. Each
    stream is its own computation, so the draws a step does not use cost nothing.

    Raises:
        ConfigError: (``field="index"``) A concrete ``index`` that is not a whole number in
            ``0 .. 2**28 - 1`` (``16 index`` would wrap to another env's numbers), or a
            ``stream`` outside ``0 .. 15``; a traced index is not checked (a batch's
            ``arange(n)`` is, through ``n``).
    """
    if _concrete(index):
        _check_index(index)
    if not 0 <= stream < 16:
        raise ConfigError(f"uniform's stream must be in 0..15, got {stream!r}", field="stream")
    x = jnp.asarray(index).astype(jnp.uint32) * jnp.uint32(16) + jnp.uint32(stream)
    h = _mix(_mix(x ^ seed[0]) ^ seed[1])
    return (h >> 8).astype(jnp.float32) * jnp.float32(2.0 ** -24)


def _check_index(index: Any) -> None:
    """A concrete env index (or array of them): whole numbers in ``0 .. MAX_BATCH - 1``."""
    values = np.asarray(index)
    if values.dtype.kind not in "iu" or (values.size and not (
            values.min() >= 0 and values.max() < MAX_BATCH)):
        raise ConfigError(f"an env's index must be a whole number in 0..{MAX_BATCH - 1:,} (the "
                          f"draws hash 16 index + stream in 32 bits: a larger index would draw "
                          f"another env's numbers), got {_describe(index)}", field="index")


def uniforms(seed: Array, index: Array, n: int = N_STREAMS) -> Array:
    """(n,) :func:`uniform` draws of one env, streams ``0 .. n - 1``."""
    return jnp.stack([uniform(seed, index, k) for k in range(n)])


def _take(table: Array, index: Array) -> Array:
    """``table[index]`` for an index the env's rules keep in range: no clamping, no
    wrapping of negative indices (each costs a pass on a CPU).
    """
    return table.at[index].get(mode="promise_in_bounds", wrap_negative_indices=False)


def _select(values: Array, index: Array) -> Array:
    """``values[index]`` of a short table (a few starts, a few rewards) as a chain of
    selects, which XLA fuses and vectorises where a gather would be a scalar loop.
    """
    if values.shape[0] > 8:
        return _take(values, index)
    out = jnp.broadcast_to(values[0], jnp.shape(index))
    for i in range(1, values.shape[0]):
        out = jnp.where(index == i, values[i], out)
    return out


def _concrete(x: Any) -> bool:
    """``x`` holds values (not a tracer of ``jit``, ``vmap`` or ``grad``)."""
    return not isinstance(x, jax.core.Tracer)


def _leaf_name(path: tuple[Any, ...]) -> str:
    """A pytree path as ``"outcome"`` or ``"member.entry"``."""
    return ".".join(str(getattr(k, "name", k)) for k in path)


def _values(bad: np.ndarray, shape: tuple[int, ...]) -> str:
    """The first offending values, one alone for a scalar input."""
    first = bad.reshape(-1)[:5].tolist()
    return repr(first[0]) if not shape else repr(first)


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# --------------------------------------------------------------------------- the env
class JaxRobotEnv:
    """The robot vs a scripted human, as pure functions (gymnax's API, same-step autoreset).

    ## Description

    :class:`~hri_envs.envs.vector.RobotVectorEnv`'s task for ``jax.jit``/``jax.vmap``:
    ``reset(key, params)`` and ``step(key, state, action, params)`` act on one env
    (:class:`EnvState`); :meth:`reset_batch` and :meth:`step_batch` on N envs with one key
    per call. A step is one flat index into the numpy env's
    :class:`~hri_envs.task.episode.StepTable` (:mod:`hri_envs.jax.tables`); the human acts
    by its table (a deterministic preference, a stochastic table, or ``softmax(β Q_pref)``
    for a Boltzmann member of a population), may wait (``passive``) and turn back. Needs the
    ``jax`` extra (``.venv/bin/pip install -c constraints.txt -e '.[jax]'``).

    ## Action Space

    ``Discrete(A)`` (:meth:`action_space`), as the numpy env: an integer (``int`` or an
    integer array; ``bool``, floats and strings are refused with an
    :class:`~hri_envs.errors.ActionError`, never rounded). The public methods check their
    inputs where it costs nothing under ``jit`` (:meth:`check_step_inputs`): types, dtypes
    and shapes when a function is traced, values too when they are concrete (eager calls).
    Under ``jit`` an action outside ``0 .. A - 1`` and a state no step made cannot raise
    (the kernels do not look at values: that would cost a pass per step); such an action
    is clipped into range (check actions where they come from; the action masks say which
    are valid).

    ## Observation Space

    A dict of ``"state"``, ``"start"``, ``"last_human_action"`` (int32) and
    ``"action_mask"`` (A,) int8, as the numpy env's; ι is not observed.

    ## Rewards

    The robot cooperation reward R_R of the rules' variant (``reward="paper"`` or
    ``"no-free-toggle"``, :class:`~hri_envs.task.episode.EpisodeRules`), float (float64
    under ``jax.enable_x64``).

    ## Starting State

    The object rests on a start support drawn uniformly, ι drawn uniformly among the other
    supports; the episode turns back with the human's ``turn_back`` rate. Every
    ``episodes_per_human`` episodes (a *trial*; 1: at every reset, as the numpy env) the
    env draws a new human from ``population`` (without one, the fixed human with a new
    preference to drift to; without drift either, the trial's human stays: the fixed
    human, for states from :meth:`reset`).

    ## Episode End

    ``done = terminated | truncated`` (``truncated`` at ``max_cycles`` steps); the step
    that ends an episode returns the next episode's first observation (gymnax's and
    Gymnasium's same-step autoreset); ``info["final_state"]`` holds the state the step
    reached. ``info`` also has ``terminated``, ``truncated``, ``aborted``,
    ``invalid_action`` (the robot's), ``human_action`` and ``new_trial`` (the returned
    observation starts a trial with a new human).

    ## Arguments

    - ``scenario``, ``r0``, ``max_cycles``, ``reward``: as for
      :class:`~hri_envs.envs.vector.RobotVectorEnv`;
    - ``human``: a :class:`~hri_envs.humans.spec.HumanSpec` (a scripted human, or a
      population or split below; its shorthand keywords ``preference``, ``human_passive``,
      ``turn_back``, ``human_rationality``, ``population`` as for the vector env) or a
      :class:`~hri_envs.humans.scripted.ScriptedHuman` shared by every env (humans of the
      human protocol with Python state, families with a state of their own and
      ``module:Class`` humans cannot run under ``jit``: refused naming them; so is a
      spec's ``body``, as the env has no physical human);
    - ``population``: a name of
      :data:`~hri_envs.jax.tables.SUPPORTED_POPULATIONS` (or a
      :class:`~hri_envs.humans.populations.PopulationSpec`), or of a split of
      :data:`~hri_envs.jax.tables.SUPPORTED_SPLITS` (a frozen member list,
      :mod:`hri_envs.humans.splits`; ``"train"`` is the one to train on): a human drawn
      per trial;
    - ``episodes_per_human``: episodes per trial (default 1);
    - ``drift``: after this many episodes of a trial the human switches to another
      preference (None: never), as the suite's drifting human.

    ## Version History

    - v0: initial version (equals ``RobotVectorEnv`` v0 on the same draws).
    """

    def __init__(
        self,
        scenario: str = "hanger",
        *,
        human: HumanSpec | ScriptedHuman | None = None,
        r0: float | None = None,
        max_cycles: int = 100,
        reward: str = "paper",
        episodes_per_human: int = 1,
        drift: int | None = None,
        **human_keywords: Any,
    ) -> None:
        (self.scenario, self.r0, self.max_cycles, _, _) = check_env_settings(
            scenario, r0, max_cycles, None, [], "graph")
        graph = self.graph = scenario_graph(self.scenario)
        population: Any = human_keywords.get("population")
        if isinstance(population, PopulationSpec | MixtureSpec):  # a spec of your own
            human_keywords = {k: v for k, v in human_keywords.items() if k != "population"}
        else:
            population = None
        given = human_spec(human, human_keywords)
        if isinstance(given, HumanSpec):
            spec = given.bodiless("the JAX env").check(graph)
            if spec.kind in ("class", "prefixed") or spec.params:
                raise ConfigError(f"the JAX env holds scripted humans and splits of them as "
                                  f"tables, not {spec.population!r}"
                                  + (" with family parameters" if spec.params else ""),
                                  field="population")
            if population is not None and spec != HumanSpec():
                raise ConfigError("give either a human or a population, not both",
                                  field="population")
            human = None
            if population is None and spec.population is not None:
                population = spec.population
            elif population is None:
                human = spec.scripted(graph)
        elif not isinstance(given, ScriptedHuman):
            raise ConfigError(f"human must be a HumanSpec or a ScriptedHuman (a table the JAX "
                              f"env can hold), got {type(given).__name__}", field="human")
        else:
            human = given
        episodes_per_human = check_whole(episodes_per_human, "episodes_per_human", minimum=1)
        validate_drift(drift, "drift")
        if human is not None and (human.graph.name != graph.name
                                  or human.graph.n_states != graph.n_states):
            raise ConfigError(f"the human was built for the {human.graph.name} scenario, not "
                              f"the {graph.name}", field="human")
        self.reward_rule = reward
        self.episodes_per_human = episodes_per_human
        self.drift = drift
        self.steps: StepArrays = step_arrays(graph, self.r0, reward)
        n_k = graph.n_intentions
        self.n_states, self.n_actions, self.n_supports = graph.n_states, graph.n_actions, n_k
        pop: PopulationArrays | None = None
        extra: ScriptedHuman | None = None
        fixed_entry = 0
        fixed_passive, fixed_turn = 0.0, 0.0
        if population is not None:
            pop = population_arrays(graph, population)
        else:
            assert human is not None
            plain = is_plain(human, graph)
            if plain is None:  # its own table, after the preference humans
                extra, fixed_entry = human, len(spec_of(graph).preferences)
            else:
                fixed_entry = plain
            fixed_passive, fixed_turn = human.passive, human.turn_back
        self.bank: HumanBank = human_bank(graph, extra)
        self.population = pop
        # What can happen, fixed when the env is built (the step traces only what can).
        if pop is None:
            self._rational = False
            self._passive = fixed_passive > 0.0
            self._turning = fixed_turn > 0.0
            self._stochastic = bool(self.bank.stochastic[fixed_entry])
        elif pop.members is not None:  # a frozen list of humans (a split)
            self._rational = bool(np.isfinite(pop.members[:, 0]).any())
            self._passive = bool((pop.members[:, 1] > 0.0).any())
            self._turning = bool((pop.members[:, 2] > 0.0).any())
            self._stochastic = self._rational
        else:
            self._rational = pop.log_beta is not None
            self._passive = bool(pop.passive[1] > 0.0)
            self._turning = bool(pop.turn_back[1] > 0.0)
            self._stochastic = self._rational
        self._fixed = (fixed_entry, fixed_passive, fixed_turn)
        self._params: dict[Any, EnvParams] = {}
        self._shapes: dict[str, tuple[int, ...]] | None = None
        self.spec = spec_of(graph)

    # ----------------------------------------------------------------- spaces
    def action_space(self, params: EnvParams | None = None) -> spaces.Discrete:
        """``Discrete(A)``, the robot's actions."""
        return spaces.Discrete(self.n_actions)

    def observation_space(self, params: EnvParams | None = None) -> spaces.Dict:
        """The numpy env's single observation space (``Dict``)."""
        return robot_observation_space(self.n_states, self.n_supports, self.n_actions)

    @property
    def num_actions(self) -> int:
        """A."""
        return self.n_actions

    @property
    def name(self) -> str:
        """The env's name, as gymnax's."""
        return f"hri_envs/{self.spec.gym_id or self.scenario}-jax"

    # ----------------------------------------------------------------- params
    @property
    def default_params(self) -> EnvParams:
        """The env's arrays as ``jax`` arrays (float64 under ``jax.enable_x64``), built once
        per float type (``reset`` and ``step`` without ``params`` read them every call).
        """
        ftype = jnp.zeros(()).dtype  # float32, or float64 under jax.enable_x64
        if ftype not in self._params:
            self._params[ftype] = self._build_params(ftype)
        return self._params[ftype]

    def _build_params(self, ftype: Any) -> EnvParams:
        t, b = self.steps, self.bank
        pop = self.population

        def f(x: Any) -> Array:
            return jnp.asarray(x, dtype=ftype)

        entry, passive, turn = self._fixed
        entries = pop.prefs if pop is not None else np.array([entry], np.int32)
        log_beta = pop.log_beta if pop is not None and pop.log_beta is not None else [0.0, 0.0]
        words, rewards = outcome_words(t)
        return EnvParams(
            outcome=jnp.asarray(words), reward_values=f(rewards),
            state0=jnp.asarray(t.state0),
            action_mask=jnp.asarray((t.action_mask.astype(np.uint32)
                                     << np.arange(self.n_actions, dtype=np.uint32)).sum(1),
                                    dtype=jnp.uint32),
            support=jnp.asarray(t.support),
            greedy=jnp.asarray(b.greedy), cum=f(b.cum), stochastic=jnp.asarray(b.stochastic),
            q=f(b.q), turn_state=jnp.asarray(b.turn_state),
            pop_entries=jnp.asarray(entries, dtype=jnp.int32), pop_log_beta=f(log_beta),
            pop_passive=f(pop.passive if pop is not None else [0.0, 0.0]),
            pop_turn_back=f(pop.turn_back if pop is not None else [0.0, 0.0]),
            pop_members=f(pop.members if pop is not None and pop.members is not None
                          else [[math.inf, 0.0, 0.0]]),
            fixed=Member(jnp.int32(entry), f(math.inf), f(passive), f(turn), jnp.int32(entry)),
            max_cycles=jnp.int32(min(self.max_cycles, 2**31 - 1)),
        )

    # ----------------------------------------------------------------- draws
    def member_from_uniforms(self, u: Array | Callable[[int], Array],
                             params: EnvParams) -> Member:
        """A human from five uniforms: the population's recipe (:class:`PopulationArrays`)
        from ``u[:4]``, the drift's other preference from ``u[4]``; the fixed human
        without a population. ``u`` is an array, or a function of the index.
        """
        p = params
        if not callable(u):
            u = u.__getitem__
        if self.population is None:
            m = p.fixed
        elif self.population.members is not None:
            n = p.pop_entries.shape[0]
            i = jnp.minimum((u(0) * n).astype(jnp.int32), n - 1)
            rates = p.pop_members[i]
            m = Member(p.pop_entries[i], rates[0], rates[1], rates[2], p.pop_entries[i])
        else:
            n = p.pop_entries.shape[0]
            entry = p.pop_entries[jnp.minimum((u(0) * n).astype(jnp.int32), n - 1)]
            dtype = p.pop_passive.dtype
            if self._rational:
                lo, hi = p.pop_log_beta[0], p.pop_log_beta[1]
                beta = jnp.exp(lo + u(1).astype(dtype) * (hi - lo))
            else:
                beta = jnp.asarray(jnp.inf, dtype)
            passive = p.pop_passive[0] + u(2).astype(dtype) * (p.pop_passive[1]
                                                               - p.pop_passive[0])
            turn = p.pop_turn_back[0] + u(3).astype(dtype) * (p.pop_turn_back[1]
                                                              - p.pop_turn_back[0])
            m = Member(entry, beta, passive, turn, entry)
        if self.drift is None:
            return m
        n_p = self.bank.n_preferences
        shift = jnp.minimum((u(4) * (n_p - 1)).astype(jnp.int32), n_p - 2)
        other = jnp.where(m.entry < n_p, (m.entry + 1 + shift) % n_p,
                          jnp.minimum((u(4) * n_p).astype(jnp.int32), n_p - 1))
        return m._replace(drift_entry=other.astype(jnp.int32))

    def draws_from_uniforms(self, u: Array | Callable[[int], Array],
                            params: EnvParams) -> StepDraws:
        """One env's :class:`StepDraws` from (10,) uniforms (or a function of the index):
        passive, choice, start, intention, turn, then the five of
        :meth:`member_from_uniforms`.
        """
        get = u if callable(u) else u.__getitem__
        k = self.n_supports
        start = jnp.minimum((get(2) * k).astype(jnp.int32), k - 1)
        offset = jnp.minimum((get(3) * (k - 1)).astype(jnp.int32), k - 2)
        reset = ResetDraws(start, (start + 1 + offset) % k, get(4),
                           self.member_from_uniforms(lambda i: get(5 + i), params))
        return StepDraws(get(0), get(1), reset)

    def draws(self, key: Array, params: EnvParams, index: Array | int = 0) -> StepDraws:
        """The draws of env ``index`` of a batch for one step, from ``key`` (:func:`uniform`).

        Raises:
            ConfigError: A concrete ``index`` outside ``0 .. 2**28 - 1`` (``field="index"``).
        """
        if _concrete(index):
            _check_index(index)
        seed = jax.random.bits(key, (2,), jnp.uint32)
        return self.draws_from_uniforms(lambda k: uniform(seed, jnp.asarray(index), k), params)

    def batch_draws(self, key: Array, n: int, params: EnvParams) -> StepDraws:
        """(n,) draws, one per env, from one key (one threefry draw, then a hash per env)."""
        return jax.vmap(self.draws, in_axes=(None, None, 0))(
            key, params, jnp.arange(n, dtype=jnp.uint32))

    # ----------------------------------------------------------------- the rules
    def _entry(self, member: Member, episode: Array) -> Array:
        """The bank entry acting in episode ``episode`` of a trial (after drift)."""
        if self.drift is None:
            return member.entry
        return jnp.where(episode >= self.drift, member.drift_entry, member.entry)

    def human_action(self, state: EnvState, u_passive: Array, u_choice: Array,
                     params: EnvParams) -> Array:
        """The human's action in ``state`` (as :class:`~hri_envs.humans.tables.TableHumans`:
        the preferred action, or the inverse CDF of a stochastic table at ``u_choice``, or a
        wait when ``u_passive < passive``).
        """
        p, m = params, state.member
        entry = self._entry(m, state.episode)
        k, n_s = self.n_supports, self.n_states
        a = _take(p.greedy.reshape(-1),
                  ((entry * k + state.start) * k + state.intention) * n_s + state.state)
        if self._stochastic:
            where = (entry, state.start, state.intention, state.state)
            if self._rational:
                finite = jnp.isfinite(m.beta)
                beta = jnp.where(finite, m.beta, 1.0)
                z = beta * p.q[where]  # -inf on invalid actions (β > 0)
                e = jnp.exp(z - z.max())
                pi = e / e.sum()
                below = jnp.zeros((), jnp.int32)  # actions whose CDF is <= u_choice
                run = jnp.zeros((), pi.dtype)
                for i in range(self.n_actions):  # the CDF by sequential adds, as np.cumsum
                    run = run + pi[i]  # (jnp.cumsum is a reduce-window, slower than the step)
                    below = below + (u_choice >= run)
                use = finite
            else:
                below = jnp.sum(u_choice >= p.cum[where])
                use = p.stochastic[entry]
            sampled = jnp.minimum(below, self.n_actions - 1)
            a = jnp.where(use, sampled.astype(a.dtype), a)
        if self._passive:
            a = jnp.where(u_passive < m.passive, WAIT, a)
        return a

    def _begin(self, draws: ResetDraws, member: Member, episode: Array,
               params: EnvParams) -> EnvState:
        """A new episode with ``member`` as the human (the episode ``episode`` of its trial)."""
        p = params
        start, goal = draws.start, draws.intention
        turn_at = jnp.int32(-1)
        if self._turning:
            entry = self._entry(member, episode)
            turn_at = jnp.where(draws.u_turn < member.turn_back,
                                p.turn_state[entry, start, goal], -1)
        return EnvState(state=_select(p.state0, start), start=start, intention=goal,
                        lifted=jnp.bool_(False), steps=jnp.int32(0), turn_at=turn_at,
                        last_human=jnp.int32(WAIT), member=member, episode=episode)

    def observation(self, state: EnvState, params: EnvParams) -> dict[str, Array]:
        """The robot's observation of ``state`` (never ι)."""
        bits = params.action_mask[state.state] >> jnp.arange(self.n_actions, dtype=jnp.uint32)
        return {"state": state.state, "start": state.start,
                "last_human_action": state.last_human,
                "action_mask": (bits & 1).astype(jnp.int8)}

    # ----------------------------------------------------------------- input checks
    def _param_shapes(self) -> dict[str, tuple[int, ...]]:
        """The shape of each leaf of this env's params (``"outcome"``, ``"fixed.entry"``...)."""
        if self._shapes is None:
            ftype = jnp.zeros(()).dtype
            abstract = jax.eval_shape(lambda: self._build_params(ftype))
            self._shapes = {_leaf_name(path): tuple(leaf.shape) for path, leaf
                            in jax.tree_util.tree_leaves_with_path(abstract)}
        return self._shapes

    def check_params(self, params: EnvParams | None, where: str = "params") -> EnvParams:
        """``params`` (this env's :attr:`default_params` for None) if its arrays have the
        shapes of this env's; free under ``jit`` (shapes are known when tracing).

        Raises:
            ConfigError: Not an :class:`EnvParams`, or arrays of other shapes: the params
                of another scenario (or population, or human) (``field="params"``).
        """
        if params is None:
            return self.default_params
        if not isinstance(params, EnvParams) or not isinstance(params.fixed, Member):
            raise ConfigError(f"{where}: params must be this env's EnvParams "
                              f"(env.default_params), got {type(params).__name__}",
                              field="params")
        want = self._param_shapes()
        for path, leaf in jax.tree_util.tree_leaves_with_path(params):
            name = _leaf_name(path)
            if tuple(np.shape(leaf)) != want.get(name):
                raise ConfigError(
                    f"{where}: params.{name} has shape {tuple(np.shape(leaf))}, this env "
                    f"(the {self.scenario}, its humans) has {want.get(name)}: the params of "
                    "another scenario or env; pass this env's default_params",
                    field="params")
        return params

    def check_step_inputs(self, state: EnvState, action: Any, params: EnvParams | None,
                          batch: int | None = None, where: str = "step") -> EnvParams:
        """Check a step's inputs as far as it costs nothing under ``jit``; return the params.

        Types, dtypes and shapes are checked always (under ``jit`` and ``vmap`` only while
        tracing); values only when they are concrete (an eager call), never in a compiled
        step (a value check there would cost a pass over the batch per step).

        Args:
            state: The env state (its leaves of shape ``()``, or ``(batch,)``).
            action: The robot's action: an ``int`` or integer array (not bool, float, str)
                in ``0 .. A - 1``, of the state's shape.
            params: The env's params (None: :attr:`default_params`).
            batch: N for :meth:`step_batch`, None for one env.
            where: The calling method, for the messages.

        Raises:
            ActionError: A non-integer action, one of the wrong shape, or (concrete) one
                outside ``0 .. A - 1``.
            ConfigError: A state that is not an :class:`EnvState` of this env's dtypes and
                shapes, or (concrete) with a value no reset or step makes
                (``field="state"``); params of another env (``field="params"``).
        """
        p = self.check_params(params, where)
        shape = () if batch is None else (batch,)
        self._check_state(state, shape, where)
        self._check_action(action, shape, where)
        return p

    def _check_action(self, action: Any, shape: tuple[int, ...], where: str) -> None:
        n_a = self.n_actions
        kind = "an int or a 0-d integer array" if not shape else (
            f"an integer array of shape {shape}")
        allowed = (f"an integer in 0..{n_a - 1} ({kind}; bool, float and str are refused, "
                   "not rounded)")
        if type(action) is int and not shape:
            if not 0 <= action < n_a:
                raise ActionError(f"{where}: action must be {allowed}, got {action}")
            return
        dtype = getattr(action, "dtype", None)
        if dtype is None or isinstance(action, bool | float | str):
            raise ActionError(f"{where}: action must be {allowed}, got {_describe(action)} "
                              f"({type(action).__name__})")
        if np.dtype(dtype).kind not in "iu":
            raise ActionError(f"{where}: action must be {allowed}, got an array of "
                              f"{np.dtype(dtype)}")
        if tuple(np.shape(action)) != shape:
            raise ActionError(f"{where}: action must be {allowed}, got shape "
                              f"{tuple(np.shape(action))}")
        if _concrete(action):
            a = np.asarray(action)
            bad = a[(a < 0) | (a >= n_a)]
            if bad.size:
                raise ActionError(f"{where}: action must be {allowed}, got "
                                  f"{_values(bad, shape)}")

    def _state_ranges(self) -> dict[str, tuple[str, float, float]]:
        """Each state leaf's dtype kind and the values a reset or step gives it."""
        s, k, a = self.n_states, self.n_supports, self.n_actions
        entries = len(self.bank.names) - 1
        return {"state": ("i", 0, s - 1), "start": ("i", 0, k - 1),
                "intention": ("i", 0, k - 1), "lifted": ("b", 0, 1),
                "steps": ("i", 0, min(self.max_cycles, 2**31 - 1) - 1),
                "turn_at": ("i", -1, s - 1), "last_human": ("i", 0, a - 1),
                "episode": ("i", 0, self.episodes_per_human - 1),
                "member.entry": ("i", 0, entries), "member.beta": ("f", 0.0, math.inf),
                "member.passive": ("f", 0.0, 1.0), "member.turn_back": ("f", 0.0, 1.0),
                "member.drift_entry": ("i", 0, entries)}

    def _check_state(self, state: Any, shape: tuple[int, ...], where: str) -> None:
        if not isinstance(state, EnvState) or not isinstance(state.member, Member):
            raise ConfigError(f"{where}: state must be an EnvState of this env's reset or "
                              f"step, got {type(state).__name__}", field="state")
        leaves = {_leaf_name(path): leaf
                  for path, leaf in jax.tree_util.tree_leaves_with_path(state)}
        for name, (kind, lo, hi) in self._state_ranges().items():
            leaf = leaves[name]
            dtype = np.dtype(leaf.dtype if hasattr(leaf, "dtype") else np.asarray(leaf).dtype)
            kinds = {"i": "iu", "b": "b", "f": "f"}[kind]
            if dtype.kind not in kinds or tuple(np.shape(leaf)) != shape:
                raise ConfigError(
                    f"{where}: state.{name} must be {'an integer' if kind == 'i' else dtype}"
                    f" array of shape {shape}, as reset and step make it; got "
                    f"{dtype}{tuple(np.shape(leaf))}", field="state")
            if kind == "b" or not _concrete(leaf):
                continue
            v = np.asarray(leaf)
            ok = v > 0 if name == "member.beta" else (v >= lo) & (v <= hi)  # NaN: never
            bad = v[~ok]
            if bad.size:
                allowed = (f"in {lo}..{hi}" if kind == "i" else
                           "> 0 (inf: the entry's own policy)" if name == "member.beta"
                           else f"in [{lo:g}, {hi:g}]")
                raise ConfigError(f"{where}: state.{name} must be {allowed} (values a reset "
                                  f"or step of this env makes), got {_values(bad, shape)}",
                                  field="state")

    # ----------------------------------------------------------------- the kernels
    def reset_given(self, draws: ResetDraws, params: EnvParams | None = None
                    ) -> tuple[dict[str, Array], EnvState]:
        """Start a trial (a new human) and its first episode from given draws."""
        return self._reset_given(draws, self.check_params(params, "reset_given"))

    def _reset_given(self, draws: ResetDraws, p: EnvParams
                     ) -> tuple[dict[str, Array], EnvState]:
        state = self._begin(draws, draws.member, jnp.int32(0), p)
        return self.observation(state, p), state

    def step_given(self, state: EnvState, action: Array | int, draws: StepDraws,
                   params: EnvParams | None = None
                   ) -> tuple[dict[str, Array], EnvState, Array, Array, dict[str, Array]]:
        """One step of one env on given draws (pure; ``jit``/``vmap`` it).

        Its inputs are checked first (:meth:`check_step_inputs`).

        Returns:
            ``(obs, state, reward, done, info)``; when the step ends the episode, ``obs`` and
            ``state`` are the next episode's (drawn from ``draws.reset``).
        """
        p = self.check_step_inputs(state, action, params, where="step_given")
        return self._step_given(state, action, draws, p)

    def _step_given(self, state: EnvState, action: Array | int, draws: StepDraws,
                    p: EnvParams
                    ) -> tuple[dict[str, Array], EnvState, Array, Array, dict[str, Array]]:
        """:meth:`step_given` without its checks: the kernel every step runs."""
        n_s, n_a = self.n_states, self.n_actions
        a_r = jnp.clip(jnp.asarray(action, jnp.int32), 0, n_a - 1)
        a_h = self.human_action(state, draws.u_passive, draws.u_choice, p)
        j = (((state.start * 2 + state.lifted.astype(jnp.int32)) * n_s + state.state) * n_a
             + a_r) * n_a + a_h
        word = _take(p.outcome, j)  # the whole outcome in one gather (OUTCOME_BITS)
        bit = OUTCOME_BITS
        s_next = (word >> bit["next_state"]) & 255
        terminated = ((word >> bit["terminated"]) & 1).astype(bool)
        steps = state.steps + 1
        truncated = (steps >= p.max_cycles) & ~terminated
        done = terminated | truncated
        intention, turn_at = state.intention, state.turn_at
        if self._turning:  # ι becomes the start on entering the turning state
            back = s_next == state.turn_at
            intention = jnp.where(back, state.start, state.intention)
            turn_at = jnp.where(back, -1, state.turn_at)
        stepped = state._replace(
            state=s_next, intention=intention, lifted=((word >> bit["lifted"]) & 1).astype(bool),
            steps=steps, turn_at=turn_at, last_human=a_h)
        new_trial = state.episode + 1 >= self.episodes_per_human
        member = state.member  # a fixed human that does not drift stays the same
        if self.population is not None or self.drift is not None:
            member = jax.tree.map(lambda new, old: jnp.where(new_trial, new, old),
                                  draws.reset.member, state.member)
        episode = jnp.where(new_trial, 0, state.episode + 1).astype(jnp.int32)
        fresh = self._begin(draws.reset, member, episode, p)
        following = jax.tree.map(lambda a, b: jnp.where(done, a, b), fresh, stepped)
        info = {"terminated": terminated, "truncated": truncated,
                "aborted": ((word >> bit["aborted"]) & 1).astype(bool),
                "invalid_action": ((word >> bit["robot_invalid"]) & 1).astype(bool),
                "human_action": a_h, "final_state": s_next, "new_trial": done & new_trial}
        reward = _select(p.reward_values, word >> bit["reward"])
        return self.observation(following, p), following, reward, done, info

    # ----------------------------------------------------------------- gymnax API
    def reset(self, key: Array, params: EnvParams | None = None
              ) -> tuple[dict[str, Array], EnvState]:
        """Start one env: a human (the population's draw) and an episode, from ``key``."""
        p = self.check_params(params, "reset")
        return self._reset_given(self.draws(key, p).reset, p)

    def step(self, key: Array, state: EnvState, action: Array | int,
             params: EnvParams | None = None
             ) -> tuple[dict[str, Array], EnvState, Array, Array, dict[str, Array]]:
        """One step of one env, its draws from ``key`` (see :meth:`step_given`)."""
        p = self.check_step_inputs(state, action, params, where="step")
        return self._step_given(state, action, self.draws(key, p), p)

    def reset_batch(self, key: Array, n: int, params: EnvParams | None = None
                    ) -> tuple[dict[str, Array], EnvState]:
        """Start ``n`` envs from one key (arrays with a leading (n,) axis).

        Raises:
            ConfigError: ``n`` is not a whole number in ``1 .. 2**28`` (``field="n"``;
                a float is refused, not rounded), or params of another env.
        """
        n = check_whole(n, "n", minimum=1, maximum=MAX_BATCH, label="reset_batch's n",
                        allowed=f"a whole number of envs in 1..{MAX_BATCH:,} (an int, not a "
                                "float or bool)")
        p = self.check_params(params, "reset_batch")
        draws = self.batch_draws(key, n, p)
        return jax.vmap(self._reset_given, in_axes=(0, None))(draws.reset, p)

    def step_batch(self, key: Array, state: EnvState, action: Array,
                   params: EnvParams | None = None
                   ) -> tuple[dict[str, Array], EnvState, Array, Array, dict[str, Array]]:
        """One step of N envs ((N,) actions) with one key: the fast path under ``jit``.

        Its inputs are checked first (:meth:`check_step_inputs`: shapes and dtypes while
        tracing, values of concrete inputs; nothing in the compiled step).
        """
        n = np.shape(state.state) if isinstance(state, EnvState) else ()
        if len(n) != 1 or not 1 <= n[0] <= MAX_BATCH:
            raise ConfigError(f"step_batch: state must be an EnvState of reset_batch or "
                              f"step_batch (arrays of shape (N,), N in 1..{MAX_BATCH:,}), got "
                              f"{type(state).__name__} of shape {n}", field="state")
        p = self.check_step_inputs(state, action, params, batch=n[0], where="step_batch")
        draws = self.batch_draws(key, n[0], p)
        return jax.vmap(self._step_given, in_axes=(0, 0, 0, None))(state, action, draws, p)
