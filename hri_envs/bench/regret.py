"""Regret against the intention-blind ceiling ``blind`` (see :mod:`baselines.bounds`).

The regret of an agent in episode e of run r is ``V_blind(start[r, e]) - reward[r, e]``:
the exact expected episode reward of the Bayes-optimal intention-blind robot from the
episode's start support (its prior over ι is uniform over the other supports, and the
human turns back with the study's probability: exactly how random schedules draw them),
minus the reward the agent got. The study reports its mean over runs per episode. On a
random schedule its expectation is the agent's shortfall from ``blind``; on the fixed
``table2`` schedule it compares with blind's prior expectation for the start, not with
blind on that particular goal.

The three references are: ``informed`` (the information bound: the exact optimum for a
robot that sees ι), ``blind`` (the ceiling for any robot that must infer ι; regret is
measured against it) and ``oracle`` (the paper's heuristic baseline: it sees ι but is not
optimal, so it is no bound).
"""

from __future__ import annotations

import math

import numpy as np

from baselines.bounds import plan
from hri_envs.bench.results import StudyResult
from hri_envs.errors import ConfigError
from hri_envs.task.humans import preference_human
from hri_envs.task.scenarios import scenario_graph

__all__ = ["REFERENCES", "blind_values"]

#: What each reference agent is, for reports.
REFERENCES: dict[str, str] = {
    "informed": "information bound: the exact optimum for a robot that sees the intention",
    "blind": "ceiling for any robot that must infer the intention; regret is measured "
             "against it",
    "oracle": "the paper's heuristic baseline: sees the intention, not optimal",
}


def blind_values(result: StudyResult) -> np.ndarray:
    """(runs, episodes) blind's exact expected reward for each episode's start support.

    Raises:
        ConfigError: If the exact blind plan is too large for the study's human.
    """
    cfg = result.config
    if getattr(cfg, "per_run_humans", False) or not math.isinf(cfg.human_rationality):
        raise ConfigError("the exact blind plan is made for one deterministic (or passive) "
                          "scripted human; this study's humans are Boltzmann, drawn from a "
                          "population or drifting", field="agents")
    if cfg.human_passive > 0 and cfg.turn_back > 0:
        raise ConfigError("the exact blind plan does not fit a human who is both passive and "
                          "turns back (too many beliefs)", field="agents")
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
