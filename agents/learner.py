"""The paper's Learner (Algorithm 1): intention-aware cooperation with IRL preference learning.

The Learner keeps a model of the human, ``R_H(s, ι) = θᵀφ(s, ι)``, from which it derives

* the human policy estimate ``π̂_H = softmax(τ_H Q_H)``, with Q_H from Q-iteration on the
  human's transition model T_H (the robot's current policy substituted);
* one robot Q-function per intention from Q-iteration on T_R and R_R (π̂_H substituted).

During an episode it filters a belief over intentions from the human's actions (Eqs. 3-4)
and samples from a bounded soft-max of the belief-weighted Q (Eq. 5). After the episode it
removes loops from the state trace and makes one ME-IRL step on θ for the intention the
episode revealed, then recomputes π̂_H and the robot's Q.

All of this is batched: ``n_runs`` independent learners (one per simulated run) advance in
one call. A single learner is ``n_runs=1`` (or :meth:`Learner.single`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import ClassVar

import numpy as np

from agents.archive import BoundedNpz
from agents.config import LearnerConfig, default_config
from agents.learning import algorithm1, mdp, partner_mdp
from agents.protocol import BatchAgent, Trace, run_streams
from hri_envs.errors import ConfigError, LearnerStateError
from hri_envs.task import episode as rules
from hri_envs.task import mdp as task_mdp
from hri_envs.task.features import initial_theta
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["MAX_STATE_BYTES", "Learner", "LearnerStateError", "graph_fingerprint",
           "sample_actions"]

_FORMAT = "hri-envs/learner/1"
_ARRAYS = ("theta", "pi_h", "q_r", "pi_r")
#: The most memory a saved learner state's arrays may take when loaded (256 MiB: about
#: 8,000 wheel runs; a study's learners hold hundreds).
MAX_STATE_BYTES = 256 * 2**20
#: The most its metadata (a JSON string, 4 bytes per character) may take.
MAX_META_BYTES = 4 * 2**20


def graph_fingerprint(graph: TaskGraph) -> str:
    """A short hash of the graph's dynamics and features (to match saved states to graphs)."""
    h = hashlib.sha256()
    for a in (graph.next_state, graph.valid, np.round(graph.features, 9)):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def sample_actions(probs: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Inverse-CDF sampling: (N, A) probabilities and (N,) uniforms -> (N,) actions."""
    cum = np.cumsum(probs, axis=-1)
    return np.minimum((u[:, None] >= cum).sum(axis=-1), probs.shape[-1] - 1)


class Learner(BatchAgent):
    """Algorithm 1 for ``n_runs`` independent runs.

    Args:
        graph: The scenario's task graph.
        n_runs: Number of independent learners advanced together.
        config: Parameters; default: the paper's for the graph's scenario.
        seed: Base seed; run ``r`` draws from a generator seeded by ``(seed, r)``.
        runs: The run indices of this batch (default ``range(n_runs)``), so that a run's
            randomness does not depend on which batch it is in.
        workspace: Arrays each update may write into (:class:`~agents.learning.algorithm1.
            Workspace`): faster, but then the arrays below (all but ``theta``) are
            overwritten by the update after next, so copy what you keep. None (the
            default): every update makes new arrays.

    Attributes:
        theta: (B, F) feature weights of the human model.
        pi_h: (B, I, S, A) human policy estimate π̂_H(a | s, ι).
        q_r: (B, I, S, A) robot Q per intention.
        pi_r: (B, I, S, A) robot policy per intention assumed by the human model.
        posterior: (B, I) current belief over intentions (:meth:`belief` gives a copy).
    """

    name: ClassVar[str] = "learner"
    q_h: np.ndarray
    pi_h: np.ndarray
    q_r: np.ndarray

    def __init__(
        self,
        graph: TaskGraph,
        n_runs: int = 1,
        config: LearnerConfig | None = None,
        *,
        seed: int = 0,
        runs: Sequence[int] | None = None,
        workspace: algorithm1.Workspace | None = None,
    ) -> None:
        super().__init__(n_runs)
        self.graph = graph
        self.config = config if config is not None else default_config(spec_of(graph))
        runs = range(n_runs) if runs is None else runs
        if len(runs) != n_runs:
            raise ConfigError(f"runs must have n_runs={n_runs} entries, got {len(runs)}",
                              field="runs")
        self.rngs = run_streams(seed, runs)
        c = self.config
        self._tables = algorithm1.Tables.of(graph, c.r0)
        self._params = algorithm1.Params(c.gamma, c.human_temperature,
                                         c.robot_model_temperature, c.irl_temperature,
                                         c.learning_rate)
        self._valid = self._tables.valid
        # (K, 2, S) the passive baseline action per start support, lifted or not, and state.
        self._passive = task_mdp.passive_actions(graph, np.arange(graph.n_intentions)[:, None],
                                            np.array([[False, True]]))
        n_i, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
        self.posterior = np.full((n_runs, n_i), 1.0 / n_i)
        self.start = np.zeros(n_runs, dtype=np.int64)
        self.lifted = np.zeros(n_runs, dtype=bool)
        self.episodes = 0
        # Every run starts from the same model: solve it once, then copy it to all runs.
        self.theta = initial_theta(graph.n_features)[None]  # (1, F)
        uniform = np.where(self._valid, 1.0, 0.0) / self._valid.sum(1, keepdims=True)
        self.pi_r = np.broadcast_to(uniform, (1, n_i, n_s, n_a)).copy()
        self._models: algorithm1.Models | None = None  # the last update's (warm starts)
        self._theta_seen = np.zeros(0)  # a copy of the θ the last update made
        self._workspace: algorithm1.Workspace | None = None
        if self.config.initial_preference is not None and n_runs > 1:
            one = Learner(graph, 1, self.config)  # pretrains once, for every run
            self._models, self._theta_seen = one._models, one._theta_seen
        else:
            self._update()
            if self.config.initial_preference is not None:
                self._start_from_preference(self.config.initial_preference)
        assert self._models is not None
        self._adopt(algorithm1.Models(*(np.repeat(a, n_runs, axis=0) for a in self._models)))
        self._workspace = workspace

    def _start_from_preference(self, preference: str) -> None:
        """Pretrain the human model on a preference's routes (paper Sect. 7 variant).

        Each demonstration is the preference human's route from every start support to
        every other, the robot taking the same action as the human (a perfect partner).
        """
        from hri_envs.humans.scripted import preference_human

        g = self.graph
        human = preference_human(g, preference)
        pairs = [(a, b) for a in range(g.n_intentions) for b in range(g.n_intentions) if a != b]
        routes = []
        for start, goal in pairs:
            s = int(rules.start_state(g, start))
            states = [s]
            for _ in range(4 * g.n_states):  # until it rests on the goal, let go (μ = 0)
                a = int(human.preferred_action(np.array(s), np.array(start), np.array(goal)))
                s = int(g.next_state[s, a, a])
                states.append(s)
                if rules.episode_over(g, s, start, True):
                    break
            else:
                raise AssertionError(f"the {preference} route from {start} to {goal} never ends")
            routes.append(Trace(np.array(states), np.zeros(len(states) - 1, dtype=np.int64),
                                np.zeros(len(states) - 1, dtype=np.int64)))
        for _ in range(self.config.pretrain_passes):
            for (_, goal), trace in zip(pairs, routes, strict=True):
                self._update([trace] * self.n_runs, np.full(self.n_runs, goal))

    # ------------------------------------------------------------------ model updates
    def _update(self, traces: Sequence[Trace] | None = None,
                intentions: np.ndarray | None = None) -> None:
        """One ME-IRL step per run on its loop-free trace (Alg. 1 l. 17-19), unless
        ``traces`` is None, then π̂_H from θ and the current π_R (l. 20-22) and the robot's
        Q (l. 3-5): :func:`agents.learning.algorithm1.update`.

        Runs whose episode was truncated (intention -1: nothing revealed) keep their θ. The
        Q-iterations run on the sparse joint table: the dense transitions T_H, T_R of the
        paper are never built.
        """
        last = self._models
        # θ·φ of the last update's θ serves the IRL step, unless θ was changed since.
        kept = last is not None and np.array_equal(self._theta_seen, self.theta)
        new = algorithm1.update(
            self._tables, self._params, self.theta, self.pi_r, last,
            state_reward=last.state_reward if kept and last is not None else None,
            state_traces=None if traces is None else [tr.states for tr in traces],
            intentions=intentions, workspace=self._workspace)
        if last is not None and self._workspace is not None:
            self._workspace.give(last)  # replaced: the next update may write into them
        self._adopt(new)

    def _adopt(self, models: algorithm1.Models) -> None:
        """Make ``models`` the learner's current models."""
        self._models = models
        self.theta, self.q_h, self.pi_h = models.theta, models.q_h, models.pi_h
        self.q_r, self.pi_r = models.q_r, models.pi_r
        self._theta_seen = models.theta.copy()

    # ------------------------------------------------------------------ protocol
    def begin_episode(self, starts: np.ndarray) -> None:
        """Reset the belief: zero on the start support, uniform on the others (Sect. 4.1)."""
        starts = np.asarray(starts, dtype=np.int64).reshape(self.n_runs)
        n_i = self.graph.n_intentions
        self.start = starts
        self.lifted = np.zeros(self.n_runs, dtype=bool)
        self.posterior = np.where(np.arange(n_i)[None, :] == starts[:, None], 0.0, 1.0 / (n_i - 1))

    def belief(self) -> np.ndarray:
        """(B, I) the current belief over intentions (a copy; the agent protocol's)."""
        return self.posterior.copy()

    def policy(self, states: np.ndarray) -> np.ndarray:
        """(B, A) the robot's bounded soft-max policy in ``states`` under the current belief."""
        c = self.config
        baseline = None
        if c.passive_prior:
            baseline = self._passive[self.start, self.lifted.astype(np.intp), states]
        return partner_mdp.belief_policy(self.q_r, self.posterior, states, self._valid,
                                         c.robot_temperature, c.eta, baseline)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Sample the robot's actions from the bounded soft-max of Σ_ι b(ι) Q_ι (Eq. 5)."""
        states = np.asarray(observations["state"], dtype=np.int64).reshape(self.n_runs)
        probs = self.policy(states)
        u = np.zeros(self.n_runs)
        for i in np.flatnonzero(active):
            u[i] = self.rngs[i].random()
        return sample_actions(probs, u)

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Bayes update of the belief from the human's action (Eqs. 3-4)."""
        rows = np.arange(self.n_runs)
        likelihood = self.pi_h[rows, :, states, human_actions]  # (B, I)
        new = mdp.bayes_update(self.posterior, likelihood, self.config.beta)
        self.posterior = np.where(active[:, None], new, self.posterior)
        self.lifted |= active & rules.left_start(self.graph, next_states, self.start)

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Loop removal, one IRL step, then recompute π̂_H and the robot's Q."""
        intentions = np.asarray(intentions, dtype=np.int64).reshape(self.n_runs)
        self._update(traces, intentions)
        self.episodes += 1

    # ------------------------------------------------------------------ inspection
    def human_policy(self, state: int, intention: int) -> np.ndarray:
        """(B, A) π̂_H(a | state, ι)."""
        return self.pi_h[:, intention, state]

    def robot_policy(
        self, state: int, intention: int, *, bounded: bool = False, start: int | None = None
    ) -> np.ndarray:
        """(B, A) the robot's policy in ``state`` if it were sure of the intention.

        Args:
            state: The state.
            intention: The intention ι the belief is concentrated on.
            bounded: Return the bounded soft-max the robot samples from (default: the plain
                soft-max ``softmax(τ_R Q_ι)``, whose ratios the paper's Figs. 8, 11, 12 show).
            start: Start support for the bounded soft-max's passive baseline (default: the
                first support that is not ι).
        """
        if not bounded:
            return self.pi_r[:, intention, state]
        if start is None:
            start = next(k for k in range(self.graph.n_intentions) if k != intention)
        q = self.q_r[:, intention, state]
        baseline = task_mdp.passive_actions(self.graph, np.full(self.n_runs, start))[:, state]
        c = self.config
        valid = np.broadcast_to(self._valid[state], q.shape)
        return mdp.bounded_softmax(q, valid, c.robot_temperature, c.eta, baseline)

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the learner's state to ``path`` exactly (an ``.npz`` archive, no pickle).

        :meth:`load` reads it back from the same path (numpy's own ``savez`` would append
        ``.npz`` to a name without it).
        """
        meta = {"format": _FORMAT, "scenario": self.graph.name, "episodes": self.episodes,
                "fingerprint": graph_fingerprint(self.graph), "config": self.config.to_dict()}
        with open(path, "wb") as f:
            np.savez(f, meta=np.array(json.dumps(meta)), theta=self.theta, pi_h=self.pi_h,
                     q_r=self.q_r, pi_r=self.pi_r)

    @classmethod
    def load(cls, path: str | Path, graph: TaskGraph, *, seed: int = 0) -> Learner:
        """Restore a learner saved by :meth:`save` for the same scenario.

        The archive is read with bounded memory (:class:`~agents.archive.BoundedNpz`):
        its metadata and the arrays' headers are checked before any array is read, the
        arrays take at most :data:`MAX_STATE_BYTES`, and nothing is unpickled.

        Raises:
            LearnerStateError: The file is missing, truncated or damaged (any failure to
                read it), lacks an entry, is from another scenario or graph, or holds
                arrays (of a shape, of a dtype other than float64, such as complex, or of
                values: NaN, infinity, θ outside [-1, 1], a robot Q beyond what its
                rewards and γ allow, policies that are not policies), counts or parameters
                that no learner has; or its arrays would take more than
                :data:`MAX_STATE_BYTES` (a deflate bomb is refused before it is inflated).
        """
        try:
            with BoundedNpz(path, max_bytes=MAX_STATE_BYTES) as npz:
                missing = sorted({"meta", *_ARRAYS} - set(npz.headers))
                if missing:
                    raise LearnerStateError(f"{path}: missing entries {', '.join(missing)}; a "
                                            f"learner state has meta, {', '.join(_ARRAYS)}")
                head = npz.headers["meta"]
                if head.dtype.kind != "U" or head.shape != () or head.nbytes > MAX_META_BYTES:
                    raise LearnerStateError(f"{path}: its metadata is not a JSON object (a "
                                            f"string of at most {MAX_META_BYTES // 4:,} "
                                            f"characters); got shape {head.shape} of "
                                            f"{head.dtype}")
                meta = json.loads(str(npz.read("meta")))
                cls._check_meta(path, meta, graph)
                expected = cls._expected_shapes(graph, npz.headers["theta"].shape)
                for key in _ARRAYS:
                    head = npz.headers[key]
                    if head.dtype != np.float64:  # complex, float32, int, str: never a learner's
                        raise LearnerStateError(f"{path}: {key} holds {head.dtype} values; a "
                                                "learner state holds arrays of real numbers, "
                                                "float64")
                    if head.shape != expected[key]:
                        raise LearnerStateError(f"{path}: {key} has shape {head.shape}, "
                                                f"expected {expected[key]}")
                theta, pi_h, q_r, pi_r = npz.read_all(_ARRAYS)
        except LearnerStateError:
            raise
        except Exception as exc:  # zip, zlib, EOF, JSON, tokenizer, ... errors alike
            raise LearnerStateError(f"{path} is not a readable learner state "
                                    f"({type(exc).__name__}: {exc}); give a file written by "
                                    "Learner.save") from exc
        n_b = theta.shape[0]
        arrays = {"theta": theta, "pi_h": pi_h, "q_r": q_r, "pi_r": pi_r}
        for key, arr in arrays.items():
            if not np.all(np.isfinite(arr)):
                raise LearnerStateError(f"{path}: {key} contains NaN or infinity")
        if np.abs(theta).max(initial=0.0) > 1.0:
            raise LearnerStateError(
                f"{path}: theta holds {np.abs(theta).max():.6g} in absolute value; θ is kept "
                "in [-1, 1] (every IRL step rescales it to max |θ| = 1)")
        for key in ("pi_h", "pi_r"):
            p = arrays[key]
            if np.abs(p.sum(-1) - 1).max() > 1e-6 or np.any(p[..., ~graph.valid] > 0):
                raise LearnerStateError(f"{path}: {key} is not a policy over valid actions")
        try:
            config = LearnerConfig(**meta["config"])
        except (TypeError, ValueError, KeyError) as exc:
            raise LearnerStateError(f"{path}: invalid learner parameters: {exc!r}") from exc
        bound = np.abs(graph.reward(config.r0)).max() / (1.0 - config.gamma)
        if np.abs(q_r).max(initial=0.0) > bound * (1 + 1e-9) + 1e-9:
            raise LearnerStateError(
                f"{path}: q_r holds {np.abs(q_r).max():.6g} in absolute value; a robot Q "
                f"of these rewards and γ = {config.gamma:g} lies within ±{bound:.6g} "
                "(max |reward| / (1 - γ))")
        episodes = meta.get("episodes", 0)
        if type(episodes) is not int or episodes < 0:
            raise LearnerStateError(f"{path}: episode count {episodes!r}; it must be a whole "
                                    "number >= 0")
        # The saved model replaces the initial one: do not pretrain it again.
        learner = cls(graph, n_b, config.replace(initial_preference=None), seed=seed)
        learner.config = config
        learner.theta, learner.pi_h, learner.q_r, learner.pi_r = theta, pi_h, q_r, pi_r
        learner.episodes = episodes
        return learner

    @staticmethod
    def _check_meta(path: str | Path, meta: object, graph: TaskGraph) -> None:
        """The metadata is this format's, for ``graph``."""
        if not isinstance(meta, dict):
            raise LearnerStateError(f"{path}: its metadata is not a JSON object")
        if meta.get("format") != _FORMAT:
            raise LearnerStateError(f"{path}: unknown format {meta.get('format')!r}, "
                                    f"expected {_FORMAT!r}")
        same_graph = meta.get("fingerprint") == graph_fingerprint(graph)
        if meta.get("scenario") != graph.name or not same_graph:
            raise LearnerStateError(
                f"{path} holds a learner for scenario {meta.get('scenario')!r}; it cannot be "
                f"loaded for {graph.name!r} (or the task graph changed)"
            )

    @staticmethod
    def _expected_shapes(graph: TaskGraph, theta_shape: tuple[int, ...]
                         ) -> dict[str, tuple[int, ...]]:
        """The arrays' shapes for ``graph``, with B runs from θ's shape (B, F)."""
        n_b = theta_shape[0] if len(theta_shape) == 2 else -1
        shape_r = (n_b, graph.n_intentions, graph.n_states, graph.n_actions)
        return {"theta": (n_b, graph.n_features), "pi_h": shape_r, "q_r": shape_r,
                "pi_r": shape_r}
