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
"""

from __future__ import annotations

import math

import numpy as np

from baselines.bounds import plan
from hri_bench.results import StudyResult
from hri_envs.errors import ConfigError
from hri_envs.humans.populations import (
    HumanDraw,
    build_human,
    population_spec,
)
from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios import scenario_graph

__all__ = ["REFERENCES", "blind_values"]

#: What each reference agent is, for reports.
REFERENCES: dict[str, str] = {
    "informed": "information bound: the exact optimum for a robot that sees the intention",
    "blind": "ceiling for any robot that must infer the intention; regret is measured "
             "against it",
    "oracle": "the paper's heuristic baseline: sees the intention, not optimal",
}


_TOO_LARGE = ("the exact blind plan is made for deterministic (or passive) scripted humans; "
              "this study's humans are Boltzmann (a finite rationality, or a population that "
              "draws rationality or preference weights)")
_BOTH = ("the exact blind plan does not fit a human who is both passive and turns back (too "
         "many beliefs)")


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
    graph = scenario_graph(cfg.scenario)
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
    if population is not None:
        spec = population_spec(population, cfg.scenario)
        if spec.rationality is not None or spec.theta:
            raise ConfigError(_TOO_LARGE, field="agents")
    graph = scenario_graph(cfg.scenario)
    starts = np.asarray(result.schedule["start"], dtype=np.int64)
    prefs = cfg.preference_of_run()
    seqs: list[list[HumanDraw]] = []
    for r in range(cfg.runs):  # every draw first: refuse before any planning
        seq = cfg.human_draws(r, prefs[r])
        for x in seq:
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
