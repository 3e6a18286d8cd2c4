"""The routes a human may take to each goal, and a Bayesian filter over them.

**The model** (what the goal-inference robots assume of the human; docs/physical-
baselines.md). A human who carries the object to support ``g`` takes it along a route
through the task graph's abstract states (take off, moves over, up or down, rotations,
put on), as the scripted preference humans of the abstract benchmark do; which route
depends on their *preference*, an ordering of those moves. The robot knows the task graph,
the episode's geometry and the scenario's list of preferences (all public:
``task.graph``, ``task.geometry``, ``spec_of(task.graph).preferences``); it does not know
the human's goal or preference. So its hypotheses are the pairs (goal, preference), each
a route: the abstract states of :func:`~hri_envs.physics.carry.human.intention.route_states` as
object poses (:class:`~hri_envs.physics.scene.observer.StateObserver`), a polyline in the space of
object poses embedded as ``x = (p, L θ)`` (position [m] and the rotation vector from the
start's orientation [rad] times the lever ``L`` [m/rad], ``task.design.lever``).
Preferences that give the same route are merged into one hypothesis whose prior weight is
their number; the prior over goals is uniform.

**The likelihood** of one step's observation under a route ``h``: the object at ``x``
projects onto the route (the nearest point; at equal distance the later segment), and the
human, whose hand tracks a reference that moves along the route, is expected to move and
push the object towards the route's point ``lookahead_m`` further on: the direction
``u_h``. With the object's velocity ``ẋ = (v, L ω)`` and the human's wrench as the dual
``f = (F, τ / L)`` (torque about the object's origin)::

    log p(obs | h) = κ_v min(|ẋ| / v_ref, 1) cos(ẋ, u_h)
                   + κ_f min(|f| / f_ref, 1) cos(f, u_h)
                   - (d_h² - min_h' d_h'²) / (2 σ²)

(``d_h``: the object's distance from the route: far from a route, it is unlikely to be
the one the human's reference follows). After each update the posterior is mixed with
the prior, ``b <- (1 - ε) b + ε b_0``, so that no hypothesis is ever ruled out for good
(a robot that pushes the object along a wrong route can be corrected).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.intention import route_states
from hri_envs.physics.carry.robot_view import RobotTask
from hri_envs.physics.scene.kinematics import rotation_error
from hri_envs.physics.scene.observer import StateObserver
from hri_envs.task.scenarios import spec_of

__all__ = ["FilterParams", "Projection", "RouteFilter", "Routes"]


class Projection(NamedTuple):
    """The object's place relative to every route (H hypotheses).

    Attributes:
        direction: (H, 6) unit direction from the object to the route's lookahead point
            (embedded: metres, ``L`` x radians); zero at the route's end.
        distance: (H,) distance [m, embedded] from the object to the route.
        remaining: (H,) the route's length [m, embedded] from the projection to its end.
        target: (H, 6) the lookahead point (embedded).
    """

    direction: np.ndarray
    distance: np.ndarray
    remaining: np.ndarray
    target: np.ndarray


class Routes:
    """The (goal, preference) hypotheses of one episode and their routes.

    Args:
        task: The episode's public facts (graph, geometry, start, design's lever).
        preferences: The preferences the human may have (default: the scenario's list).

    Attributes:
        goals: (H,) each hypothesis's goal support.
        prior: (H,) the prior (uniform over goals, then over preferences).
        vertices: (H, V, 6) each route's vertices, embedded (padded by repeating the last).
        lever: L [m/rad].
    """

    def __init__(self, task: RobotTask, preferences: Sequence[str] | None = None) -> None:
        graph = task.graph
        prefs = tuple(preferences if preferences is not None
                      else spec_of(task.graph).preferences)
        if not prefs:
            raise ConfigError("preferences must name at least one preference",
                              field="preferences")
        self.lever = float(task.design.lever)
        observer = StateObserver(graph, task.geometry, self.lever)
        self.q0 = observer.pose(graph.support_state(task.start))[1]
        goals = [g for g in range(graph.n_intentions) if g != task.start]
        counts: dict[tuple[int, tuple[int, ...]], int] = {}
        for goal in goals:
            for pref in prefs:
                key = (goal, tuple(route_states(graph, task.start, goal, pref)))
                counts[key] = counts.get(key, 0) + 1
        keys = list(counts)
        self.goals = np.array([g for g, _ in keys])
        self.prior = np.array([counts[k] / len(prefs) / len(goals) for k in keys])
        routes = [np.array([self.embed(*observer.pose(s)) for s in states])
                  for _, states in keys]
        n_v = max(len(r) for r in routes)
        self.vertices = np.stack([np.concatenate([r, np.repeat(r[-1:], n_v - len(r), 0)])
                                  for r in routes])  # (H, V, 6)
        seg = np.diff(self.vertices, axis=1)  # (H, V-1, 6)
        self._seg = seg
        self._len = np.linalg.norm(seg, axis=2)  # (H, V-1)
        self._cum = np.concatenate([np.zeros((len(routes), 1)), np.cumsum(self._len, 1)], 1)
        self.n_goals = graph.n_intentions

    def embed(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(6,) the pose (``pos``, ``quat``) embedded: ``(p, L θ)``."""
        return np.concatenate([pos, self.lever * rotation_error(quat, self.q0)])

    def twist_of(self, direction: np.ndarray, speed: float) -> tuple[np.ndarray, np.ndarray]:
        """The object twist (v [m/s], ω [rad/s]) moving at ``speed`` [m/s, embedded] along
        an embedded ``direction``.
        """
        return direction[:3] * speed, direction[3:] * speed / self.lever

    def project(self, x: np.ndarray, lookahead_m: float) -> Projection:
        """Where the embedded pose ``x`` (6,) lies relative to every route."""
        rel = x[None, None, :] - self.vertices[:, :-1, :]  # (H, V-1, 6)
        seg_sq = np.maximum(self._len**2, 1e-12)
        t = np.clip(np.einsum("hvk,hvk->hv", rel, self._seg) / seg_sq, 0.0, 1.0)
        t = np.where(self._len > 1e-9, t, 1.0)
        foot = self.vertices[:, :-1, :] + t[..., None] * self._seg
        dist = np.linalg.norm(x[None, None, :] - foot, axis=2)  # (H, V-1)
        n_seg = dist.shape[1]
        # At equal distance (a vertex), the later segment: the route goes on from there.
        j = np.argmin(dist - 1e-9 * np.arange(n_seg)[None, :], axis=1)  # (H,)
        h = np.arange(len(j))
        arc = self._cum[h, j] + t[h, j] * self._len[h, j]  # (H,)
        total = self._cum[:, -1]
        target = self._point_at(np.minimum(arc + lookahead_m, total))
        direction = target - x[None, :]
        norm = np.linalg.norm(direction, axis=1, keepdims=True)
        direction = np.where(norm > 1e-6, direction / np.maximum(norm, 1e-12), 0.0)
        return Projection(direction, dist[h, j], total - arc, target)

    def _point_at(self, arc: np.ndarray) -> np.ndarray:
        """(H, 6) each route's point at arc length ``arc`` (H,)."""
        h = np.arange(len(arc))
        j = np.clip(np.sum(self._cum[:, 1:] < arc[:, None], axis=1), 0, self._len.shape[1] - 1)
        t = np.where(self._len[h, j] > 1e-9,
                     (arc - self._cum[h, j]) / np.maximum(self._len[h, j], 1e-12), 1.0)
        return self.vertices[h, j] + np.clip(t, 0.0, 1.0)[:, None] * self._seg[h, j]

    def goal_marginal(self, weights: np.ndarray) -> np.ndarray:
        """(K,) the weights (H,) summed per goal (0 for the start support)."""
        return np.bincount(self.goals, weights=weights, minlength=self.n_goals)


@dataclass(frozen=True)
class FilterParams:
    """The route filter's parameters (see the module docstring).

    Attributes:
        kappa_v: Weight of the velocity's direction (per step).
        kappa_f: Weight of the wrench's direction (per step).
        speed_ref: Speed [m/s, embedded] from which the velocity counts fully.
        force_ref: Wrench [N, embedded] from which it counts fully.
        sigma_m: Spread [m, embedded] of the object around the route it follows.
        lookahead_m: How far ahead on a route the human is expected to head [m, embedded].
        mix: ε, the weight of the prior mixed into the posterior after each step.
    """

    kappa_v: float = 1.0
    kappa_f: float = 0.5
    speed_ref: float = 0.1
    force_ref: float = 2.0
    sigma_m: float = 0.05
    lookahead_m: float = 0.1
    mix: float = 0.002


class RouteFilter:
    """A Bayesian filter over the episode's route hypotheses (:class:`Routes`).

    Args:
        routes: The hypotheses.
        params: The likelihood's parameters.

    Attributes:
        posterior: (H,) the posterior over hypotheses.
        last: The last :class:`Projection`.
    """

    def __init__(self, routes: Routes, params: FilterParams) -> None:
        self.routes, self.params = routes, params
        self.posterior = routes.prior.copy()
        self.last: Projection | None = None

    def log_likelihood(self, proj: Projection, velocity: np.ndarray, wrench: np.ndarray
                       ) -> np.ndarray:
        """(H,) log p(step | h) for the embedded velocity (6,) and wrench (6,)."""
        p = self.params
        out = np.zeros(len(proj.distance))
        for signal, ref, kappa in ((velocity, p.speed_ref, p.kappa_v),
                                   (wrench, p.force_ref, p.kappa_f)):
            norm = float(np.linalg.norm(signal))
            if norm > 1e-9 and kappa > 0:
                out += kappa * min(norm / ref, 1.0) * (proj.direction @ (signal / norm))
        d2 = proj.distance**2
        return out - (d2 - d2.min()) / (2.0 * p.sigma_m**2)

    def update(self, x: np.ndarray, velocity: np.ndarray, wrench: np.ndarray) -> Projection:
        """One step: the object at embedded ``x`` (6,) moving with ``velocity`` (6,), the
        human's wrench ``wrench`` (6,, embedded dual). Returns the projection.
        """
        proj = self.routes.project(x, self.params.lookahead_m)
        log_post = np.log(np.maximum(self.posterior, 1e-300)) + self.log_likelihood(
            proj, velocity, wrench)
        post = np.exp(log_post - log_post.max())
        post /= post.sum()
        eps = self.params.mix
        self.posterior = (1.0 - eps) * post + eps * self.routes.prior
        self.last = proj
        return proj

    def goals(self) -> np.ndarray:
        """(K,) the posterior over the supports as the human's goal (sums to 1)."""
        return self.routes.goal_marginal(self.posterior)
