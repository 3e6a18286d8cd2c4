"""Exact reference robots: ``informed`` (knows ι) and ``blind`` (Bayes-optimal without ι).

Both know the scripted human's policy exactly: its policy table π_H(a | s; start, ι), its
passivity (it waits with probability ``passive`` in any step) and its turning back (with
probability ``turn_back`` per episode it switches ι to the start support on entering
``turn_state[start, ι]``). They differ in what they see during an episode:

* :class:`Informed` sees the human's current intention ι every step (it is *privileged*, like
  the Oracle) but not whether the human will turn back: it learns that only when the human
  turns (ι changes) or passes the turning point without turning;
* :class:`Blind` sees what every intention-blind robot sees (state, start, the human's
  actions) and acts Bayes-optimally on the exact posterior over the hidden pair
  (ι, turning).

**Objective.** The benchmark measures the undiscounted sum of the robot cooperation reward
over an episode that ends at a terminal state or is cut at the step limit ``max_steps``.
Both planners maximise exactly that: the expected undiscounted episode reward over the
finite horizon ``max_steps`` (well defined, since the horizon is finite), by backward
induction over the horizon. Their policies therefore depend on the steps left.

**Method.** The hidden part of the episode is the hypothesis h = (ι, turning), 2K values.
A planning node is (start, state, lifted, belief over h). From a node, each robot action
a_R and human action a_H (drawn from the mixture of the hypotheses' action laws) leads to
one successor: s' = next_state[s, a_R, a_H], the belief is updated by Bayes' rule and the
turning rule is applied (h = (ι, 1) becomes (start, 0) on entering its turning state); the
informed robot additionally observes the new ι, which splits the belief. The planner
enumerates every node reachable within ``max_steps`` steps (breadth first; beliefs are
compared after rounding to 9 decimals, so paths that reach the same belief share a node)
and solves the resulting finite expectimax tree by backward induction. Hypotheses whose
posterior falls below ``prune`` (1e-12) are dropped; a belief's value with t steps left
changes by at most t per unit of total variation (rewards lie in [-1, 0]), so this moves
any value by at most 2·2K·prune·T² (< 1e-6 for T = 100). For a deterministic policy table
that is passive *or* turns back the set of reachable beliefs is small (a non-waiting
action removes the inconsistent hypotheses; a wait multiplies the weights of the
hypotheses that would not have waited by ``passive``). Passivity together with turning
back, or a stochastic (Boltzmann) table, can need many more nodes for ``blind`` (the
informed plan stays small); planning then stops with a
:class:`~hri_envs.errors.ConfigError` once ``max_nodes`` nodes are exceeded rather than
return an approximation.

**Off-model observations.** If a run shows a transition that the model gives probability
0 (a different human, a physics backend whose outcome differs from the graph), the agent
cannot place the run in its plan any more and falls back to the Passive baseline for the
rest of that episode.

The plan is computed once per (graph, human, r0, max_steps, reward variant) and cached.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from agents.protocol import BatchAgent, Trace
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task import episode as rules
from hri_envs.task import mdp
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph

__all__ = ["Blind", "Informed", "Plan", "plan", "reward_table"]

_TERMINAL = -1
#: Hypotheses whose posterior falls below this are dropped (see the module docstring).
PRUNE = 1e-12
#: Default cap on the number of planning nodes.
MAX_NODES = 50_000


@dataclass(frozen=True)
class Plan:
    """An exact finite-horizon plan on the (start, state, lifted, belief) nodes.

    Attributes:
        informed: Whether the robot observes ι (:class:`Informed`) or not (:class:`Blind`).
        horizon: T = ``max_steps``.
        n_supports: K.
        roots: (K, K) int, ``roots[start, ι]``: the node an informed episode starts in
            (-1 for ι == start); for a blind plan every column holds the start's node.
        value: (T+1, N) float, ``value[t, n]``: the optimal expected reward with t steps left.
        policy: (T+1, N) int, the optimal robot action with t steps left (row 0 unused).
        successor: dict ``(node, a_R, observation) -> node`` (-1: the episode ended), where
            the observation is ``a_H * K + ι`` (informed) or ``a_H * K`` (blind).
        n_nodes: N.
    """

    informed: bool
    horizon: int
    n_supports: int
    roots: np.ndarray
    value: np.ndarray
    policy: np.ndarray
    successor: dict[tuple[int, int, int], int]
    n_nodes: int

    def start_value(self) -> np.ndarray:
        """(K,) the exact expected episode reward per start support (uniform ι ≠ start).

        Blind: the value of the start's root; informed: the mean over ι ≠ start.
        """
        k = self.n_supports
        out = np.zeros(k)
        for start in range(k):
            nodes = [self.roots[start, i] for i in range(k) if i != start]
            out[start] = float(np.mean(self.value[self.horizon, nodes]))
        return out


def _human_law(human: ScriptedHuman) -> np.ndarray:
    """(K, K, S, A) P(a_H | s; start, ι) with passivity mixed in."""
    law = (1.0 - human.passive) * human.policy
    law[..., WAIT] += human.passive
    return law


def reward_table(graph: TaskGraph, r0: float, reward: str) -> np.ndarray:
    """(K, 2, S, A, A) the robot's step reward ``[start, lifted, s, a_R, a_H]`` (the object
    moving by the graph's joint transition), for the plans here and in
    :mod:`baselines.product`.
    """
    n_s, n_a = graph.n_states, graph.n_actions
    s_ix, r_ix, h_ix = np.ix_(np.arange(n_s), np.arange(n_a), np.arange(n_a))
    return np.stack([np.stack([
        rules.step_reward(graph, s_ix, r_ix, h_ix, graph.next_state, r0, reward=reward,
                          start=st, lifted=lf) for lf in (False, True)])
        for st in range(graph.n_intentions)])


def _fingerprint(graph: TaskGraph, human: ScriptedHuman, r0: float, max_steps: int,
                 reward: str, informed: bool) -> tuple[object, ...]:
    digest = hashlib.sha1(np.ascontiguousarray(human.policy).tobytes())
    digest.update(np.ascontiguousarray(human.turn_state).tobytes())
    return (graph.name, graph.n_states, digest.hexdigest(), float(human.passive),
            float(human.turn_back), float(r0), int(max_steps), reward, informed)


_CACHE: dict[tuple[object, ...], Plan] = {}


def plan(
    graph: TaskGraph,
    human: ScriptedHuman,
    *,
    r0: float,
    max_steps: int = 100,
    informed: bool,
    reward: str = "paper",
    max_nodes: int = MAX_NODES,
    prune: float = PRUNE,
) -> Plan:
    """Solve the informed or the blind reference exactly (see the module docstring).

    Args:
        graph: The task graph.
        human: The scripted human the robot knows.
        r0: The waiting reward, in (-1, 0).
        max_steps: The step limit T, the horizon of the undiscounted objective.
        informed: Plan for a robot that observes ι (True) or not (False).
        reward: The reward variant, one of :data:`hri_envs.task.episode.REWARD_RULES`.
        max_nodes: Stop with a ConfigError beyond this many planning nodes.
        prune: Drop hypotheses whose posterior falls below this (0: never).

    Returns:
        The cached :class:`Plan`.
    """
    rules.reward_rule(reward)  # a ConfigError listing the registered rules
    if max_steps < 1:
        raise ConfigError(f"max_steps must be >= 1, got {max_steps}", field="max_steps")
    key = (*_fingerprint(graph, human, r0, max_steps, reward, informed), max_nodes, prune)
    if key not in _CACHE:
        _CACHE[key] = _solve(graph, human, r0, max_steps, informed, reward, max_nodes,
                             prune)
    return _CACHE[key]


def _solve(graph: TaskGraph, human: ScriptedHuman, r0: float, horizon: int, informed: bool,
           reward: str, max_nodes: int, prune: float) -> Plan:
    """The plan: every node reachable within ``horizon`` steps (:class:`_Tree`), then
    backward induction over them (:func:`_backward_induction`).
    """
    k = graph.n_intentions
    tree = _Tree(graph, human, r0, informed, reward, max_nodes, prune)
    roots = tree.roots()
    tree.expand(sorted(set(roots[roots >= 0].tolist())), horizon)
    value, policy = _backward_induction(graph, tree, horizon)
    if not informed:
        for start in range(k):
            roots[start, start] = roots[start, (start + 1) % k]
    return Plan(informed, horizon, k, roots, value, policy, tree.successor, len(tree.nodes))


class _Tree:
    """The planning nodes (start, state, lifted, belief over h) and the edges between them.

    Edges ``(node, a_R, prob, reward, successor)`` are kept as lists (``e_node``,
    ``e_act``, ``e_prob``, ``e_rew``, ``e_succ``; successor :data:`_TERMINAL` where the
    episode ends) and ``successor`` maps ``(node, a_R, observation)`` to the successor
    (see :class:`Plan`).
    """

    def __init__(self, graph: TaskGraph, human: ScriptedHuman, r0: float, informed: bool,
                 reward: str, max_nodes: int, prune: float) -> None:
        k, n_s = graph.n_intentions, graph.n_states
        self.k, self.informed, self.max_nodes, self.prune = k, informed, max_nodes, prune
        self.n_h = 2 * k  # hypotheses h = 2 ι + turning
        self.law = _human_law(human)
        self.turn_state = np.asarray(human.turn_state)
        self.q = float(human.turn_back)
        self.iota = np.arange(self.n_h) // 2
        self.turning = np.arange(self.n_h) % 2 == 1
        self.valid_actions = [np.flatnonzero(graph.valid[s]) for s in range(n_s)]
        self.next_state = graph.next_state
        self.rewards = reward_table(graph, r0, reward)  # (K, 2, S, A, A)
        self.left = rules.left_start(graph, np.arange(n_s)[:, None], np.arange(k)[None, :])
        self.ends = rules.episode_over(graph, np.arange(n_s)[:, None, None],
                                       np.arange(k)[None, :, None],
                                       np.array([False, True])[None, None, :])  # (S, K, 2)
        self.start_state = [int(rules.start_state(graph, start)) for start in range(k)]
        self.keys: dict[tuple[int, int, bool, bytes], int] = {}
        self.nodes: list[tuple[int, int, bool, np.ndarray]] = []
        self.successor: dict[tuple[int, int, int], int] = {}
        self.e_node: list[int] = []
        self.e_act: list[int] = []
        self.e_prob: list[float] = []
        self.e_rew: list[float] = []
        self.e_succ: list[int] = []

    def node_of(self, start: int, s: int, lifted: bool, belief: np.ndarray) -> int:
        """The node of ``belief`` (normalised, pruned, rounded to 9 decimals), made if new.

        Raises:
            ConfigError: More than ``max_nodes`` nodes.
        """
        b = belief / belief.sum()
        if self.prune > 0.0:
            b = np.where(b < self.prune, 0.0, b)
            b /= b.sum()
        key = (start, s, lifted, np.round(b, 9).tobytes())
        if key not in self.keys:
            if len(self.nodes) >= self.max_nodes:
                raise ConfigError(
                    f"the exact {'informed' if self.informed else 'blind'} plan needs more "
                    f"than {self.max_nodes} belief nodes for this human; it fits "
                    "deterministic humans that are passive or turn back (passivity together "
                    "with turning back, or a stochastic policy, can need more); raise "
                    "max_nodes to try", field="human")
            self.keys[key] = len(self.nodes)
            self.nodes.append((start, s, lifted, b))
        return self.keys[key]

    def prior(self, start: int, goals: Sequence[int]) -> np.ndarray:
        """(H,) the belief at the start: uniform over ``goals``, each split by turning."""
        b = np.zeros(self.n_h)
        for g in goals:
            w = 1.0 / len(goals)
            if self.turn_state[start, g] >= 0 and self.q > 0.0:
                b[2 * g + 1] += w * self.q
                b[2 * g] += w * (1.0 - self.q)
            else:
                b[2 * g] += w
        return b

    def roots(self) -> np.ndarray:
        """(K, K) ``roots[start, ι]``: the start nodes (-1 for ι == start; see :class:`Plan`)."""
        k = self.k
        roots = np.full((k, k), -1, dtype=np.int64)
        for start in range(k):
            others = [g for g in range(k) if g != start]
            for g in others:
                roots[start, g] = self.node_of(start, self.start_state[start], False,
                                               self.prior(start, [g] if self.informed
                                                          else others))
        return roots

    def expand(self, frontier: list[int], horizon: int) -> None:
        """Breadth-first enumeration from ``frontier``, ``horizon`` steps deep."""
        for _depth in range(horizon):
            if not frontier:
                break
            new: list[int] = []
            for n in frontier:
                new += self._expand_node(n)
            frontier = new

    def _expand_node(self, n: int) -> list[int]:
        """The edges out of node ``n``; the nodes first found on them."""
        start, s, lifted, b = self.nodes[n]
        k, iota, turning, turn_state = self.k, self.iota, self.turning, self.turn_state
        nodes, successor = self.nodes, self.successor
        lik = self.law[start, iota, s]  # (H, A)
        joint = b[:, None] * lik  # (H, A)
        p_h = joint.sum(0)
        new: list[int] = []
        for a_r in self.valid_actions[s]:
            for a_h in np.flatnonzero(p_h > 0):
                s2 = int(self.next_state[s, a_r, a_h])
                r = float(self.rewards[start, int(lifted), s, a_r, a_h])
                lifted2 = bool(lifted or self.left[s2, start])
                over = bool(self.ends[s2, start, int(lifted2)])
                post = joint[:, a_h].copy()
                turns = turning & (turn_state[start, iota] == s2) & (post > 0)
                if turns.any():
                    post[2 * start] += post[turns].sum()
                    post[turns] = 0.0
                groups = [(int(i), post * (iota == i)) for i in range(k)] if self.informed \
                    else [(0, post)]
                for i, part in groups:
                    mass = float(part.sum())
                    if mass <= 0.0:
                        continue
                    if over:
                        nxt = _TERMINAL
                    else:
                        before = len(nodes)
                        nxt = self.node_of(start, s2, lifted2, part)
                        if nxt >= before:
                            new.append(nxt)
                    successor[(n, int(a_r), int(a_h) * k + i)] = nxt
                    self.e_node.append(n)
                    self.e_act.append(int(a_r))
                    self.e_prob.append(mass)
                    self.e_rew.append(r)
                    self.e_succ.append(nxt)
        return new


def _backward_induction(graph: TaskGraph, tree: _Tree, horizon: int
                        ) -> tuple[np.ndarray, np.ndarray]:
    """``(value, policy)``, (T+1, N) each: the optimal expected reward and robot action
    with t steps left, over the tree's edges.
    """
    n_nodes, n_a = len(tree.nodes), graph.n_actions
    node = np.asarray(tree.e_node, dtype=np.int64)
    act = np.asarray(tree.e_act, dtype=np.int64)
    prob = np.asarray(tree.e_prob)
    rew = np.asarray(tree.e_rew)
    succ = np.asarray(tree.e_succ, dtype=np.int64)
    succ = np.where(succ == _TERMINAL, n_nodes, succ)  # a sink with value 0
    valid = np.zeros((n_nodes, n_a), dtype=bool)
    states = np.array([nd[1] for nd in tree.nodes], dtype=np.int64)
    valid[:] = graph.valid[states]
    # Nodes first found at depth T are never expanded: they are only needed with 0 steps left.
    unexpanded = np.ones(n_nodes, dtype=bool)
    unexpanded[np.unique(node)] = False
    value = np.zeros((horizon + 1, n_nodes))
    policy = np.zeros((horizon + 1, n_nodes), dtype=np.int64)
    flat = node * n_a + act
    immediate = np.bincount(flat, weights=prob * rew, minlength=n_nodes * n_a)
    for t in range(1, horizon + 1):
        v_prev = np.append(value[t - 1], 0.0)
        qv = immediate + np.bincount(flat, weights=prob * v_prev[succ], minlength=n_nodes * n_a)
        qv = np.where(valid, qv.reshape(n_nodes, n_a), -np.inf)
        best = np.argmax(qv, axis=1)
        policy[t] = best
        value[t] = np.where(unexpanded, 0.0, qv[np.arange(n_nodes), best])
    return value, policy


class _PlanAgent(BatchAgent):
    """Follows a :class:`Plan` in every run; the Passive baseline once a run leaves it."""

    informed: ClassVar[bool] = False

    def __init__(self, graph: TaskGraph, human: ScriptedHuman, n_runs: int = 1, *,
                 r0: float, max_steps: int = 100, reward: str = "paper") -> None:
        super().__init__(n_runs)
        self.graph = graph
        self.plan = plan(graph, human, r0=r0, max_steps=max_steps, informed=self.informed,
                         reward=reward)
        self.start = np.zeros(n_runs, dtype=np.int64)
        self.node = np.full(n_runs, -1, dtype=np.int64)
        self.steps = np.zeros(n_runs, dtype=np.int64)
        self.lifted = np.zeros(n_runs, dtype=bool)
        self.pending: list[tuple[int, int, int] | None] = [None] * n_runs
        self._fresh = np.ones(n_runs, dtype=bool)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Place every run at its start node."""
        self.start = np.asarray(starts, dtype=np.int64).reshape(self.n_runs).copy()
        self.node = self.plan.roots[self.start, (self.start + 1) % self.plan.n_supports].copy()
        self.steps[:] = 0
        self.lifted[:] = False
        self.pending = [None] * self.n_runs
        self._fresh = np.ones(self.n_runs, dtype=bool)

    def _resolve(self, i: int, seen: int) -> None:
        key = self.pending[i]
        if key is None:
            return
        n, a_r, a_h = key
        k = self.plan.n_supports
        self.node[i] = self.plan.successor.get((n, a_r, a_h * k + seen), -1)
        self.pending[i] = None

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The plan's action with the steps left; Passive for runs that left the plan."""
        states = np.asarray(observations["state"], dtype=np.int64)
        if self.informed:
            if "intention" not in observations:
                raise KeyError("the informed agent needs observations['intention'] "
                               "(it is privileged)")
            intention = np.asarray(observations["intention"], dtype=np.int64)
        out = mdp.passive_actions(self.graph, self.start, self.lifted)[
            np.arange(self.n_runs), states]
        left = np.maximum(self.plan.horizon - self.steps, 1)
        for i in np.flatnonzero(active):
            if self.informed:
                if self._fresh[i]:
                    self.node[i] = self.plan.roots[self.start[i], intention[i]]
                self._resolve(int(i), int(intention[i]))
            self._fresh[i] = False
            n = self.node[i]
            if n >= 0:
                out[i] = self.plan.policy[min(left[i], self.plan.horizon), n]
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Advance every active run's node (informed: once the new ι is seen)."""
        self.lifted |= active & rules.left_start(self.graph, next_states, self.start)
        g = self.graph
        for i in np.flatnonzero(active):
            self.steps[i] += 1
            n = int(self.node[i])
            if n < 0:
                continue
            a_r, a_h = int(robot_actions[i]), int(human_actions[i])
            if g.next_state[states[i], a_r, a_h] != next_states[i]:
                self.node[i] = -1  # the outcome differs from the graph's: off the plan
                continue
            self.pending[i] = (n, a_r, a_h)
            if not self.informed:
                self._resolve(int(i), 0)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Nothing to learn: the plan is exact for the known human."""


class Informed(_PlanAgent):
    """The information bound: the exact optimum for a robot that sees ι every step.

    It knows the human's policy, passivity and turning-back probability, and needs the true
    intention in ``observations["intention"]`` (``privileged = True``).
    """

    name: ClassVar[str] = "informed"
    privileged: ClassVar[bool] = True
    informed: ClassVar[bool] = True


class Blind(_PlanAgent):
    """The intention-blind ceiling: Bayes-optimal on the exact belief over (ι, turning).

    No robot that must infer ι can expect more on the same human; regret is measured
    against it.
    """

    name: ClassVar[str] = "blind"
    informed: ClassVar[bool] = False
