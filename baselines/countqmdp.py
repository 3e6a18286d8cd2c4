"""Count the human's actions, filter the intention, plan by QMDP: ``countqmdp``.

The first thing a researcher would try: learn the human's action law online by counting
(no reward model, no features), keep a Bayes filter over the intention ι, and act on the
belief-weighted value of plans made with the learned law. Defaults (in brackets) were
chosen on the ``train``, ``validation`` and ``validation-v2`` splits only (docs/agents.md,
"countqmdp").

**Human model.** Dirichlet–categorical counts of the human's action ``a_H``, in three nested
contexts, the posterior predictive of each level the Dirichlet prior of the next:

1. *shared, goal-relative*: per state ``s`` and its role in the episode, ``role(s; st, ι)``
   (the state's column, or support, is ι's, the start's or another's), pooled over starts
   and intentions, with "move over to support k" recorded relative to the episode
   (towards ι, towards the start, towards another: ``rel(a; st, ι)``; every other action
   as it is). One route seen towards B teaches "here the human moves over towards its
   goal" for A too: ``P_R(a | st, ι, s) = (R[s, role, rel(a)] + ρ π0(a | st, ι, s)) /
   (Σ_valid R + ρ)`` over the valid actions (ρ = ``rho`` [1]; ``inf`` leaves it out);
2. per ``(ι, s)``: ``P1(a | st, ι, s) = (M[ι, s, a] + α P_R) / (Σ_a M[ι, s, a] + α)``
   (α = ``alpha`` [1]);
3. per ``(ι, s, c)``, ``c = c(a_R)`` the class of the robot's action *of the same step*
   (``robot_context`` ["wait"]: ``"none"``, one class; ``"wait"``, whether the robot
   waited; ``"action"``, the action itself), and the start too with ``by_start`` [False]:
   ``P(a | st, ι, s, c) = (N[x, a] + κ P1) / (Σ_a N[x, a] + κ)`` (κ = ``kappa`` [1]);
   without a refinement (``"none"``, no ``by_start``) the model is ``P1``.

In free space, *waiting says nothing about the goal*: the probability that the human waits
is ``ω(s, c)``, the same for every ι, learned from the human's steps in ``s`` under robot
class ``c`` whatever the episode's intention (truncated episodes included), with prior
weight λ (``wait_weight`` [1]) on the run's rate under class ``c`` over all free states,
itself with weight λ on π0's wait; the motions keep the proportions of level 3. So an
impatient human who answers the robot's waits by waiting teaches in a few steps that the
robot must lead, everywhere, and a passive human's waits do not move the belief.

``π0`` is the goal filter's Boltzmann shortest-path human
(:func:`~baselines.goalfilter.shortest_path_policy`, β = ``prior_beta`` [3]) mixed with
``prior_epsilon`` [0.05] of a uniform choice among the valid actions in every state
(supports included, so that no valid action has probability 0). Before any data the model
is ``π0`` exactly.

**Learning.** After each episode every count is multiplied by ``decay`` [1: never forget],
then the steps ``(s_t, a_R,t, a_H,t)`` of the trace are counted in hindsight. With
``hindsight="revealed"`` a step adds 1 under the intention revealed (the support where the
episode ended); with ``"smooth"`` [default] it adds ``P(ι_t = ι | the trace, ι_T)`` to each
ι, the smoothed posterior of the intention at that step under the change-of-mind hazard
``h`` (a forward–backward pass; with ``h = 0`` it is 1 on the revealed ι, the plain rule):
the steps a fickle human made towards its first goal are not taught as steps towards its
last. A truncated episode (``-1``: nothing revealed) adds nothing to the counts per ι
(guessing ι would teach a wrong route with the confidence of a right one; no episode was
truncated in the tuning studies), only to the wait rates.

**Filter.** The belief starts uniform over the supports other than the start. After each
step, Bayes' rule with the model's probability of the human's action,
``b'(ι) ∝ b(ι) P(a_H | st, ι, s, c(a_R))``; then, if the object moved into free space, a
change of mind with probability ``h`` (``hazard`` [0.05]):
``b''(ι) = (1 - h) b'(ι) + h (1 - b'(ι)) / (n - 1)`` over the ``n`` possible intentions
(not after a step in which nothing moved). Until the object has left the start, the start
is impossible (belief 0); after, a human may turn back to it.

**Plan.** Per run, start and intention, the robot's MDP on the joint table with the learned
law substituted, ``T(s' | s, a_R) = Σ_{a_H} P(a_H | st, ι, s, c(a_R)) 1[next(s, a_R, a_H)
= s']``, with the benchmark's reward ``r(s, a_R) = Σ_{a_H} P(a_H | ·) R(s, a_R, a_H)`` (the
study's ``r0`` and reward rule), solved exactly by policy iteration
(:func:`hri_envs.task.mdp.solve_q`) with discount γ (``gamma`` [0.95]), warm-started from
the last plan, after every episode; the states where the episode would end (resting,
nobody holding, on a support other than the start, or on the start when ι is the start)
are absorbing with value 0.

**Adapt** (``adapt`` [True]). Within an episode the steps seen so far are counted as well,
each weighted by the belief after it (and in the wait rates), and the action values in
the current state are one Bellman backup of the plan's ``V_ι = max_a Q_ι`` under that
model: ``Q̃_ι(s, a_R) = Σ_{a_H} P̃(a_H | ·) (R(s, a_R, a_H) + γ V_ι(next(s, a_R, a_H)))``
(the plan's Q where the episode has not yet been). A robot that waited and saw the human
wait does not wait there again and again; the episode's counts are dropped at its end,
when the steps are counted in hindsight.

**Act** (QMDP): ``a = argmax_a Σ_ι b(ι) Q̃_ι(s, a)`` over the valid actions. Ties (within
1e-9 of the best, relative) go to the Passive baseline's action if it is among them, else
to the lowest action index. Nothing is random: a run's actions depend on its own episodes
only, whatever the batching and the seed.

Shapes: ``B`` runs, ``K`` supports (= intentions), ``S`` states, ``A`` actions, ``C``
robot classes, ``X`` = K with ``by_start``, else 1.

The human model and its learning are :class:`baselines.countmodel.CountModel`'s (the base
class of :class:`CountQMDP`); this module holds the filter, the plan and the action, and
re-exports the model's public functions.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from agents.protocol import Trace
from baselines.bounds import reward_table
from baselines.countmodel import (
    HINDSIGHT,
    ROBOT_CONTEXTS,
    CountModel,
    change_of_mind,
    prior_policy,
    relative_actions,
    robot_classes,
    state_roles,
)
from hri_envs.checks import check_real
from hri_envs.errors import ConfigError
from hri_envs.task import episode as rules
from hri_envs.task import mdp
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph

__all__ = ["HINDSIGHT", "ROBOT_CONTEXTS", "CountQMDP", "change_of_mind", "prior_policy",
           "relative_actions", "robot_classes", "state_roles"]

#: Mixed values within this (relative) of the best are ties.
_TIE = 1e-9
#: MDPs solved per call (bounds the dense (S, A, S) transitions held at once).
_CHUNK = 96


class CountQMDP(CountModel):
    """Dirichlet counts of the human's actions, a Bayes filter over ι, QMDP (module docstring).

    Args:
        graph: The task graph.
        n_runs: Independent runs.
        r0: The study's waiting reward, in (-1, 0) (default the hanger's -0.33).
        reward: The study's reward rule, one of :data:`hri_envs.task.episode.REWARD_RULES`.
        rho: ρ > 0, the prior's weight in the shared goal-relative level, or ``inf`` to
            leave that level out (default 1).
        alpha: α > 0, the weight of the shared level in the (ι, s) level (default 1).
        kappa: κ > 0, the weight of the (ι, s) level in a refined context (default 1).
        prior_beta: β > 0 of the shortest-path prior (default 3, the goal filter's).
        prior_epsilon: Weight in (0, 1) of a uniform choice in the prior (default 0.05).
        gamma: Discount γ in [0, 1) of the plans (default 0.95).
        hazard: The filter's change-of-mind probability per motion into free space, in
            [0, 1) (default 0.05).
        decay: Factor in (0, 1] applied to every count after each episode (default 1).
        robot_context: How the robot's action of the step splits the human's context, one
            of :data:`ROBOT_CONTEXTS` (default ``"wait"``).
        by_start: Whether the start support splits the human's context (default False).
        hindsight: One of :data:`HINDSIGHT`: ``"revealed"`` (a step counts under the
            revealed intention) or ``"smooth"`` (weighted by the smoothed posterior under
            ``hazard``; the default).
        adapt: Whether the actions use this episode's steps already (module docstring,
            "Adapt"; default True).
        wait_weight: λ > 0, the prior weight of the wait rates (default 1).

    Attributes:
        shared: (B, S, 3, A) the counts ``R`` of the goal-relative level, per role.
        pooled: (B, K, S, A) the counts ``M`` per (ι, s).
        counts: (B, X, K, S, C, A) the counts ``N`` per full context.
        q: (B, K, K, S, A) the robot's Q per (start, ι).
        posterior: (B, K) the belief over ι in each run's episode (:meth:`belief`).

    Raises:
        ConfigError: A parameter outside its range; the message says what is allowed.
    """

    name: ClassVar[str] = "countqmdp"

    def __init__(self, graph: TaskGraph, n_runs: int = 1, *, r0: float = -0.33,
                 reward: str = "paper", rho: float = 1.0, alpha: float = 1.0,
                 kappa: float = 1.0, prior_beta: float = 3.0, prior_epsilon: float = 0.05,
                 gamma: float = 0.95, hazard: float = 0.05, decay: float = 1.0,
                 robot_context: str = "wait", by_start: bool = False,
                 hindsight: str = "smooth", adapt: bool = True, wait_weight: float = 1.0
                 ) -> None:
        super().__init__(graph, n_runs)
        self.r0 = check_real(r0, "r0", low=-1.0, high=0.0, low_open=True, high_open=True)
        self.reward = rules.reward_rule(reward).name  # a ConfigError names the rules
        self.rho = check_real(rho, "rho", low=0.0, low_open=True, allow_inf=True,
                              allowed="a number > 0, or inf (no shared level)")
        self.alpha = check_real(alpha, "alpha", low=0.0, low_open=True, high=1e6)
        self.kappa = check_real(kappa, "kappa", low=0.0, low_open=True, high=1e6)
        self.prior_beta = check_real(prior_beta, "prior_beta", low=0.0, low_open=True,
                                     high=1e3)
        self.prior_epsilon = check_real(prior_epsilon, "prior_epsilon", low=0.0, high=1.0,
                                        low_open=True, high_open=True)
        self.gamma = check_real(gamma, "gamma", low=0.0, high=1.0, high_open=True)
        self.hazard = check_real(hazard, "hazard", low=0.0, high=1.0, high_open=True)
        self.decay = check_real(decay, "decay", low=0.0, high=1.0, low_open=True)
        self.wait_weight = check_real(wait_weight, "wait_weight", low=0.0, low_open=True,
                                      high=1e6)
        for flag, value in (("by_start", by_start), ("adapt", adapt)):
            if not isinstance(value, bool | np.bool_):
                raise ConfigError(f"{flag} must be True or False, got {value!r}", field=flag)
        self.adapt = bool(adapt)
        if not isinstance(hindsight, str) or hindsight not in HINDSIGHT:
            raise ConfigError(f"hindsight must be one of {', '.join(HINDSIGHT)}, got "
                              f"{hindsight!r}", field="hindsight")
        self.hindsight = hindsight
        self.robot_context = robot_context
        self.classes = robot_classes(graph, robot_context)  # (A,)
        self.by_start = bool(by_start)
        g = graph
        n_k, n_s, n_a = g.n_intentions, g.n_states, g.n_actions
        n_c = int(self.classes.max()) + 1
        self.refined = n_c > 1 or self.by_start
        self.prior = prior_policy(g, self.prior_beta, self.prior_epsilon)  # (K, K, S, A)
        # (S,) π0's wait, the same for every start and ι in free space (ε / valid actions).
        self._prior_wait = self.prior[..., WAIT].mean((0, 1))
        self.relative = relative_actions(g)  # (K, K, A)
        self.roles = state_roles(g)  # (K, K, S)
        self.shared = np.zeros((n_runs, n_s, 3, n_a))
        self.pooled = np.zeros((n_runs, n_k, n_s, n_a))
        self.counts = np.zeros((n_runs, n_k if self.by_start else 1, n_k, n_s, n_c, n_a))
        # This episode's steps, weighted by the belief after each (see "Adapt").
        self._fresh = np.zeros((n_runs, n_k, n_s, n_c, n_a))
        self._fresh_pooled = np.zeros((n_runs, n_k, n_s, n_a))
        # The human's waits and all its steps per (free state, robot class), any ι.
        self._waits_seen = np.zeros((n_runs, n_s, n_c))
        self._steps_seen = np.zeros((n_runs, n_s, n_c))
        self._fresh_waits = np.zeros((n_runs, n_s, n_c))
        self._fresh_steps = np.zeros((n_runs, n_s, n_c))
        # (K, S, A, A) the reward of (s, a_R, a_H) from each start, lifted once off it.
        lifted = (g.support[None, :] != np.arange(n_k)[:, None]).astype(np.int64)  # (K, S)
        table = reward_table(g, self.r0, reward)  # (K, 2, S, A, A)
        self._reward = table[np.arange(n_k)[:, None], lifted, np.arange(n_s)[None, :]]
        # (K, K, S) where the episode ends in the MDP of (start, ι).
        resting = (g.support >= 0) & (g.grasp == 0)
        other = g.support[None, None, :] != np.arange(n_k)[:, None, None]
        back = (np.arange(n_k)[:, None] == np.arange(n_k)[None, :])[..., None]
        self._absorbing = resting[None, None] & (other | back)
        self.posterior = np.full((n_runs, n_k), 1.0 / n_k)
        # Every run starts from the prior: plan once, copy to every run.
        self.q = np.repeat(self.plan(self.law(np.zeros(1, dtype=np.int64))), n_runs, axis=0)
        masked = np.where(g.valid, self.q, -np.inf)
        self._greedy = np.argmax(masked, axis=-1)
        self._value = masked.max(-1)  # (B, K, K, S)

    @classmethod
    def defaults(cls, **changes: Any) -> dict[str, Any]:
        """The keyword parameters with their defaults (changed by ``changes``), as recorded
        in a study's ``summary.json``.

        Raises:
            ConfigError: A change names no parameter.
        """
        params = inspect.signature(cls.__init__).parameters
        out = {k: p.default for k, p in params.items() if p.kind is p.KEYWORD_ONLY}
        unknown = sorted(set(changes) - set(out))
        if unknown:
            raise ConfigError(f"unknown countqmdp parameter(s) {', '.join(unknown)}; allowed: "
                              f"{', '.join(out)}", field=unknown[0])
        return {**out, **changes}

    def settings(self) -> dict[str, Any]:
        """The agent's parameters (the keywords of the constructor)."""
        return {k: getattr(self, k) for k in self.defaults()}

    # ------------------------------------------------------------------ planning
    def plan(self, law: np.ndarray, warm: np.ndarray | None = None) -> np.ndarray:
        """(R, K, K, S, A) the robot's Q per (start, ι) for laws (R, K, K, S, C, A) (module
        docstring, "Plan"); ``warm`` (R, K, K, S) the greedy actions to start policy
        iteration from.
        """
        g = self.graph
        n_k, n_s, n_a = g.n_intentions, g.n_states, g.n_actions
        n_r = len(law)
        flat_law = law.reshape(n_r * n_k * n_k, *law.shape[3:])  # (N, S, C, A)
        st = np.tile(np.repeat(np.arange(n_k), n_k), n_r)  # (N,) the MDPs' starts
        io = np.tile(np.arange(n_k), n_r * n_k)  # (N,) and intentions
        warm_flat = None if warm is None else warm.reshape(-1, n_s)
        out = np.empty((len(flat_law), n_s, n_a))
        nxt = g.next_state  # (S, A, A)
        for lo in range(0, len(flat_law), _CHUNK):
            hi = min(lo + _CHUNK, len(flat_law))
            n = hi - lo
            p = flat_law[lo:hi][:, :, self.classes, :]  # (n, S, A_R, A_H)
            flat = ((np.arange(n)[:, None, None, None] * n_s + np.arange(n_s)[:, None, None])
                    * n_a + np.arange(n_a)[:, None]) * n_s + nxt[None]  # (n, S, A, A)
            t = np.bincount(flat.ravel(), p.ravel(), minlength=n * n_s * n_a * n_s)
            t = t.reshape(n, n_s, n_a, n_s)  # T(s' | s, a_R)
            r = np.einsum("nsah,nsah->nsa", p, self._reward[st[lo:hi]])
            absorb = self._absorbing[st[lo:hi], io[lo:hi]]  # (n, S)
            t[absorb] = 0.0
            m, s_abs = np.nonzero(absorb)
            t[m, s_abs, :, s_abs] = 1.0
            r[absorb] = 0.0
            policy = None if warm_flat is None else warm_flat[lo:hi]
            out[lo:hi] = mdp.solve_q(t, r, g.valid, self.gamma, policy=policy)
        return out.reshape(n_r, n_k, n_k, n_s, n_a)

    def _replan(self) -> None:
        """Q of every run's MDPs from the current counts (warm-started), and their V."""
        self.q = self.plan(self.law(), self._greedy)
        masked = np.where(self.graph.valid, self.q, -np.inf)
        self._greedy = np.argmax(masked, axis=-1)
        self._value = masked.max(-1)  # (B, K, K, S)

    def action_values(self, states: np.ndarray) -> np.ndarray:
        """(B, K, A) each run's ``Q_ι(s, ·)`` in its state (module docstring, "Adapt").

        Without ``adapt``, the plan's. With it, one Bellman backup of the plan's values
        ``V_ι = max_a Q_ι`` under the model with this episode's steps counted:
        ``Σ_{a_H} P̃(a_H | st, ι, s, c(a_R)) (R(s, a_R, a_H) + γ V_ι(next(s, a_R, a_H)))``,
        which is the plan's Q wherever the episode has not yet been.
        """
        rows = np.arange(self.n_runs)
        if not self.adapt:
            return self.q[rows, self.start, :, states]
        n_k = self.graph.n_intentions
        law = self.predictive(rows[:, None, None], self.start[:, None, None],
                              np.arange(n_k)[None, :, None], states[:, None, None],
                              self.classes[None, None, :])  # (B, K, A_R, A_H)
        nxt = self.graph.next_state[states]  # (B, A_R, A_H)
        value = self._value[rows, self.start]  # (B, K, S)
        after = value[rows[:, None, None, None], np.arange(n_k)[None, :, None, None],
                      nxt[:, None]]  # (B, K, A_R, A_H)
        reward = self._reward[self.start, states]  # (B, A_R, A_H)
        return np.einsum("bkrh,bkrh->bkr", law, reward[:, None] + self.gamma * after)

    # ------------------------------------------------------------------ protocol
    def begin_episode(self, starts: np.ndarray) -> None:
        """Belief uniform over the supports other than the start."""
        super().begin_episode(starts)
        k = self.graph.n_intentions
        self.posterior = np.where(np.arange(k)[None] == self.start[:, None], 0.0, 1.0 / (k - 1))
        for a in (self._fresh, self._fresh_pooled, self._fresh_waits, self._fresh_steps):
            a[:] = 0.0

    def belief(self) -> np.ndarray:
        """(B, K) the posterior over ι (a copy; the agent protocol's)."""
        return self.posterior.copy()

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """QMDP: the valid action of best belief-weighted Q (ties: the passive action, else
        the lowest index).
        """
        states = np.asarray(observations["state"], dtype=np.int64).reshape(self.n_runs)
        rows = np.arange(self.n_runs)
        score = np.einsum("bk,bka->ba", self.posterior, self.action_values(states))
        score = np.where(self.graph.valid[states], score, -np.inf)
        best = score.max(axis=1, keepdims=True)
        near = score >= best - _TIE * (1.0 + np.abs(best))
        passive = self.passive(states)
        return np.where(near[rows, passive], passive, np.argmax(near, axis=1))

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Bayes' rule on the human's action, then the change-of-mind hazard."""
        super().observe(states, robot_actions, human_actions, next_states, active)
        k = self.graph.n_intentions
        s, a_r, a_h, s2 = (np.asarray(x, dtype=np.int64).reshape(self.n_runs) for x in (
            states, robot_actions, human_actions, next_states))
        allowed = self.lifted[:, None] | (np.arange(k)[None] != self.start[:, None])
        post = self.posterior * self.likelihood(s, a_r, a_h) * allowed
        total = post.sum(1, keepdims=True)
        post = np.where(total > 0, post / np.where(total > 0, total, 1.0), self.posterior)
        if self.adapt:  # this step, weighted by the belief in each ι
            w = np.where(active[:, None], post, 0.0)
            rows = np.arange(self.n_runs)[:, None]
            io = np.arange(k)[None, :]
            self._fresh[rows, io, s[:, None], self.classes[a_r][:, None], a_h[:, None]] += w
            self._fresh_pooled[rows, io, s[:, None], a_h[:, None]] += w
            free = active & ~self.graph.is_support_state[s]
            self._fresh_waits[rows[:, 0], s, self.classes[a_r]] += free & (a_h == WAIT)
            self._fresh_steps[rows[:, 0], s, self.classes[a_r]] += free
        if self.hazard > 0.0:
            post = np.where(self._may_switch(s, s2)[:, None],
                            change_of_mind(post, allowed, self.hazard), post)
        self.posterior = np.where(active[:, None], post, self.posterior)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Forget by ``decay``, count the episode's steps in hindsight, plan again."""
        intentions = np.asarray(intentions, dtype=np.int64).reshape(self.n_runs)
        for fresh in (self._fresh, self._fresh_pooled, self._fresh_waits, self._fresh_steps):
            fresh[:] = 0.0
        if self.decay < 1.0:
            for seen in (self.shared, self.pooled, self.counts, self._waits_seen,
                         self._steps_seen):
                seen *= self.decay
        self.add_counts(traces, intentions)
        self._replan()




