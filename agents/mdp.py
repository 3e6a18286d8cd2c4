"""The learning math; it lives in :mod:`hri_envs.task.mdp` (the scripted humans need it too).

Kept here so that ``from agents import mdp`` goes on working.
"""

from hri_envs.task.mdp import (
    Demonstrations,
    absorbing,
    bayes_update,
    bounded_softmax,
    demonstrations,
    expected_feature_counts,
    human_transition,
    irl_step,
    passive_actions,
    passive_policy,
    q_iteration,
    remove_loops,
    robot_reward,
    robot_transition,
    softmax,
    solve_q,
)

__all__ = [
    "Demonstrations",
    "absorbing",
    "bayes_update",
    "bounded_softmax",
    "demonstrations",
    "expected_feature_counts",
    "human_transition",
    "irl_step",
    "passive_actions",
    "passive_policy",
    "q_iteration",
    "remove_loops",
    "robot_reward",
    "robot_transition",
    "softmax",
    "solve_q",
]
