"""Exact plans on the product of the task's and the human's states, and the references on it.

For a :class:`~hri_envs.humans.finite_state.FiniteStateHuman` (every family of
:mod:`hri_envs.humans.families`, a scripted human without turning back as the case Z = 1)
the world within an episode is Markov in the node ``(start, ι, lifted, s, z)``: the human's
law, its state update and its changes of mind depend on nothing else. :func:`plan_product`
solves the robot's problem on these nodes exactly:

The plans (the objective, backward induction, the plan cache) are
:mod:`baselines.product_plan`'s; :func:`plan_product`, :class:`ProductPlan` and
:func:`model_of_row` are re-exported here.

**References on the product.**

* :class:`PerRunInformed` (agent ``informed`` with humans drawn per run): sees ι and the
  human's state ``z`` every step and follows each run's exact plan, solved once per distinct
  human (plans are cached by the model's :attr:`fingerprint`); a scripted human that turns
  back is planned by :func:`baselines.bounds.plan` (which keeps turning back hidden until it
  happens), per distinct human too. No robot can expect more on the same humans: it is the
  upper bound of every track's reference.
* :class:`QMDP` (agent ``qmdp``): a robot that knows each run's human model and its state
  at the start of each episode, but not ι: it keeps the exact posterior over (ι, z) (Bayes
  filter on the human's actions, its state updates and changes of mind) and takes the
  action with the best posterior-weighted value of the informed plan (QMDP). It is a
  feasible intention-blind policy, so its simulated reward is a lower bound, in
  expectation, on the intention-blind optimum ``blind`` for the same humans; with
  ``informed`` above it, it brackets ``blind`` where the exact ``blind`` plan does not fit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from baselines.bounds import Plan, plan
from baselines.product_plan import ProductPlan, model_of_row, node_index, plan_product
from baselines.simple import Tracking
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans, as_model
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.graph import TaskGraph

__all__ = ["QMDP", "PerRunInformed", "ProductPlan", "model_of_row", "plan_product"]


# --------------------------------------------------------------------------- the agents
class _ProductRows(Tracking):
    """Shared bookkeeping of the agents that follow product plans: rows grouped by plan
    (start and lifted tracking, and the passive action, are :class:`Tracking`'s).
    """

    def __init__(self, graph: TaskGraph, human: ScriptedHuman | BatchHuman, n_runs: int, *,
                 r0: float, max_steps: int = 100, reward: str = "paper", episodes: int = 1
                 ) -> None:
        super().__init__(graph, n_runs)
        self.human = human
        self.r0, self.max_steps, self.reward, self.episodes = r0, max_steps, reward, episodes
        self.steps = np.zeros(n_runs, dtype=np.int64)
        self.z_start = np.zeros(n_runs, dtype=np.int64)
        self.episode = -1
        self.groups: list[tuple[ProductPlan, np.ndarray]] = []

    def _product_model(self, row: int) -> FiniteStateHuman | None:
        model = model_of_row(self.human, row)
        if isinstance(model, ScriptedHuman):
            return None if model.turn_back > 0 else as_model(model)
        return model

    def _z(self) -> np.ndarray:
        """(n_runs,) the human's state in each row now (0 for a one-state human)."""
        h = self.human
        return h.z.copy() if isinstance(h, FiniteStateHumans) else np.zeros(self.n_runs,
                                                                            dtype=np.int64)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Look up each row's human model and its plan; group the rows by plan."""
        super().begin_episode(starts)
        self.steps[:] = 0
        self.episode += 1
        self.z_start = self._z()
        by_plan: dict[int, tuple[ProductPlan, list[int]]] = {}
        for i in range(self.n_runs):
            m = self._product_model(i)
            if m is None:
                continue
            p = plan_product(self.graph, m, r0=self.r0, max_steps=self.max_steps,
                             reward=self.reward, episodes=self.episodes)
            by_plan.setdefault(id(p), (p, []))[1].append(i)
        self.groups = [(p, np.asarray(rows, dtype=np.int64)) for p, rows in by_plan.values()]

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Count the steps and the lifted flag."""
        super().observe(states, robot_actions, human_actions, next_states, active)
        self.steps += active


class PerRunInformed(_ProductRows):
    """The information bound for humans of their own per run (see the module docstring).

    Privileged: needs ``observations["intention"]``; reads each row's human model and state
    ``z`` from the seat (like the Oracle reads the preference).
    """

    name: ClassVar[str] = "informed"
    privileged: ClassVar[bool] = True

    def __init__(self, graph: TaskGraph, human: ScriptedHuman | BatchHuman, n_runs: int, *,
                 r0: float, max_steps: int = 100, reward: str = "paper", episodes: int = 1
                 ) -> None:
        super().__init__(graph, human, n_runs, r0=r0, max_steps=max_steps, reward=reward,
                         episodes=episodes)
        self._v0: dict[int, _V0Cursor] = {}

    def begin_episode(self, starts: np.ndarray) -> None:
        """Plans per row: the product plan, or the scripted plan of a turning-back human."""
        super().begin_episode(starts)
        self._v0 = {}
        for i in range(self.n_runs):
            model = model_of_row(self.human, i)
            if isinstance(model, ScriptedHuman) and model.turn_back > 0:
                p = plan(self.graph, model, r0=self.r0, max_steps=self.max_steps,
                         informed=True, reward=self.reward)
                self._v0[i] = _V0Cursor(p, int(self.start[i]))

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Each row's plan's action for its node and steps left."""
        if "intention" not in observations:
            raise KeyError("the informed agent needs observations['intention'] (privileged)")
        states = np.asarray(observations["state"], dtype=np.int64)
        goal = np.asarray(observations["intention"], dtype=np.int64)
        out = self.passive(states)
        left = np.maximum(self.max_steps - self.steps, 1)
        z = self._z()
        for p, rows in self.groups:
            pol = p.policies[p.index(self.episode)]
            n = node_index(self.graph, p.human.n_z, self.start[rows], goal[rows],
                           self.lifted[rows], states[rows], z[rows])
            out[rows] = pol[np.minimum(left[rows], len(pol) - 1), n]
        for i, cursor in self._v0.items():
            if active[i]:
                out[i] = cursor.act(int(goal[i]), int(left[i]), int(out[i]))
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Advance the scripted cursors; count steps."""
        for i, cursor in self._v0.items():
            if active[i]:
                cursor.observe(self.graph, int(states[i]), int(robot_actions[i]),
                               int(human_actions[i]), int(next_states[i]))
        super().observe(states, robot_actions, human_actions, next_states, active)


class _V0Cursor:
    """One row's walk through an informed :class:`~baselines.bounds.Plan` (a scripted human
    who turns back), as :class:`baselines.bounds.Informed` walks it.
    """

    def __init__(self, p: Plan, start: int) -> None:
        self.plan, self.start = p, start
        self.node = -1
        self.pending: tuple[int, int, int] | None = None
        self.fresh = True

    def act(self, intention: int, left: int, passive: int) -> int:
        k = self.plan.n_supports
        if self.fresh:
            self.node = int(self.plan.roots[self.start, intention])
            self.fresh = False
        if self.pending is not None:
            n, a_r, a_h = self.pending
            self.node = self.plan.successor.get((n, a_r, a_h * k + intention), -1)
            self.pending = None
        if self.node < 0:
            return passive
        return int(self.plan.policy[min(left, self.plan.horizon), self.node])

    def observe(self, graph: TaskGraph, s: int, a_r: int, a_h: int, s2: int) -> None:
        if self.node < 0:
            return
        if graph.next_state[s, a_r, a_h] != s2:
            self.node = -1
            return
        self.pending = (self.node, a_r, a_h)


class QMDP(_ProductRows):
    """The bracket's lower bound: QMDP on the exact posterior over (ι, z) (module docstring).

    Not privileged: it never reads ι; it reads each row's human model and the human's state
    at the start of each episode from the seat (what ``blind`` is given), and nothing of the
    human during the episode but its actions.

    Attributes:
        posterior: (n_runs, K, Z_max) the posterior over (ι, z) of each row (rows of a model
            with fewer states use the first Z).
    """

    name: ClassVar[str] = "qmdp"

    def begin_episode(self, starts: np.ndarray) -> None:
        """Prior: ι uniform among the other supports, the human's state as the episode starts."""
        super().begin_episode(starts)
        self._stack = _Stack(self.graph, self.groups, self.n_runs, self.episode,
                             getattr(self, "_stack", None))
        k = self.graph.n_intentions
        n_z = self._stack.z_max
        self.posterior = np.zeros((self.n_runs, k, n_z))
        rows = np.arange(self.n_runs)
        self.posterior[rows[:, None], np.arange(k)[None, :], self.z_start[:, None]] = 1.0 / (k - 1)
        self.posterior[rows, self.start] = 0.0

    def belief(self) -> np.ndarray | None:
        """(n_runs, K) the marginal over ι of the posterior over (ι, z) (the agent protocol's);
        None before the first episode.
        """
        posterior = getattr(self, "posterior", None)
        return None if posterior is None else posterior.sum(-1)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """argmax_a Σ_(ι,z) b(ι, z) Q_informed((start, ι, lifted, s, z), a), every row at once
        (the rows' plans stacked, :class:`_Stack`).
        """
        states = np.asarray(observations["state"], dtype=np.int64)
        out = self.passive(states)
        st = self._stack
        rows = st.rows
        if rows.size == 0:
            return out
        k = self.graph.n_intentions
        z = np.arange(st.z_max)[None, None, :]
        n_z = st.n_z[rows, None, None]
        nodes = node_index(self.graph, n_z, self.start[rows, None, None],
                           np.arange(k)[None, :, None], self.lifted[rows, None, None],
                           states[rows, None, None], np.minimum(z, n_z - 1))
        vals = st.q[st.q_off[rows, None, None] + nodes]  # (R, K, Z, A), 0 where not finite
        score = np.einsum("rkz,rkza->ra", self.posterior[rows], vals)
        score = np.where(self.graph.valid[states[rows]], score, -np.inf)
        out[rows] = np.argmax(score, axis=1)
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Bayes' rule on the human's action, then its state update and changes of mind (every
        active row at once).
        """
        st = self._stack
        rows = st.rows[active[st.rows]]
        if rows.size:
            self._update(rows, *(np.asarray(x, dtype=np.int64) for x in (
                states, robot_actions, human_actions, next_states)))
        super().observe(states, robot_actions, human_actions, next_states, active)

    def _update(self, rows: np.ndarray, s: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                s2: np.ndarray) -> None:
        stack = self._stack
        k = self.graph.n_intentions
        n_r, z_max = len(rows), stack.z_max
        io = np.arange(k)[None, :, None]
        zz = np.minimum(np.arange(z_max)[None, None, :], stack.n_z[rows, None, None] - 1)
        st, sr, ar, ah = (x[rows, None, None] for x in (self.start, s, a_r, a_h))
        slot = np.where(stack.reacts[rows, None, None], ar, 0)
        b = self.posterior[rows]  # (R, K, Z): 0 beyond each row's Z
        post = b * stack.gather("law", rows, zz, st, io, sr, slot, ah)
        z2 = stack.gather("next_z", rows, zz, st, io, sr, ar, ah).astype(np.int64)
        nb = np.zeros((n_r, k, z_max))
        r_ix = np.broadcast_to(np.arange(n_r)[:, None, None], z2.shape)
        np.add.at(nb, (r_ix, np.broadcast_to(io, z2.shape), z2), post)
        fickle = stack.has_switch[rows]
        if fickle.any():
            sw = np.where(fickle[:, None, None], stack.gather(
                "switch", rows, zz[:, 0], s2[rows, None])[:, None, :], 0.0)  # (R, 1, Z)
            moving = nb * sw
            nb -= moving
            spread = np.zeros_like(nb)
            for shift in range(1, k):
                spread[:, (np.arange(k) + shift) % k] += moving / (k - 1)
            to = np.where(fickle[:, None], stack.gather("switched", rows, zz[:, 0]),
                          np.arange(z_max)[None, :]).astype(np.int64)  # (R, Z)
            np.add.at(nb, (r_ix, np.broadcast_to(io, nb.shape),
                           np.broadcast_to(to[:, None, :], nb.shape)), spread)
        total = nb.sum((1, 2))
        lost = total <= 0.0  # off the model: start over from the prior
        if lost.any():
            r_lost = rows[lost]
            nb[lost] = 0.0
            nb[np.flatnonzero(lost)[:, None], np.arange(k)[None, :],
               self.z_start[r_lost, None]] = 1.0 / (k - 1)
            nb[np.flatnonzero(lost), self.start[r_lost]] = 0.0
            total = nb.sum((1, 2))
        self.posterior[rows] = nb / total[:, None, None]


class _Stack:
    """The human models and plans of a batch's rows, concatenated so that every row is looked
    up at once: each table raveled into one flat array, with per-row offsets and strides.

    A row's human has ``n_z[row]`` states; indices beyond it are clamped by the caller (their
    belief is 0). Rows without a plan are left out of :attr:`rows`.
    """

    def __init__(self, graph: TaskGraph, groups: Sequence[tuple[ProductPlan, np.ndarray]],
                 n_runs: int, episode: int, previous: _Stack | None = None) -> None:
        models = [p.human for p, _ in groups]
        self.models = models  # alive with the key: their ids are not reused meanwhile
        self.key = tuple((id(m), rows.tobytes()) for m, (_, rows) in zip(models, groups,
                                                                          strict=True))
        self.z_max = max([m.n_z for m in models], default=1)
        group = np.full(n_runs, -1, dtype=np.int64)
        for g, (_, rows) in enumerate(groups):
            group[rows] = g
        self.rows = np.flatnonzero(group >= 0)
        safe = np.maximum(group, 0)

        def per_row(values: Sequence[Any], dtype: Any) -> np.ndarray:
            return np.asarray(values, dtype=dtype)[safe] if values else np.zeros(n_runs, dtype)

        self.n_z = per_row([m.n_z for m in models], np.int64)
        self.reacts = per_row([m.reacts for m in models], bool)
        self.has_switch = per_row([m.switch is not None for m in models], bool)
        q = [np.where(np.isfinite(x), x, 0.0) for x in
             (p.q[p.index(episode)] for p, _ in groups)]  # (N_g, A)
        self.q = np.concatenate(q) if q else np.zeros((0, graph.n_actions))
        self.q_off = per_row(np.cumsum([0] + [len(x) for x in q])[:-1].tolist(), np.int64)
        self._flat: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        if previous is not None and previous.key == self.key:  # the same humans, same rows
            self._flat = previous._flat
            return
        for name in ("law", "next_z", "switch", "switched"):
            arrays = [np.ascontiguousarray(getattr(m, name) if getattr(m, name) is not None
                                           else np.zeros((m.n_z, graph.n_states)) if
                                           name == "switch" else np.arange(m.n_z))
                      for m in models]
            ndim = arrays[0].ndim if arrays else 1
            flat = np.concatenate([a.ravel() for a in arrays]) if arrays else np.zeros(0)
            off = per_row(np.cumsum([0] + [a.size for a in arrays])[:-1].tolist(), np.int64)
            strides = (np.asarray([[st // a.itemsize for st in a.strides] for a in arrays],
                                  dtype=np.int64)[safe] if arrays
                       else np.zeros((n_runs, ndim), np.int64))
            self._flat[name] = (flat, off, strides)

    def gather(self, name: str, rows: np.ndarray, *index: np.ndarray) -> np.ndarray:
        """``table[index]`` of each row's own model (``index`` broadcast against (R, ...))."""
        flat, off, strides = self._flat[name]
        shape = np.broadcast_shapes(*(np.shape(i) for i in index))
        extra = (slice(None),) + (None,) * (len(shape) - 1)
        at = np.broadcast_to(off[rows][extra], shape).copy()
        for d, i in enumerate(index):
            at += np.asarray(i, dtype=np.int64) * strides[rows, d][extra]
        return flat[at]
