"""The data Algorithm 1 reads and writes: a graph's :class:`Tables` in the kernels' layouts,
the update's :class:`Params`, the Learner's :class:`Models` of both partners, and the
:class:`Workspace` an update may write its results into.

:mod:`agents.learning.algorithm1` (the update) re-exports them; import them from there.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hri_envs.task.graph import TaskGraph


class Tables(NamedTuple):
    """A graph's tables in the layouts the kernels take (own, writeable, contiguous copies,
    so that neither the kernels copy them per call nor a read-only variant is compiled).

    Attributes:
        next_state: (S, A, A) int64 joint table ``next_state[s, a_R, a_H]``.
        valid: (S, A) bool valid actions (of both partners).
        reward: (S, A, A) float64 the robot's joint reward R_R (with the Learner's r0).
        features: (I, S, F) float64 φ(s, ι).
        terminal: (I,) int64 the absorbing goal state of each intention.
    """

    next_state: np.ndarray
    valid: np.ndarray
    reward: np.ndarray
    features: np.ndarray
    terminal: np.ndarray

    @classmethod
    def of(cls, graph: TaskGraph, r0: float) -> Tables:
        """The tables of ``graph`` with the robot reward of ``r0``."""
        return cls(np.array(graph.next_state, dtype=np.int64), np.array(graph.valid, dtype=bool),
                   np.array(graph.reward(r0), dtype=np.float64),
                   np.array(graph.features, dtype=np.float64),
                   np.array(graph.terminal, dtype=np.int64))


class Params(NamedTuple):
    """The update's parameters (the Learner's configuration, :class:`agents.config.
    LearnerConfig`).

    Attributes:
        gamma: Discount γ in [0, 1) of every Q-iteration.
        human_temperature: τ_H of π̂_H.
        robot_temperature: τ of the robot policy the human model assumes.
        irl_temperature: τ of the IRL's soft-max policy.
        learning_rate: λ of the IRL step.
        max_iter: Cap on policy-improvement rounds.
    """

    gamma: float
    human_temperature: float
    robot_temperature: float
    irl_temperature: float
    learning_rate: float
    max_iter: int = 100


class Models(NamedTuple):
    """The Learner's model of both partners after :func:`update` (B runs, I intentions).

    Attributes:
        theta: (B, F) feature weights of the human's reward.
        state_reward: (B, I, S) that reward, θ·φ(s, ι).
        q_h: (B, I, S, A) the human's Q.
        greedy_h: (B, I, S) int its greedy actions (the next update's warm start).
        pi_h: (B, I, S, A) the human policy estimate π̂_H.
        q_r: (B, I, S, A) the robot's Q.
        greedy_r: (B, I, S) int its greedy actions.
        pi_r: (B, I, S, A) the robot's soft-max policy the human model assumes.
    """

    theta: np.ndarray
    state_reward: np.ndarray
    q_h: np.ndarray
    greedy_h: np.ndarray
    pi_h: np.ndarray
    q_r: np.ndarray
    greedy_r: np.ndarray
    pi_r: np.ndarray


class Workspace:
    """Arrays an update may write its results into, handed over explicitly.

    A learner that keeps nothing of an earlier update's models gives them to its workspace
    (:meth:`give`) when an update replaces them; the next update writes into them
    (:meth:`take`) instead of fresh arrays, which spares the allocator fresh pages (about a
    sixth of a 100-run update's time). So with a workspace, the arrays a learner exposes
    are overwritten by the update after next: whoever keeps them copies them. The benchmark
    gives its learners one; a learner made without one never overwrites an array.
    """

    def __init__(self) -> None:
        self._spare: Models | None = None

    def give(self, models: Models) -> None:
        """Models no one reads any more: the next update may write into their arrays."""
        self._spare = models

    def take(self) -> Models | None:
        """The arrays to write the next update into (None: fresh ones)."""
        spare, self._spare = self._spare, None
        return spare
