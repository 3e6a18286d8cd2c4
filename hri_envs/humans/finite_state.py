"""Humans with a finite internal state: the model behind every family beyond the scripted one.

A :class:`FiniteStateHuman` is a scripted human with a memory: an internal state ``z`` out
of ``Z`` (a count of the robot's waits, a trust level, the route it currently follows, the
number of times it changed its mind) that it carries across steps and episodes. Per step,
with the episode's start support and the human's current intention ι:

1. the human's action is drawn from ``law[z, start, ι, s, r]``, where ``r`` is the robot's
   action of the same step where the seat knows it (the last slot, ``A``, otherwise) and
   0 for a human whose law ignores the robot (``law.shape[4] == 1``);
2. the object moves by the joint transition; the state becomes
   ``next_z[z, start, ι, s, a_R, a_H]``;
3. with probability ``switch[z, s']`` the human changes its mind: ι becomes one of the other
   supports, uniformly, and ``z`` becomes ``switched[z]`` (an inconsistent human); the seat
   learns the new ι from :meth:`FiniteStateHumans.revised_intentions`;
4. when the episode ends, the next episode starts in ``z' ~ carry[z]``; the first episode of
   a run starts in ``z0``.

Everything is a table, so the exact references plan on the product of the task's and the
human's states (:mod:`baselines.product`), and a batch of rows acts with a few look-ups.
A deterministic :class:`~hri_envs.humans.scripted.ScriptedHuman` without turning back is
the case ``Z = 1`` (:meth:`FiniteStateHuman.from_scripted`).

Draws: each active row takes three uniforms per step (the action, whether it changes its
mind, the new intention) and one at the end of each episode (the next ``z``), from its own
generator (the benchmark, ``(seed, run, 1)``) or, with one generator shared by the rows
(the envs), as (3, n_runs) and (rows,) arrays.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman, Rows, all_rows
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph

__all__ = [
    "FiniteStateHuman",
    "FiniteStateHumans",
    "as_model",
    "carry_to",
    "keep_z",
    "one_hot",
]

def one_hot(table: np.ndarray, n_actions: int) -> np.ndarray:
    """(..., A) a deterministic law from an int action ``table`` (...,)."""
    out = np.zeros((*table.shape, n_actions))
    np.put_along_axis(out, np.asarray(table, dtype=np.int64)[..., None], 1.0, axis=-1)
    return out


def keep_z(graph: TaskGraph, n_z: int) -> np.ndarray:
    """(Z, K, K, S, A, A) the ``next_z`` of a human whose state no step changes."""
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    z = np.arange(n_z, dtype=np.int16)[:, None, None, None, None, None]
    return np.broadcast_to(z, (n_z, n_k, n_k, n_s, n_a, n_a)).copy()


def carry_to(z_next: np.ndarray | Sequence[int], n_z: int) -> np.ndarray:
    """(Z, Z) the deterministic carry ``z -> z_next[z]`` (e.g. ``[0] * Z``: forget)."""
    out = np.zeros((n_z, n_z))
    out[np.arange(n_z), np.asarray(z_next, dtype=np.int64)] = 1.0
    return out


@dataclass(frozen=True, eq=False)
class FiniteStateHuman:
    """A human with an internal state ``z`` in ``0 .. Z-1`` (see the module docstring).

    Shapes: Z human states, K supports, S task states, A actions; R = 1 (the law ignores
    the robot's action) or A + 1 (one slot per robot action and a last one for "unknown").

    Attributes:
        graph: The task graph.
        name: A readable label (family and parameters).
        law: (Z, K, K, S, R, A) ``P(a_H | z, start, ι, s, a_R)``; zero on invalid actions.
        next_z: (Z, K, K, S, A, A) int, ``z`` after the step ``(s, a_R, a_H)``.
        carry: (Z, Z) ``P(z at the next episode's start | z at this episode's end)``.
        z0: The state of the run's first episode.
        switch: (Z, S) probability of a change of mind after a step into ``s'`` (per ``z``
            after :attr:`next_z`), or None: never.
        switched: (Z,) int, ``z`` after a change of mind (needed with :attr:`switch`).
        family: The family's name (:mod:`hri_envs.humans.families`), "" for none.
        params: The family's parameters as (name, value) pairs.
    """

    graph: TaskGraph
    name: str
    law: np.ndarray
    next_z: np.ndarray
    carry: np.ndarray
    z0: int = 0
    switch: np.ndarray | None = None
    switched: np.ndarray | None = None
    family: str = ""
    params: tuple[tuple[str, Any], ...] = ()
    _cum: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        g = self.graph
        n_k, n_s, n_a = g.n_intentions, g.n_states, g.n_actions
        law = np.asarray(self.law, dtype=float)
        if law.ndim != 6 or law.shape[1:4] != (n_k, n_k, n_s) or law.shape[5] != n_a \
                or law.shape[4] not in (1, n_a + 1):
            raise ConfigError(f"law must have shape (Z, {n_k}, {n_k}, {n_s}, 1 or {n_a + 1}, "
                              f"{n_a}), got {law.shape}", field="law")
        n_z = law.shape[0]
        if np.any(law < 0) or not np.allclose(law.sum(-1), 1.0):
            raise ConfigError("law must hold probabilities that sum to 1 over the human's "
                              "actions", field="law")
        invalid = ~g.valid.astype(bool)[None, None, None, :, None, :]
        if np.any(np.where(invalid, law, 0.0) > 0):
            raise ConfigError("law puts probability on actions that are invalid in the state; "
                              "only the graph's valid actions are allowed", field="law")
        nz = np.asarray(self.next_z)
        if nz.shape != (n_z, n_k, n_k, n_s, n_a, n_a) or nz.dtype.kind not in "iu" \
                or nz.min() < 0 or nz.max() >= n_z:
            raise ConfigError(f"next_z must be ints in [0, {n_z}) of shape "
                              f"{(n_z, n_k, n_k, n_s, n_a, n_a)}, got {nz.dtype} {nz.shape}",
                              field="next_z")
        carry = np.asarray(self.carry, dtype=float)
        if carry.shape != (n_z, n_z) or np.any(carry < 0) or not np.allclose(carry.sum(1), 1):
            raise ConfigError(f"carry must be a ({n_z}, {n_z}) matrix of probabilities whose "
                              "rows sum to 1", field="carry")
        if not 0 <= int(self.z0) < n_z:
            raise ConfigError(f"z0 must be a state in [0, {n_z}), got {self.z0}", field="z0")
        if self.switch is not None:
            sw = np.asarray(self.switch, dtype=float)
            to = np.asarray(self.switched)
            if sw.shape != (n_z, n_s) or np.any(sw < 0) or np.any(sw > 1) \
                    or np.any(sw[:, g.is_support_state] > 0):
                raise ConfigError(f"switch must be ({n_z}, {n_s}) probabilities, 0 at the "
                                  f"support states (a human changes its mind in free space), "
                                  f"got {sw.shape}", field="switch")
            if to.shape != (n_z,) or to.min() < 0 or to.max() >= n_z:
                raise ConfigError(f"switched must be ({n_z},) states in [0, {n_z})",
                                  field="switched")
            object.__setattr__(self, "switch", sw)
            object.__setattr__(self, "switched", to.astype(np.int64))
        object.__setattr__(self, "law", law)
        object.__setattr__(self, "next_z", nz.astype(np.int16 if n_z < 2**15 else np.int64))
        object.__setattr__(self, "carry", carry)
        object.__setattr__(self, "_cum", np.cumsum(law, axis=-1))
        for a in (self.law, self.next_z, self.carry, self._cum):
            a.setflags(write=False)

    # ----------------------------------------------------------------- sizes and kinds
    @property
    def n_z(self) -> int:
        """Z, the number of internal states."""
        return int(self.law.shape[0])

    @property
    def reacts(self) -> bool:
        """Whether the law depends on the robot's action of the same step."""
        return self.law.shape[4] > 1

    @cached_property
    def remembers(self) -> bool:
        """Whether ``z`` carries information across episodes (the carry depends on ``z``)."""
        return bool(np.any(self.carry != self.carry[:1]))

    @cached_property
    def fingerprint(self) -> str:
        """A hash of every table (plans are cached by it)."""
        digest = hashlib.sha1()
        for a in (self.law, self.next_z.astype(np.int64), self.carry,
                  np.zeros(0) if self.switch is None else self.switch,
                  np.zeros(0, np.int64) if self.switched is None else self.switched):
            digest.update(np.ascontiguousarray(a).tobytes())
            digest.update(str(a.shape).encode())
        digest.update(f"{self.graph.name}|{self.graph.n_states}|{int(self.z0)}".encode())
        return digest.hexdigest()

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_scripted(cls, human: ScriptedHuman) -> FiniteStateHuman:
        """The scripted human as a one-state human (its passivity folded into the law).

        Raises:
            ConfigError: The human turns back (an episode rule the seat applies to scripted
                humans; a finite-state human changes its mind itself).
        """
        if human.turn_back > 0:
            raise ConfigError(f"{human.name!r} turns back halfway (turn_back "
                              f"{human.turn_back:g}); a finite-state human does not: give "
                              "turn_back 0", field="turn_back")
        g = human.graph
        law = (1.0 - human.passive) * human.policy
        law[..., WAIT] += human.passive
        n_k, n_s, n_a = g.n_intentions, g.n_states, g.n_actions
        return cls(g, human.name, law[None, :, :, :, None, :],
                   np.zeros((1, n_k, n_k, n_s, n_a, n_a), dtype=np.int16), np.ones((1, 1)),
                   family="scripted", params=(("name", human.name),))


_CONVERTED: dict[int, tuple[ScriptedHuman, FiniteStateHuman]] = {}


def as_model(human: FiniteStateHuman | ScriptedHuman) -> FiniteStateHuman:
    """``human`` as a finite-state model; a scripted human is converted once
    (:meth:`FiniteStateHuman.from_scripted`) and the conversion kept while it lives.
    """
    if isinstance(human, FiniteStateHuman):
        return human
    if isinstance(human, ScriptedHuman):
        hit = _CONVERTED.get(id(human))
        if hit is None or hit[0] is not human:
            if len(_CONVERTED) > 1024:
                _CONVERTED.clear()
            hit = _CONVERTED[id(human)] = (human, FiniteStateHuman.from_scripted(human))
        return hit[1]
    raise ConfigError(f"a finite-state seat takes FiniteStateHuman or ScriptedHuman models, "
                      f"got {human!r}", field="human")


class _Stack:
    """The models of a seat as flat tables, so that one look-up serves every row.

    Model ``m``'s arrays sit at offsets in shared flat arrays: its law's CDF (``cum``), its
    ``next_z``, its changes of mind (``switch``, ``switched``, zeros when it has none) and
    its carry's CDF padded to the largest Z (``carry``: (M, Z_max, Z_max)).
    """

    def __init__(self, graph: TaskGraph) -> None:
        self.graph = graph
        self.models: list[FiniteStateHuman] = []
        self._index: dict[int, int] = {}
        self._stale = True

    def add(self, model: FiniteStateHuman) -> int:
        """The model's index, stacking it first if it is new."""
        i = self._index.get(id(model))
        if i is not None and self.models[i] is model:
            return i
        self.models.append(model)
        i = self._index[id(model)] = len(self.models) - 1
        self._stale = True
        return i

    def ready(self) -> _Stack:
        """The stack with every model added so far in its tables."""
        if self._stale:
            self._build()
            self._stale = False
        return self

    def _build(self) -> None:
        g = self.graph
        n_s = g.n_states
        ms = self.models
        self.n_z = np.array([m.n_z for m in ms], dtype=np.int64)
        self.n_robot = np.array([m.law.shape[4] for m in ms], dtype=np.int64)
        self.cum, self.cum_off = _flat([np.ascontiguousarray(m._cum) for m in ms])
        self.next_z, self.next_off = _flat([np.ascontiguousarray(m.next_z) for m in ms])
        self.switch, self.switch_off = _flat([np.zeros((m.n_z, n_s)) if m.switch is None
                                              else m.switch for m in ms])
        self.switched, self.switched_off = _flat([np.arange(m.n_z) if m.switched is None
                                                  else m.switched for m in ms])
        z_max = int(self.n_z.max())
        carry = np.ones((len(ms), z_max, z_max))
        for j, m in enumerate(ms):
            carry[j, :m.n_z, :m.n_z] = np.cumsum(m.carry, axis=1)
        self.carry = carry
        self.any_switch = any(m.switch is not None for m in ms)


def _flat(arrays: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The arrays raveled into one, and the offset of each."""
    sizes = np.array([a.size for a in arrays], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    return np.concatenate([a.ravel() for a in arrays]), offsets


#: Uniforms drawn at once from a row's own generator (a row consumes them in order, so the
#: numbers do not depend on the block).
_BLOCK = 96


class FiniteStateHumans(BatchHuman):
    """Finite-state humans in a seat: one model per row, each with its own state ``z``.

    Args:
        humans: One model shared by every row, or one per row (a population's members;
            :class:`~hri_envs.humans.scripted.ScriptedHuman` models without turning back
            are converted with :meth:`FiniteStateHuman.from_scripted`).
        n_runs: Rows, when ``humans`` is one model (default 1).

    Attributes:
        models: Each row's current model.
        z: (n_runs,) int, each row's internal state (of the episode under way, or of the
            next one between episodes).

    Every row's step is a handful of look-ups into the models' tables stacked flat
    (:class:`_Stack`), whatever the number of distinct models. With one generator per row
    (the benchmark) each row reads its uniforms, in order, from blocks its generator draws.
    """

    def __init__(self, humans: FiniteStateHuman | ScriptedHuman
                 | Sequence[FiniteStateHuman | ScriptedHuman], n_runs: int = 1) -> None:
        if isinstance(humans, FiniteStateHuman | ScriptedHuman):
            model = as_model(humans)
            super().__init__(model.graph, n_runs)
            models = [model] * self.n_runs
        else:
            models = [as_model(h) for h in humans]
            if not models:
                raise ConfigError("give one model, or one per row", field="human")
            super().__init__(models[0].graph, len(models))
        self._stack = _Stack(self.graph)
        self.models: list[FiniteStateHuman] = list(models)
        self.model_id = np.zeros(self.n_runs, dtype=np.int64)
        self.z = np.zeros(self.n_runs, dtype=np.int64)
        # What act() saw, for the observe() of the same step: ι, and the flat index of
        # (z, start, ι, s) (:meth:`_context`).
        self._intention = np.zeros(self.n_runs, dtype=np.int64)
        self._ctx = np.zeros(self.n_runs, dtype=np.int64)
        self._u = np.zeros((3, self.n_runs))
        self._revised: np.ndarray | None = None
        self._buffer: np.ndarray | None = None
        self._pos = np.zeros(self.n_runs, dtype=np.int64)
        self.assign(None, models)

    # ----------------------------------------------------------------- models
    def assign(self, rows: Rows, humans: Sequence[FiniteStateHuman | ScriptedHuman]) -> None:
        """Seat ``humans`` in ``rows`` (one each), starting from their ``z0``."""
        idx = all_rows(rows, self.n_runs)
        models = [as_model(h) for h in humans]
        if len(models) != len(idx):
            raise ConfigError(f"give one human per row ({len(idx)}), got {len(models)}",
                              field="human")
        for i, m in zip(idx, models, strict=True):
            if m.graph.name != self.graph.name or m.graph.n_states != self.graph.n_states:
                raise ConfigError(f"the human {m.name!r} was built for the {m.graph.name}, "
                                  f"not the {self.graph.name}", field="human")
            self.models[i] = m
            self.model_id[i] = self._stack.add(m)
            self.z[i] = m.z0
        self.name = self.models[0].name  # type: ignore[misc]

    def model_of(self, row: int) -> FiniteStateHuman:
        """Row ``row``'s current model."""
        return self.models[row]

    # ----------------------------------------------------------------- randomness
    def seed(self, rng: np.random.Generator | Sequence[np.random.Generator]) -> None:
        """Draw from ``rng`` (one generator, or one per row; see :meth:`BatchHuman.seed`)."""
        super().seed(rng)
        self._buffer = None
        self._pos[:] = 0

    def _uniforms(self, count: int, active: np.ndarray) -> np.ndarray:
        """(count, n_runs) uniforms; rows with their own generator read theirs in order."""
        if self.rngs is None:
            return self.rng.random((count, self.n_runs))
        if self._buffer is None:
            self._buffer = np.zeros((self.n_runs, _BLOCK))
            self._pos[:] = _BLOCK
        rows = np.flatnonzero(active)
        for i in rows[self._pos[rows] + count > _BLOCK]:
            left = self._buffer[i, self._pos[i]:].copy()
            self._buffer[i, :len(left)] = left
            self._buffer[i, len(left):] = self.rngs[i].random(_BLOCK - len(left))
            self._pos[i] = 0
        u = np.zeros((count, self.n_runs))
        u[:, rows] = self._buffer[rows[None, :], self._pos[rows][None, :]
                                  + np.arange(count)[:, None]]
        self._pos[rows] += count
        return u

    # ----------------------------------------------------------------- protocol
    def _context(self, state: np.ndarray, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """(n_runs,) the flat index of ``(z, start, ι, s)`` within each row's model."""
        k, n_s = self.graph.n_intentions, self.graph.n_states
        return ((self.z * k + start) * k + goal) * n_s + state

    def _law_cdf(self, st: _Stack, context: np.ndarray, robot: Any) -> np.ndarray:
        """(n_runs, A) each row's law's CDF in ``context`` for the robot's action ``robot``
        ((n_runs,), or None: unknown, the last slot).
        """
        n_a = self.graph.n_actions
        m = self.model_id
        n_r = st.n_robot[m]
        slot = np.where(n_r == 1, 0, n_a if robot is None else np.asarray(robot))
        base = st.cum_off[m] + (context * n_r + slot) * n_a
        return st.cum[base[:, None] + np.arange(n_a)]

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """(n_runs,) actions drawn from each row's law (three uniforms per active row)."""
        st = self._stack.ready()
        n_a = self.graph.n_actions
        state = np.asarray(observations["state"], dtype=np.int64)
        start = np.asarray(observations["start"], dtype=np.int64)
        goal = np.asarray(observations["intention"], dtype=np.int64)
        self._intention = goal.copy()
        self._ctx = self._context(state, start, goal)
        self._u = u = self._uniforms(3, active)
        cum = self._law_cdf(st, self._ctx, observations.get("robot_action"))  # (B, A)
        return np.minimum((u[0, :, None] >= cum).sum(-1), n_a - 1)

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Advance each active row's ``z``; draw the changes of mind (see the module).

        ``states`` are those :meth:`act` saw in this step (the protocol's order), so the
        context it computed is reused.
        """
        st = self._stack.ready()
        n_a, n_k, n_s = self.graph.n_actions, self.graph.n_intentions, self.graph.n_states
        a_r, a_h, s2 = (np.asarray(x, dtype=np.int64) for x in (
            robot_actions, human_actions, next_states))
        m = self.model_id
        j = st.next_off[m] + (self._ctx * n_a + a_r) * n_a + a_h
        z = np.where(active, st.next_z[j], self.z)
        self._revised = None
        if st.any_switch:
            p = st.switch[st.switch_off[m] + z * n_s + s2]
            turns = active & (self._u[1] < p)
            if turns.any():
                pick = np.minimum((self._u[2] * (n_k - 1)).astype(np.int64), n_k - 2)
                revised = np.where(turns, (self._intention + 1 + pick) % n_k, -1)
                z = np.where(turns, st.switched[st.switched_off[m] + z], z)
                self._revised = revised
        self.z = z.astype(np.int64)

    def revised_intentions(self) -> np.ndarray | None:
        """The rows' changes of mind in the last step (-1: none), None when no row changed."""
        return self._revised

    def end_episode(self, rows: Rows = None) -> None:
        """Draw each row's ``z`` for its next episode from the carry (one uniform per row)."""
        idx = all_rows(rows, self.n_runs)
        mask = np.zeros(self.n_runs, dtype=bool)
        mask[idx] = True
        u = self._uniforms(1, mask)[0]
        cum = self._stack.ready().carry[self.model_id[idx], self.z[idx]]  # (R, Z_max)
        self.z[idx] = (u[idx, None] >= cum).sum(-1)
        self._revised = None

    # ----------------------------------------------------------------- for the references
    def preferred_action(self, state: np.ndarray, start: np.ndarray, goal: np.ndarray
                         ) -> np.ndarray:
        """(n_runs,) each row's most likely action other than waiting where it would act at all
        (the robot's action unknown), for the Oracle: a passive human's action is what it
        does when it acts, as for :class:`~hri_envs.humans.tables.TableHumans`.
        """
        state, start, goal = (np.broadcast_to(np.asarray(x, dtype=np.int64), (self.n_runs,))
                              for x in (state, start, goal))
        cum = self._law_cdf(self._stack.ready(), self._context(state, start, goal), None)
        pdf = np.diff(cum, axis=1, prepend=0.0)  # (B, A)
        moves = pdf[:, WAIT + 1:].sum(1) > 0  # a passive human's action is its motion
        pdf[:, WAIT] = np.where(moves, -1.0, pdf[:, WAIT])
        return np.argmax(pdf, axis=1)
