"""Regret against the intention-blind ceiling ``blind`` (see :mod:`baselines.bounds`).

The regret of an agent in episode e of run r is ``V_blind(start[r, e]) - reward[r, e]``:
the exact expected episode reward of the Bayes-optimal intention-blind robot from the
episode's start support (its prior over ι is uniform over the other supports, and the
human turns back with the study's probability: exactly how random schedules draw them),
minus the reward the agent got. The study reports its mean over runs per episode. On a
random schedule its expectation is the agent's shortfall from ``blind``; on the fixed
``table2`` schedule it compares with blind's prior expectation for the start, not with
blind on that particular goal.

Runs with humans of their own (``--population``, ``--human-drift``) are compared episode by
episode with blind planned for *that episode's* human (the reference knows the human's
policy, so after a drift it knows the new one): one plan per distinct human, cached by the
human's label and its passive and turning-back rates. Boltzmann humans (a finite β, or a
population that draws β or θ) are refused up front, before any planning: their exact plan
is too large.

The three references are: ``informed`` (the information bound: the exact optimum for a
robot that sees ι), ``blind`` (the ceiling for any robot that must infer ι; regret is
measured against it) and ``oracle`` (the paper's heuristic baseline: it sees ι but is not
optimal, so it is no bound).

Where the exact ``blind`` plan does not fit the humans (Boltzmann, finite-state humans:
misspecified, adaptive, inconsistent), a study that runs ``informed`` and ``qmdp`` reports a
**bracket** on ``blind`` instead (:func:`reference_summary`): ``informed`` above it (no robot
expects more; exact), ``qmdp`` below it (a feasible intention-blind policy that knows the
human's model, :mod:`baselines.product`; simulated). Each agent's gap to either end is the
mean over runs of the paired difference of run means (the same runs meet the same humans
and schedules), with a 95 % bootstrap CI. :func:`refuse_references` refuses a reference that
cannot run with a study's humans before anything is simulated or planned.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from baselines.bounds import plan
from hri_bench.core import stats
from hri_bench.core.results import StudyResult
from hri_bench.run.agents import PLANNING_REFERENCES
from hri_envs.errors import ConfigError
from hri_envs.humans.populations import (
    POPULATIONS,
    HumanDraw,
    build_human,
    population_spec,
)
from hri_envs.humans.scripted import ScriptedHuman, preference_human

__all__ = ["REFERENCES", "blind_values", "what_ran"]

#: What each reference agent is, for reports (suite v1's wording, frozen).
REFERENCES: dict[str, str] = {
    "informed": "information bound: the exact optimum for a robot that sees the intention",
    "blind": "ceiling for any robot that must infer the intention; regret is measured "
             "against it",
    "oracle": "the paper's heuristic baseline: sees the intention, not optimal",
}
#: Every reference, the bracket's lower end included.
ALL_REFERENCES: dict[str, str] = {
    **REFERENCES,
    "qmdp": "lower end of the bracket on blind: a feasible intention-blind policy (QMDP on "
            "the exact posterior) that knows the human's model; simulated",
}


_TOO_LARGE = ("the exact blind plan is made for deterministic (or passive) scripted humans; "
              "this study's humans are Boltzmann (a finite rationality, or a population that "
              "draws rationality or preference weights)")
_BOTH = ("the exact blind plan does not fit a human who is both passive and turns back (too "
         "many beliefs)")
#: What a suite reports where the exact blind plan does not fit (the suite adds both ends).
_BRACKET = "a bracket (qmdp below, informed above) is reported"
_MODEL = ("the exact blind plan fits deterministic scripted humans; this population has "
          "members with a finite state or a stochastic law (misspecified, adaptive, "
          "inconsistent or Boltzmann): " + _BRACKET)


def what_ran(note: str, agents: Sequence[str]) -> str:
    """``note`` (why regret is not reported, as a suite records it) made true of a study
    whose agents are ``agents``: its bracket is reported only when ``qmdp`` and ``informed``
    both ran, else the note says which to add.
    """
    if not note.endswith(_BRACKET) or {"qmdp", "informed"} <= set(agents):
        return note
    missing = [a for a in ("qmdp", "informed") if a not in agents]
    return (note[:-len(_BRACKET)] + f"no reference ran for a bracket (add {' and '.join(missing)}"
            " to the agents: qmdp below, informed above)")


def blind_refusal(cfg: Any) -> str | None:
    """Why the agent ``blind`` cannot run in the study ``cfg``, or None; decided from the
    settings alone, before any planning.
    """
    if getattr(cfg, "per_run_humans", False):
        return ("agent 'blind' plans for one scripted human shared by every run; this "
                "study's runs have humans of their own (population=, human_drift=): leave "
                "it out (regret still uses blind's exact values where they fit) or run "
                "informed and qmdp for a bracket")
    if not math.isinf(cfg.human_rationality):
        return (_TOO_LARGE + " (human_rationality=); run informed and qmdp for a bracket "
                "instead")
    if cfg.human_passive > 0 and cfg.turn_back > 0:
        return _BOTH + " (human_passive= with turn_back=)"
    return None


def refuse_references(cfg: Any) -> None:
    """Raise a :class:`ConfigError` (``field="agents"``) naming the reason when a reference
    among the study's agents cannot run with its humans (before anything is simulated).

    ``informed`` and ``qmdp`` need a model of the humans (not ``--population module:Class``);
    ``blind`` needs one shared deterministic (or passive, or turning-back) scripted human
    (:func:`blind_refusal`); ``qmdp`` needs humans that do not turn back.
    """
    refs = [a for a in cfg.agents if a in PLANNING_REFERENCES]
    if not refs:
        return
    population = getattr(cfg, "population", None)
    if population is not None and ":" in population:
        raise ConfigError(f"agent(s) {', '.join(refs)} plan with the human's model; the "
                          f"humans of {population} have none: leave them out",
                          field="agents")
    if "blind" in refs:
        why = blind_refusal(cfg)
        if why is not None:
            raise ConfigError(why, field="agents")
    if "qmdp" in refs:
        turning = cfg.turn_back > 0 or (population in POPULATIONS
                                        and POPULATIONS[population].turn_back[1] > 0)
        if turning:
            raise ConfigError("agent 'qmdp' keeps a posterior over the human's finite state; "
                              "humans who turn back halfway (turn_back=, or a population "
                              "that draws it) are not supported", field="agents")


def _paired(upper: np.ndarray, lower: np.ndarray, seed: int,
            labels: Sequence[str] | None = None) -> dict[str, Any]:
    """Mean over runs of ``upper - lower`` (run means), with its 95 % bootstrap CI.

    With ``labels`` (each run's human) and at least two runs per human, the bootstrap is
    stratified by human: a population's runs meet its members in balanced blocks
    (:meth:`hri_envs.humans.splits.MixtureSpec.draw`), so its make-up is fixed, not sampled.
    """
    diff = upper.mean(1) - lower.mean(1)
    strata: list[np.ndarray] | np.ndarray = diff
    if labels is not None and len(set(labels)) > 1:
        groups = [diff[[i for i, x in enumerate(labels) if x == key]]
                  for key in dict.fromkeys(labels)]
        if min(len(g) for g in groups) >= 2:
            strata = groups
    lo, hi = stats.bootstrap_ci(strata, "mean", seed)
    return {"mean": float(diff.mean()), "ci95": [lo, hi],
            "stratified": isinstance(strata, list)}


def reference_summary(result: StudyResult) -> dict[str, Any]:
    """How the study's reference is reported, and each agent's gap to it.

    Returns:
        ``kind``: "exact" (blind's exact values: regret), "bracket" (``qmdp`` below
        ``informed``), "upper" (``informed`` only) or "none"; ``upper`` and ``lower``: the
        bounds' names (null where absent) and their mean episode reward; ``gaps``: per
        agent, ``to_upper`` (upper − agent) and ``to_lower`` (lower − agent), each the mean
        over runs of the paired difference of run means with a 95 % CI; ``note``: in words.
    """
    cfg = result.config
    metrics = result.metrics
    try:
        exact = blind_values(result)
    except ConfigError:
        exact = None
    upper = "informed" if "informed" in metrics else None
    if exact is not None:
        kind, lower = "exact", "blind"
        low_values = exact
    elif upper is not None and "qmdp" in metrics:
        kind, lower = "bracket", "qmdp"
        low_values = metrics["qmdp"]["reward"]
    else:
        kind, lower = ("upper" if upper else "none"), None
        low_values = None
    gaps: dict[str, Any] = {}
    labels = result.humans if getattr(cfg, "mixture_population", False) else None
    for name, m in metrics.items():
        r = m["reward"]
        gaps[name] = {
            "to_upper": None if upper is None else _paired(metrics[upper]["reward"], r,
                                                           cfg.seed, labels),
            "to_lower": None if low_values is None else _paired(low_values, r, cfg.seed,
                                                                labels)}
    notes = {
        "exact": "blind exact (regret = blind's exact expected episode reward minus the "
                 "agent's); informed above it where it ran",
        "bracket": "blind bracketed: informed (exact optimum that sees the intention) above, "
                   "qmdp (a feasible intention-blind policy, simulated) below",
        "upper": "upper bound only (informed); run qmdp for the bracket's lower end",
        "none": "no reference ran",
    }
    return {"kind": kind, "upper": upper, "lower": lower,
            "upper_reward": None if upper is None else float(metrics[upper]["reward"].mean()),
            "lower_reward": None if low_values is None else float(np.mean(low_values)),
            "gaps": gaps, "note": notes[kind]}


def blind_values(result: StudyResult) -> np.ndarray:
    """(runs, episodes) blind's exact expected reward for each episode's start support.

    Each episode is planned for the human of that episode: the study's human, or each run's
    own (population draw, drifted after ``human_drift`` episodes).

    Raises:
        ConfigError: If the exact blind plan is too large for the study's humans (Boltzmann,
            or both passive and turning back); raised before any planning.
    """
    cfg = result.config
    if not math.isinf(cfg.human_rationality):
        raise ConfigError(_TOO_LARGE, field="agents")
    if getattr(cfg, "per_run_humans", False):
        return _per_run_values(result)
    if cfg.human_passive > 0 and cfg.turn_back > 0:
        raise ConfigError(_BOTH, field="agents")
    graph = cfg.graph
    prefs = cfg.preference_of_run()
    starts = np.asarray(result.schedule["start"], dtype=np.int64)
    out = np.zeros(starts.shape)
    for pref in sorted(set(prefs)):
        human = preference_human(graph, pref, passive=cfg.human_passive,
                                 turn_back=cfg.turn_back)
        value = plan(graph, human, r0=cfg.waiting_reward, max_steps=cfg.max_steps,
                     informed=False, reward=cfg.reward).start_value()
        rows = [r for r, p in enumerate(prefs) if p == pref]
        out[rows] = value[starts[rows]]
    return out


def _per_run_values(result: StudyResult) -> np.ndarray:
    """Blind's value per (run, episode) for studies whose runs have their own humans."""
    cfg = result.config
    population = getattr(cfg, "population", None)
    if population is not None and ":" in population:
        raise ConfigError("the exact blind plan needs a scripted human; this study's humans "
                          f"are {population}", field="agents")
    if population is not None and population in POPULATIONS:
        spec = population_spec(population, cfg.scenario)
        if spec.rationality is not None or spec.theta:
            raise ConfigError(_TOO_LARGE, field="agents")
    graph = cfg.graph
    starts = np.asarray(result.schedule["start"], dtype=np.int64)
    prefs = cfg.preference_of_run()
    seqs: list[list[HumanDraw]] = []
    for r in range(cfg.runs):  # every draw first: refuse before any planning
        seq = cfg.human_draws(r, prefs[r])
        for x in seq:
            if x.family is not None:  # a family's member: its model decides
                model = build_human(graph, x)
                if not isinstance(model, ScriptedHuman) or not model.deterministic:
                    raise ConfigError(_MODEL, field="agents")
                if model.passive > 0 and model.turn_back > 0:
                    raise ConfigError(_BOTH, field="agents")
                continue
            if x.theta is not None or not math.isinf(x.rationality):
                raise ConfigError(_TOO_LARGE, field="agents")
            if x.passive > 0 and x.turn_back > 0:
                raise ConfigError(_BOTH, field="agents")
        seqs.append(seq)
    values: dict[tuple[str, float, float], np.ndarray] = {}
    out = np.zeros(starts.shape)
    for r, seq in enumerate(seqs):
        for e, x in enumerate(seq):
            key = (x.label(), x.passive, x.turn_back)
            if key not in values:
                values[key] = plan(graph, build_human(graph, x), r0=cfg.waiting_reward,
                                   max_steps=cfg.max_steps, informed=False,
                                   reward=cfg.reward).start_value()
            out[r, e] = values[key][starts[r, e]]
    return out
