"""A robot that infers the goal but learns no preference: a Bayesian goal filter.

The yardstick for preference learning: it does what the Learner does about the intention ι
(a Bayes filter over the supports from the human's actions) but models the human as a
Boltzmann-rational *shortest-path* mover, the same for every human and never updated. If
the Learner does not beat it, learning the human's preference bought nothing.

**Human model.** ``D(ι, s)``: the fewest human motions from ``s`` to rest on ι with the robot
waiting (held by both; :data:`~hri_envs.humans.rational.D_MAX` where it cannot). In free
space ``π_sp(a | s, ι) ∝ exp(β · Q(s, a; ι))`` over the valid motions, with
``Q = -(1 + D(ι, s'))`` and ``s'`` where the motion leads, mixed with ``ε`` of a uniform
choice so that no action is impossible; at a support the human grasps, takes off and lets
go as every scripted human does (:func:`~hri_envs.humans.scripted.support_actions`).

**Filter.** The belief over ι starts uniform over the supports other than the start; every
human motion seen in free space multiplies it by ``π_sp(a_H | s, ι)`` (waits and grasp
toggles carry no information). Nothing is kept from one episode to the next.

**Action.** The human's action predicted by the belief, ``P(a) = Σ_ι b(ι) π(a | s, ι)``: the
robot joins the likeliest motion when ``P >= eta`` (take-off and put-on included) and waits
otherwise; it grasps at the start and lets go at the goal as the Passive baseline does. The
default ``eta = 1 + r0`` is where joining pays in one step: a joined motion earns 0 if the
human makes it and r⁻ = -1 if not, waiting earns r0. Where the shortest routes tie (move over
or down first?), ``P`` splits and the robot waits: only a preference could tell.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from agents.protocol import Trace
from baselines.simple import Tracking
from hri_envs.checks import check_real
from hri_envs.humans.finite_state import one_hot
from hri_envs.humans.rational import D_MAX
from hri_envs.humans.scripted import support_actions
from hri_envs.task import mdp
from hri_envs.task.actions import TAKE_OFF, TOGGLE, WAIT
from hri_envs.task.graph import TaskGraph

__all__ = ["GoalFilter", "shortest_path_policy"]


def shortest_path_policy(graph: TaskGraph, beta: float, epsilon: float) -> np.ndarray:
    """(K, K, S, A) ``π_sp(a | s; start, ι)`` of the module docstring.

    Args:
        graph: The task graph.
        beta: β of the Boltzmann choice among motions (> 0).
        epsilon: Weight of a uniform choice among the valid actions, in [0, 1).
    """
    g = graph
    n_k, n_s, n_a = g.n_intentions, g.n_states, g.n_actions
    free = ~g.is_support_state
    moves = mdp.free_motions(g)  # (S, A)
    nxt = g.next_state[:, WAIT, :]
    dist = np.minimum(mdp.cost_to_goal(g, np.where(moves, 1.0, np.inf)), D_MAX)  # (K, S)
    q = np.where(moves[None], -(1.0 + dist[:, nxt]), -np.inf)  # (K, S, A)
    # β scales q minus the best motion's value (βq - β max q would round otherwise); states
    # without a motion (the supports) keep probability 0 here.
    rows = moves.any(-1)
    soft = np.zeros((n_k, n_s, n_a))
    soft[:, rows] = mdp.softmax(q[:, rows] - q[:, rows].max(-1, keepdims=True), moves[rows],
                                beta)
    uniform = g.valid / g.valid.sum(-1, keepdims=True)
    law = np.broadcast_to((1.0 - epsilon) * soft + epsilon * uniform[None], (n_k, n_s, n_a))
    table = np.zeros((n_k, n_k, n_s), dtype=np.int64)
    support_actions(g, table)
    return np.where(free[None, None, :, None], law[None], one_hot(table, n_a))


class GoalFilter(Tracking):
    """A Bayes filter over the goal with a fixed shortest-path human model (module docstring).

    Args:
        graph: The task graph.
        n_runs: Independent runs.
        beta: β of the human model (default 3: shortest motions strongly preferred).
        epsilon: Weight of a uniform choice in the human model (default 0.05).
        eta: The predicted probability at which the robot joins the human's motion
            (default ``1 + r0``, see the module docstring).
        r0: The waiting reward that sets the default ``eta`` (default the hanger's -0.33).

    Attributes:
        posterior: (n_runs, K) the posterior over ι in each run's episode (:meth:`belief`).
    """

    name: ClassVar[str] = "goalfilter"

    def __init__(self, graph: TaskGraph, n_runs: int = 1, *, beta: float = 3.0,
                 epsilon: float = 0.05, eta: float | None = None, r0: float = -0.33) -> None:
        super().__init__(graph, n_runs)
        self.beta = check_real(beta, "beta", low=0.0, low_open=True, high=1e3)
        self.epsilon = check_real(epsilon, "epsilon", low=0.0, high=1.0, high_open=True)
        r0 = check_real(r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True)
        self.eta = check_real(1.0 + r0 if eta is None else eta, "eta", low=0.0, high=1.0,
                              low_open=True)
        self.model = shortest_path_policy(graph, self.beta, self.epsilon)  # (K, K, S, A)
        self.posterior = np.full((n_runs, graph.n_intentions), 1.0 / graph.n_intentions)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Belief uniform over the supports other than the start."""
        super().begin_episode(starts)
        k = self.graph.n_intentions
        self.posterior = np.where(np.arange(k)[None] == self.start[:, None], 0.0, 1.0 / (k - 1))

    def belief(self) -> np.ndarray:
        """(n_runs, K) the posterior over ι (a copy; the agent protocol's)."""
        return self.posterior.copy()

    def predicted(self, states: np.ndarray) -> np.ndarray:
        """(n_runs, A) the human's action predicted by the belief."""
        law = self.model[self.start[:, None], np.arange(self.graph.n_intentions)[None],
                         states[:, None]]  # (B, K, A)
        return np.einsum("bk,bka->ba", self.posterior, law)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Join the likeliest human motion when it is likely enough; else wait (passive)."""
        g = self.graph
        states = np.asarray(observations["state"], dtype=np.int64)
        p = self.predicted(states)
        best = np.argmax(p, axis=1)
        sure = p[np.arange(self.n_runs), best] >= self.eta
        passive = self.passive(states)
        join = sure & (best >= TAKE_OFF) & g.valid[states, best]
        return np.where(passive == TOGGLE, TOGGLE, np.where(join, best, WAIT))

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Bayes' rule on the human's motions in free space."""
        g = self.graph
        s = np.asarray(states, dtype=np.int64)
        a_h = np.asarray(human_actions, dtype=np.int64)
        informative = active & ~g.is_support_state[s] & (a_h >= TAKE_OFF)
        if informative.any():
            rows = np.flatnonzero(informative)
            lik = self.model[self.start[rows, None], np.arange(g.n_intentions)[None],
                             s[rows, None], a_h[rows, None]]  # (R, K)
            post = self.posterior[rows] * lik
            total = post.sum(1, keepdims=True)
            keep = total[:, 0] > 0
            self.posterior[rows[keep]] = post[keep] / total[keep]
        super().observe(states, robot_actions, human_actions, next_states, active)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Nothing is learned."""
