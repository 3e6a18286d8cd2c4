"""Plain ME-IRL (Algorithm 4): the robot adopts the learned preference reward as its own.

It has no separate human model: it assumes maximum cooperation,
``T(s'|s, a) = T(s'|s, a, a)`` (both agents take the same action, or for the grasp the
matching one), learns ``R(s, ι) = θᵀφ(s, ι)`` by one ME-IRL step per episode
(λ = 0.03), and estimates the intention by counting how often each intention
occurred in a state given the start support, ``Λ(ι | s_0, s)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from agents.config import LearnerConfig, default_config
from agents.learner import sample_actions
from agents.learning import mdp, partner_mdp
from agents.protocol import Trace, run_streams
from baselines.simple import Tracking
from hri_envs.task import episode as rules
from hri_envs.task import mdp as task_mdp
from hri_envs.task.features import initial_theta
from hri_envs.task.graph import TOGGLE, WAIT, TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["MaxEntIRL"]


class MaxEntIRL(Tracking):
    """Algorithm 4 for ``n_runs`` independent runs.

    Args:
        graph: The task graph.
        n_runs: Number of runs advanced together.
        config: Parameters (the Learner's, with λ = 0.03 by default).
        seed: Base seed; run ``r`` draws from ``(seed, r)``.
        runs: Run indices of this batch.

    Attributes:
        theta: (B, F) the agent's own reward weights.
        q: (B, I, S, A) Q per intention.
        counts: (B, K, S, I) how often intention ι was seen in state s from start k.
    """

    name: ClassVar[str] = "maxent"

    def __init__(self, graph: TaskGraph, n_runs: int = 1, config: LearnerConfig | None = None,
                 *, seed: int = 0, runs: Sequence[int] | None = None) -> None:
        super().__init__(graph, n_runs)
        self.config = (config if config is not None
                       else default_config(spec_of(graph), learning_rate=0.03))
        self.rngs = run_streams(seed, range(n_runs) if runs is None else runs)
        n_i, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
        # Both agents take the same action; for the grasp toggle the "matching" human action
        # makes the grasp cooperative (grasp together, or let go together), i.e. the human
        # toggles only when both hands are in the same state.
        matching = np.tile(np.arange(n_a), (n_s, 1))  # (S, A) the human's matching action
        same_hold = (graph.grasp & 1) == (graph.grasp >> 1)
        matching[:, TOGGLE] = np.where(same_hold, TOGGLE, WAIT)
        diag = graph.next_state[np.arange(n_s)[:, None], np.arange(n_a)[None, :], matching]
        # Deterministic: one "partner action" that always happens, for the sparse solvers.
        self._next = np.ascontiguousarray(diag[..., None], dtype=np.int64)  # (S, A, 1)
        self._certain = np.ones((1, 1, n_s, 1))  # (B, I, S, 1) its probability
        self._valid = np.array(graph.valid, dtype=bool)
        self._terminal = np.asarray(graph.terminal)[None]  # (1, I) goal of each intention
        self.theta = np.tile(initial_theta(graph.n_features), (n_runs, 1))
        self.counts = np.zeros((n_runs, n_i, n_s, n_i))
        self.goal_belief = np.full((n_runs, n_i), 1.0 / n_i)
        # Every run starts from the same θ: solve once and copy.
        q, greedy = self._solve(self.theta[:1])
        self.q = np.repeat(q, n_runs, axis=0)
        self._greedy = np.repeat(greedy, n_runs, axis=0)  # the last solve's, to start from

    def _solve(self, theta: np.ndarray, warm: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """Q per intention for the rewards θᵀφ, θ (B, F), and its greedy policy.

        Each intention's goal absorbs (it loops on itself, collecting its reward). Solved on
        the sparse table (:mod:`agents.learning.partner_mdp`) by policy iteration from
        ``warm`` (B, I, S) if given.

        Returns:
            (B, I, S, A) Q and (B, I, S) int greedy actions.
        """
        reward = np.einsum("isf,bf->bis", self.graph.features, theta)  # (B, I, S)
        certain = np.broadcast_to(self._certain, (*reward.shape, 1))
        r_sa = partner_mdp.partner_backup(self._next, certain, reward, self._terminal)
        return partner_mdp.solve_partner_q(self._next, certain, r_sa, self._valid,
                                           self.config.gamma, terminal=self._terminal,
                                           policy=warm)

    def _belief(self, states: np.ndarray) -> np.ndarray:
        """Λ(ι | s_0, s): observed frequencies, uniform over non-start supports before data.

        Where the object rests on a support after leaving the start, that support is taken
        as the intention, the knowledge the Passive baseline also has. Without it the agent
        can hold on forever at a goal it has not seen yet (its own model punishes letting go
        at a non-goal support), and an episode would only end by truncation.
        """
        c = self.counts[np.arange(self.n_runs), self.start, states]  # (B, I)
        n_i = c.shape[1]
        ids = np.arange(n_i)[None]
        prior = np.where(ids == self.start[:, None], 0.0, 1.0 / (n_i - 1))
        total = c.sum(axis=1, keepdims=True)
        belief = np.where(total > 0, c / np.maximum(total, 1e-300), prior)
        sup = self.graph.support[states]
        arrived = rules.arrived(self.graph, states, self.start, self.lifted)
        return np.where(arrived[:, None], (ids == sup[:, None]).astype(float), belief)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Bounded soft-max of Σ_ι Λ(ι|s_0,s) Q_ι(s, ·)."""
        states = np.asarray(observations["state"], dtype=np.int64)
        self.goal_belief = self._belief(states)
        q = np.einsum("bi,bia->ba", self.goal_belief, self.q[np.arange(self.n_runs), :, states])
        c = self.config
        probs = mdp.bounded_softmax(q, self.graph.valid[states], c.robot_temperature, c.eta,
                                    self.passive(states))
        u = np.zeros(self.n_runs)
        for i in np.flatnonzero(active):
            u[i] = self.rngs[i].random()
        return sample_actions(probs, u)

    def robot_policy(self, state: int, intention: int) -> np.ndarray:
        """(B, A) ``softmax(τ_R Q_ι(state, ·))``, the agent's policy if sure of ι."""
        q = self.q[:, intention, state]
        valid = np.broadcast_to(self.graph.valid[state], q.shape)
        return task_mdp.softmax(q, valid, self.config.robot_temperature)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Count intentions along the trace and take one ME-IRL step (λ = 0.03)."""
        g, c = self.graph, self.config
        n_b = self.n_runs
        revealed = np.asarray(intentions, dtype=np.int64) >= 0  # -1: truncated, no update
        intentions = np.where(revealed, intentions, 0)
        demo = mdp.demonstrations(g.features, [tr.states for tr in traces], intentions)
        for b, (trace, path) in enumerate(zip(traces, demo.paths, strict=True)):
            if revealed[b]:
                self.counts[b, g.support[trace.states[0]], path, intentions[b]] += 1
        rows = np.arange(n_b)
        phi = g.features[intentions]
        q = self.q[rows, intentions]
        policy = task_mdp.softmax(q, g.valid, c.irl_temperature)
        certain = np.broadcast_to(self._certain[0], (n_b, g.n_states, 1))
        expected = partner_mdp.expected_feature_counts(self._next, certain, policy, phi,
                                                       demo.start, g.terminal[intentions],
                                                       demo.horizon)
        new = mdp.irl_step(self.theta, demo.counts, expected, c.learning_rate)
        self.theta = np.where(revealed[:, None], new, self.theta)
        self.q, self._greedy = self._solve(self.theta, self._greedy)
