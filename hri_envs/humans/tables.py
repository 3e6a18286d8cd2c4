"""Scripted humans in a seat: :class:`TableHumans`, the human protocol by table look-up.

A :class:`~hri_envs.humans.scripted.ScriptedHuman` is a model (a policy table, passivity,
turning back); :class:`TableHumans` seats such models for ``n_runs`` streams. Every row has
a sequence of models, one per episode (one throughout for a fixed human; a population's
draw, a drifting human who changes preference after some episodes); the rows' current
models are gathered into arrays, so that a step of every row is a handful of look-ups.

Draws: each active row takes two uniforms per step (passivity, then the choice of action,
by inverse CDF over the table), from its own generator (the benchmark) or, with one
generator shared by the rows (the envs), two (n_runs,) arrays per step for all rows.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman, Rows, all_rows
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.actions import WAIT

__all__ = ["TableHumans"]


class TableHumans(BatchHuman):
    """Scripted humans acting by their policy tables.

    Args:
        humans: One :class:`ScriptedHuman` shared by every row, or per row a non-empty
            sequence of models per episode (a sequence shorter than the episodes repeats
            its last model).
        n_runs: Rows, when ``humans`` is one model (default 1).

    Attributes:
        episode: (n_runs,) int, each row's episode count (-1 before the first), counted
            for rows that have a sequence of models.
    """

    def __init__(self, humans: ScriptedHuman | Sequence[Sequence[ScriptedHuman]],
                 n_runs: int = 1) -> None:
        if isinstance(humans, ScriptedHuman):
            self.shared: ScriptedHuman | None = humans
            self.per_run: list[list[ScriptedHuman]] | None = None
            super().__init__(humans.graph, n_runs)
            self.current = [humans] * self.n_runs
        else:
            per_run = [list(seq) for seq in humans]
            if not per_run or not all(per_run) or not all(
                    isinstance(h, ScriptedHuman) for seq in per_run for h in seq):
                raise ConfigError("give one ScriptedHuman, or per run a non-empty sequence of "
                                  "ScriptedHuman models", field="human")
            self.shared, self.per_run = None, per_run
            super().__init__(per_run[0][0].graph, len(per_run))
            self.current = [seq[0] for seq in per_run]
            self._gather()
        if self.shared is not None:
            self._turn_back = np.full(self.n_runs, self.shared.turn_back)
            self._turn_back.setflags(write=False)
        self.episode = np.full(self.n_runs, -1, dtype=np.int64)
        self.name = self.current[0].name  # type: ignore[misc]

    def _gather(self, rows: Rows = None) -> None:
        """Stack the current models of ``rows`` (None: all) into the arrays :meth:`act` reads."""
        g = self.graph
        k = np.arange(g.n_intentions)
        grid = np.arange(g.n_states)[None, None, :], k[:, None, None], k[None, :, None]
        if rows is None or not hasattr(self, "_greedy"):
            rows = np.arange(self.n_runs)
            n_k = g.n_intentions
            self._greedy = np.zeros((self.n_runs, n_k, n_k, g.n_states), dtype=np.int64)
            self._cum = np.zeros((self.n_runs, n_k, n_k, g.n_states, g.n_actions))
            self._stochastic = np.zeros(self.n_runs, dtype=bool)
            self._passive = np.zeros(self.n_runs)
            self._turn_back = np.zeros(self.n_runs)
            self._turn_states = np.zeros((self.n_runs, n_k, n_k), dtype=np.int64)
        for i in rows:
            h = self.current[i]
            self._greedy[i] = h.preferred_action(*grid)
            self._cum[i] = np.cumsum(h.policy, axis=-1)
            self._stochastic[i] = not h.deterministic
            self._passive[i] = h.passive
            self._turn_back[i] = h.turn_back
            self._turn_states[i] = h.turn_state

    def assign(self, rows: Rows, humans: Sequence[ScriptedHuman]) -> None:
        """Seat ``humans`` (one per row of ``rows``) from now on, throughout their episodes."""
        idx = all_rows(rows, self.n_runs)
        if len(humans) != len(idx):
            raise ConfigError(f"give one human per row ({len(idx)}), got {len(humans)}",
                              field="human")
        if self.per_run is None:
            self.per_run = [[h] for h in self.current]
            self.shared = None
        for i, human in zip(idx, humans, strict=True):
            self.per_run[i] = [human]
            self.current[i] = human
        self._gather(idx)
        self.name = self.current[0].name  # type: ignore[misc]

    # ----------------------------------------------------------------- episode rules
    @property
    def turn_state(self) -> np.ndarray:
        """(K, K) of the shared model, or (n_runs, K, K) of each row's current model."""
        return self.shared.turn_state if self.shared is not None else self._turn_states

    @property
    def turn_back(self) -> np.ndarray:
        """(n_runs,) each row's current model's turning-back probability (read-only)."""
        return self._turn_back

    def preferred_action(self, state: np.ndarray, start: np.ndarray, goal: np.ndarray
                         ) -> np.ndarray:
        """(n_runs,) each row's most likely action (for the Oracle, which copies it)."""
        if self.shared is not None:
            return self.shared.preferred_action(state, start, goal)
        state, start, goal = np.broadcast_arrays(state, start, goal)
        return self._greedy[np.arange(len(state)), start, goal, state]

    # ----------------------------------------------------------------- protocol
    def begin_episode(self, starts: np.ndarray, intentions: np.ndarray, rows: Rows = None
                      ) -> None:
        """Count the rows' episodes; a row whose sequence moves on changes model."""
        if self.per_run is None:  # one model throughout: nothing to count
            return
        idx = all_rows(rows, self.n_runs)
        self.episode[idx] += 1
        changed = []
        for i in idx:
            seq = self.per_run[i]
            human = seq[min(int(self.episode[i]), len(seq) - 1)]
            if human is not self.current[i]:
                self.current[i] = human
                changed.append(i)
        if changed:
            self._gather(np.array(changed))

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The table's actions (the robot's action does not matter to a scripted human)."""
        state = observations["state"]
        start, intention = observations["start"], observations["intention"]
        if self.rngs is None:
            u_passive, u_choice = self.rng.random((2, *np.shape(state)))
        else:
            u = np.zeros((2, len(state)))
            for i in np.flatnonzero(active):
                u[:, i] = self.rngs[i].random(2)
            u_passive, u_choice = u
        if self.shared is not None:
            return self.shared.act_from_uniforms(state, start, intention, u_passive, u_choice)
        rows = np.arange(len(state))
        actions = self._greedy[rows, start, intention, state]
        if self._stochastic.any():
            cum = self._cum[rows, start, intention, state]  # (B, A)
            sampled = np.minimum((u_choice[:, None] >= cum).sum(axis=-1), cum.shape[-1] - 1)
            actions = np.where(self._stochastic, sampled, actions)
        return np.where(u_passive < self._passive, WAIT, actions)
