"""The JAX env's arrays, built in numpy from the tables the numpy envs step with.

Nothing here restates a rule: the step is :class:`~hri_envs.task.episode.StepTable`'s
(itself fused from :class:`~hri_envs.task.episode.EpisodeRules`), the humans are
:class:`~hri_envs.humans.scripted.ScriptedHuman` tables (:func:`preference_human`,
:func:`~hri_envs.humans.rational.preference_q`) and a population's draw is
:meth:`~hri_envs.humans.populations.PopulationSpec.sample`'s recipe, read from its spec.
This module imports numpy only; :mod:`hri_envs.jax.env` turns the arrays into ``jax`` ones.

Humans are a *bank*: every preference human of the scenario (index ``0 .. P - 1``, in
:func:`~hri_envs.humans.scripted.preferences_for`'s order), plus, for an env built with one
fixed human that is not plain, that human as entry ``P``. An env's human is a *member*:
a bank index, a rationality β (``inf``: the bank entry's own policy), a passive rate, a
turning-back rate and, for drift, the preference it drifts to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.populations import PopulationSpec
from hri_envs.humans.rational import preference_q
from hri_envs.humans.scripted import ScriptedHuman, preference_human
from hri_envs.humans.splits import MixtureSpec
from hri_envs.humans.splits import population as named_population
from hri_envs.task.episode import EpisodeRules, StepTable
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["OUTCOME_BITS", "SUPPORTED_POPULATIONS", "SUPPORTED_SPLITS", "HumanBank",
           "PopulationArrays", "StepArrays", "human_bank", "is_plain", "mixture_arrays",
           "outcome_words", "population_arrays", "step_arrays"]


@dataclass(frozen=True)
class StepArrays:
    """A :class:`~hri_envs.task.episode.StepTable` without its ended-episode context.

    The flat index of a joint step is ``j = (((start 2 + lifted) S + s) A + a_R) A + a_H``
    (``lifted`` before the step), as the step table's.

    Attributes:
        next_state: (2 K S A A,) int32, the state after the step.
        reward: (2 K S A A,) float64, the robot's reward (the rules' r0 and reward variant).
        terminated: (2 K S A A,) bool, the step ends the episode.
        lifted: (2 K S A A,) bool, the lifted flag after the step.
        aborted: (2 K S A A,) bool, the joint action was aborted.
        robot_invalid: (2 K S A A,) bool, the robot's action is not valid in the state.
        state0: (K,) int32, each support's start state.
        action_mask: (S, A) int8, the observations' action masks.
        support: (S,) int32, the support a state rests on (-1 in free space).
    """

    next_state: np.ndarray
    reward: np.ndarray
    terminated: np.ndarray
    lifted: np.ndarray
    aborted: np.ndarray
    robot_invalid: np.ndarray
    state0: np.ndarray
    action_mask: np.ndarray
    support: np.ndarray


def step_arrays(graph: TaskGraph, r0: float, reward: str = "paper") -> StepArrays:
    """The step table of ``(graph, r0, reward)``'s :class:`EpisodeRules`, as flat arrays."""
    table = StepTable(EpisodeRules(graph, r0, reward))
    live = slice(0, table.over)  # drop the ended-episode context: the JAX env autoresets
    return StepArrays(
        next_state=table.next_state[live].astype(np.int32),
        reward=np.asarray(table.reward[live], dtype=np.float64),
        terminated=table.terminated[live].copy(),
        lifted=table.lifted[live].copy(),
        aborted=table.aborted[live].copy(),
        robot_invalid=table.robot_invalid[live].copy(),
        state0=table.state0.astype(np.int32),
        action_mask=table.rules.action_mask.copy(),
        support=graph.support.astype(np.int32),
    )


#: Where :func:`outcome_words` puts each field of a step's outcome: the next state in bits
#: 0-7, then one bit per flag, the reward's index into the reward values from bit 12.
OUTCOME_BITS: dict[str, int] = {"next_state": 0, "terminated": 8, "lifted": 9, "aborted": 10,
                                "robot_invalid": 11, "reward": 12}


def outcome_words(steps: StepArrays) -> tuple[np.ndarray, np.ndarray]:
    """The step table as one int32 word per joint step, and the reward values it indexes.

    A step of the JAX env reads its whole outcome with one gather: on a CPU a gather is a
    scalar loop and costs more than the arithmetic that unpacks the word
    (docs/rl.md, "What a step of the JAX env costs"). The layout is :data:`OUTCOME_BITS`.

    Returns:
        ``(words, rewards)``: (2 K S A A,) int32 and (R,) float64, the distinct rewards
        (sorted), so that ``rewards[words >> 12]`` is ``steps.reward``.

    Raises:
        ConfigError: More than 256 states (the word holds the next state in 8 bits).
    """
    if steps.action_mask.shape[0] > 256:
        raise ConfigError(f"the JAX env holds at most 256 states, the graph has "
                          f"{steps.action_mask.shape[0]}", field="scenario")
    rewards, code = np.unique(steps.reward, return_inverse=True)
    b = OUTCOME_BITS
    words = (steps.next_state.astype(np.int64) << b["next_state"]
             | steps.terminated.astype(np.int64) << b["terminated"]
             | steps.lifted.astype(np.int64) << b["lifted"]
             | steps.aborted.astype(np.int64) << b["aborted"]
             | steps.robot_invalid.astype(np.int64) << b["robot_invalid"]
             | code.astype(np.int64).reshape(-1) << b["reward"])
    return words.astype(np.int32), rewards


@dataclass(frozen=True)
class HumanBank:
    """The base humans an env's members refer to (P preference humans, maybe one more).

    Attributes:
        names: (P',) the entries' names (preferences; the fixed human's own name last).
        n_preferences: P, the scenario's preference humans (entries ``0 .. P - 1``).
        greedy: (P', K, K, S) int32, each entry's likeliest action ``[start, ι, s]``.
        cum: (P', K, K, S, A) float64, the CDF of each entry's own policy.
        stochastic: (P',) bool, the entry's own policy is not deterministic.
        q: (P', K, K, S, A) float64, ``Q_pref`` of the preference humans, for Boltzmann
            members (``-inf`` on invalid actions, so ``softmax(β q)`` needs no mask; 0 on
            the valid actions of a last entry that is not a preference human).
        turn_state: (P', K, K) int32, where each entry turns back (-1: never).
    """

    names: tuple[str, ...]
    n_preferences: int
    greedy: np.ndarray
    cum: np.ndarray
    stochastic: np.ndarray
    q: np.ndarray
    turn_state: np.ndarray


def human_bank(graph: TaskGraph, extra: ScriptedHuman | None = None) -> HumanBank:
    """The scenario's preference humans (deterministic, never passive), and ``extra`` last."""
    prefs = spec_of(graph).preferences
    humans = [preference_human(graph, p) for p in prefs]
    qs = [preference_q(h) for h in humans]  # -inf on invalid actions
    if extra is not None:
        humans.append(extra)
        qs.append(np.where(graph.valid, 0.0, -np.inf) + np.zeros_like(qs[0]))
    return HumanBank(
        names=tuple(h.name for h in humans),
        n_preferences=len(prefs),
        greedy=np.stack([h.route_table for h in humans]).astype(np.int32),
        cum=np.stack([np.cumsum(h.policy, axis=-1) for h in humans]),
        stochastic=np.array([not h.deterministic for h in humans]),
        q=np.stack(qs),
        turn_state=np.stack([h.turn_state for h in humans]).astype(np.int32),
    )


#: The populations the JAX env draws from (every registered one whose members are tables).
SUPPORTED_POPULATIONS: tuple[str, ...] = ("hanger-all", "preferences", "mixed-rationality",
                                          "passive-turnback", "heldout")
#: The frozen splits (:mod:`hri_envs.humans.splits`) the JAX env holds as member lists: their
#: members are all scripted preference humans (passive, Boltzmann or neither).
SUPPORTED_SPLITS: tuple[str, ...] = ("train", "validation")


@dataclass(frozen=True)
class PopulationArrays:
    """A population's recipe (:meth:`PopulationSpec.sample`) as numbers, for drawing in JAX.

    From four uniforms ``u``: the bank entry ``prefs[min(⌊u₀ n⌋, n - 1)]`` (n = len(prefs)),
    β = ``exp(log_beta[0] + u₁ (log_beta[1] - log_beta[0]))`` (``inf`` without a
    rationality range), passive ``passive[0] + u₂ (passive[1] - passive[0])`` and the
    turning-back rate likewise from ``u₃``.

    Attributes:
        name: The population's name.
        prefs: (n,) int32, the bank entries drawn from.
        log_beta: (2,) float64, log of β's range, or None (deterministic members).
        passive: (2,) float64, the passive rate's range.
        turn_back: (2,) float64, the turning-back rate's range.
        members: For a frozen list of humans (a split, :class:`MixtureSpec`), None
            otherwise: (M, 3) float64, each member's β (``inf``: deterministic), passive and
            turning-back rate; ``prefs`` is then (M,), each member's bank entry, and the
            member is ``min(⌊u₀ M⌋, M - 1)`` (the ranges are unused).
    """

    name: str
    prefs: np.ndarray
    log_beta: np.ndarray | None
    passive: np.ndarray
    turn_back: np.ndarray
    members: np.ndarray | None = None


def mixture_arrays(graph: TaskGraph, spec: MixtureSpec) -> PopulationArrays:
    """A frozen list of humans (a split) as member arrays (:class:`PopulationArrays`).

    Raises:
        ConfigError: A member is not a scripted preference human (a family with a state of
            its own: misspecified, adaptive, inconsistent), or the list is for another
            scenario.
    """
    if spec.scenario != graph.name:
        raise ConfigError(f"population {spec.name!r} is for the {spec.scenario}, not the "
                          f"{graph.name}", field="population")
    names = spec_of(graph).preferences
    entries, rates = [], []
    for draw in spec.member_draws:
        params = dict(draw.params)
        if draw.family != "preference" or not set(params) <= {"preference", "passive",
                                                                "rationality"}:
            raise ConfigError(
                f"population {spec.name!r} holds {draw.label()!r}, which is not a scripted "
                f"preference human; the JAX env holds the splits "
                f"{', '.join(SUPPORTED_SPLITS)} and the populations "
                f"{', '.join(SUPPORTED_POPULATIONS)}", field="population")
        pref = params.get("preference") or spec_of(graph).default_preference
        entries.append(names.index(pref))
        rates.append((float(params.get("rationality", math.inf)),
                      float(params.get("passive", 0.0)), 0.0))
    members = np.asarray(rates, dtype=np.float64)
    return PopulationArrays(spec.name, np.asarray(entries, dtype=np.int32), None,
                            np.array([members[:, 1].min(), members[:, 1].max()]),
                            np.zeros(2), members)


def population_arrays(graph: TaskGraph, population: str | PopulationSpec | MixtureSpec
                      ) -> PopulationArrays:
    """The draw of ``population`` (a registered name or split, or a spec of your own) as
    arrays.

    Raises:
        ConfigError: An unknown population, one for another scenario, or one whose members
            are not tables (``theta``: each member needs a Q-iteration of its own; a family
            with a state of its own).
    """
    spec = named_population(population, graph.name) if isinstance(population, str) else (
        population)
    if isinstance(spec, MixtureSpec):
        return mixture_arrays(graph, spec)
    if spec.theta:
        raise ConfigError(
            f"population {spec.name!r} draws preference weights θ, whose humans need a "
            f"Q-iteration each; the JAX env draws from {', '.join(SUPPORTED_POPULATIONS)}",
            field="population")
    if graph.name not in spec.scenarios:
        raise ConfigError(f"population {spec.name!r} is for {', '.join(spec.scenarios)}; not "
                          f"{graph.name!r}", field="population")
    names = spec_of(graph).preferences
    chosen = names if spec.preferences == ("*",) else (  # "*": every preference
        spec.preferences or (spec_of(graph).default_preference,))
    prefs = np.array([names.index(p) for p in chosen], dtype=np.int32)
    log_beta = None
    if spec.rationality is not None:
        log_beta = np.log(np.asarray(spec.rationality, dtype=np.float64))
    return PopulationArrays(spec.name, prefs, log_beta,
                            np.asarray(spec.passive, dtype=np.float64),
                            np.asarray(spec.turn_back, dtype=np.float64))


def is_plain(human: ScriptedHuman, graph: TaskGraph) -> int | None:
    """The bank index of ``human`` when it is one of the scenario's preference humans with
    rates only (deterministic, the preference's own table); None otherwise.
    """
    names = spec_of(graph).preferences
    if human.name not in names or not human.deterministic:
        return None
    base = preference_human(graph, human.name)
    same = (np.array_equal(base.policy, human.policy)
            and np.array_equal(base.turn_state, human.turn_state))
    return names.index(human.name) if same else None
