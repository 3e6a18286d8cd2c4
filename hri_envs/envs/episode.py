"""Episode semantics shared by every environment (SPEC §2), as lookup tables.

The rules of an episode are written down once, as arrays over the task graph, in
:class:`EpisodeRules`; the single-episode envs (:class:`Episode`) and the batched vector env
only look them up, with Python scalars or with ``np.take`` over N episodes.

* Reset: the object rests on the start support k with μ = 0; the intention ι ≠ k.
* Step: ``s' = next_state[s, a_R, a_H]``, robot reward ``R_R(s, a_R, a_H)``. The object is
  *lifted* once it has been in free space.
* The episode terminates when ``s'`` rests on a support with μ = 0 and that support is not
  the start, or the object was lifted (the human turned back).
* Turning back: in an episode where the human turns back, on entering the state
  ``turn_state[start, ι]`` (so before the human acts there) ι becomes the start support.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hri_envs.task.graph import WAIT, TaskGraph

__all__ = [
    "Episode",
    "EpisodeRules",
    "Transition",
    "draw_other_support",
    "draw_start_intention",
]


class EpisodeRules:
    """The episode's dynamics, rewards and end condition as flat lookup tables.

    Args:
        graph: The task graph.
        r0: Robot reward for waiting while the human acts, in (-1, 0).

    Attributes:
        next_state: (S A A,) int64, ``next_state[(s A + a_R) A + a_H]``.
        reward: (S A A,) float64, the robot cooperation reward R_R.
        aborted: (S A A,) bool, the joint action was aborted.
        valid: (S A,) bool, ``valid[s A + a]``: the action is allowed in the state.
        action_mask: (S, A) int8, read-only rows of the observations' ``action_mask``.
        lifts: (S,) bool, the object is in free space (it has left its support).
        ends: (S K 2,) bool, ``ends[(s K + start) 2 + lifted]``: the episode terminates.
    """

    def __init__(self, graph: TaskGraph, r0: float) -> None:
        self.graph = graph
        self.r0 = r0
        n_s, n_a, n_k = graph.n_states, graph.n_actions, graph.n_intentions
        self.n_states, self.n_actions, self.n_supports = n_s, n_a, n_k
        self.next_state = graph.next_state.astype(np.int64).reshape(-1)
        self.reward = graph.reward(r0).astype(np.float64).reshape(-1)
        self.aborted = graph.aborted.reshape(-1).copy()
        self.valid = graph.valid.reshape(-1).copy()
        self.action_mask = graph.valid.astype(np.int8)
        self.lifts = ~graph.is_support_state
        ends = graph.episode_over(np.arange(n_s)[:, None, None], np.arange(n_k)[None, :, None],
                                  np.array([False, True])[None, None, :])  # (S, K, 2)
        self.ends = np.ascontiguousarray(ends).reshape(-1)  # (S K 2,)
        for table in (self.next_state, self.reward, self.aborted, self.valid,
                      self.action_mask, self.lifts, self.ends):
            table.setflags(write=False)
        # Python-list mirrors for the scalar path (list indexing beats numpy scalars).
        self.next_list: list[int] = self.next_state.tolist()
        self.reward_list: list[float] = self.reward.tolist()
        self.aborted_list: list[bool] = self.aborted.tolist()
        self.valid_list: list[bool] = self.valid.tolist()
        self.lifts_list: list[bool] = self.lifts.tolist()
        self.ends_list: list[bool] = self.ends.tolist()


def draw_start_intention(
    rng: np.random.Generator, n_supports: int, size: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Draw start supports and intentions ι ≠ start, uniformly (scalars when size is None)."""
    start = rng.integers(n_supports, size=size)
    intention = (start + 1 + rng.integers(n_supports - 1, size=size)) % n_supports
    return start, intention


def draw_other_support(rng: np.random.Generator, n_supports: int, other: int) -> int:
    """Draw a support uniformly among those different from ``other``."""
    return int((other + 1 + rng.integers(n_supports - 1)) % n_supports)


class Transition(NamedTuple):
    """The outcome of one joint step of an :class:`Episode`."""

    reward: float
    aborted: bool
    terminated: bool
    robot_invalid: bool
    human_invalid: bool


class Episode:
    """One running episode with scalar state, for the single-episode envs.

    Args:
        rules: The scenario's :class:`EpisodeRules`.
        turn_state: (K, K) int, where a turning-back human switches ι to the start support
            (-1 = never), see :attr:`hri_envs.task.humans.ScriptedHuman.turn_state`; None
            for a human who never turns back.
    """

    __slots__ = ("_turn", "intention", "last_human", "last_robot", "lifted", "previous",
                 "rules", "start", "state", "steps", "turn_back")

    def __init__(self, rules: EpisodeRules, turn_state: np.ndarray | None) -> None:
        self.rules = rules
        if turn_state is None:
            turn_state = np.full((rules.n_supports,) * 2, -1)
        self._turn: list[list[int]] = np.asarray(turn_state, dtype=np.int64).tolist()
        self.begin(0, 1 % rules.n_supports, False)

    def begin(self, start: int, intention: int, turn_back: bool) -> None:
        """Start a new episode on support ``start`` with μ = 0."""
        self.start, self.intention, self.turn_back = start, intention, turn_back
        self.state = self.previous = self.rules.graph.support_state(start, 0)
        self.lifted = False
        self.steps = 0
        self.last_human = self.last_robot = WAIT

    def draw(
        self,
        rng: np.random.Generator,
        start: int | None = None,
        intention: int | None = None,
        turn_back: bool | None = None,
        turn_back_p: float = 0.0,
    ) -> None:
        """Start a new episode, drawing what is not given from ``rng``.

        Args:
            rng: The env's generator.
            start: The start support (default: uniform).
            intention: ι (default: uniform among the supports other than the start).
            turn_back: Whether the human turns back (default: drawn with ``turn_back_p``).
            turn_back_p: Probability of turning back when ``turn_back`` is None.
        """
        n_k = self.rules.n_supports
        if start is None:
            if intention is None:
                s, i = draw_start_intention(rng, n_k)
                start, intention = int(s), int(i)
            else:
                start = draw_other_support(rng, n_k, intention)
        elif intention is None:
            intention = draw_other_support(rng, n_k, start)
        if turn_back is None:
            turn_back = bool(turn_back_p > 0.0 and rng.random() < turn_back_p)
        self.begin(start, intention, turn_back)

    def advance(self, a_r: int, a_h: int) -> Transition:
        """Apply the joint action (already checked to lie in the action space)."""
        r = self.rules
        n_a = r.n_actions
        s = self.state
        i = (s * n_a + a_r) * n_a + a_h
        s_next = r.next_list[i]
        return Transition(r.reward_list[i], r.aborted_list[i],
                          *self._commit(s_next, a_r, a_h))

    def _commit(self, s_next: int, a_r: int, a_h: int) -> tuple[bool, bool, bool]:
        """Move to ``s_next`` after the joint action; the bookkeeping every backend shares.

        Returns ``(terminated, robot action invalid, human action invalid)``.
        """
        r = self.rules
        s, n_a = self.state, r.n_actions
        self.previous, self.state = s, s_next
        self.lifted = lifted = self.lifted or r.lifts_list[s_next]
        self.steps += 1
        self.last_human, self.last_robot = a_h, a_r
        if self.turn_back and s_next == self._turn[self.start][self.intention]:
            self.intention, self.turn_back = self.start, False
        return (r.ends_list[(s_next * r.n_supports + self.start) * 2 + lifted],
                not r.valid_list[s * n_a + a_r], not r.valid_list[s * n_a + a_h])
