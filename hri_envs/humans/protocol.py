"""The human protocol: how a human partner plugs into the envs, the benchmark and ``play``.

The human is an agent like the robot (:mod:`agents.protocol`), seen from the other seat. It
knows its intention ι, acts on an observation that includes it, sees what the robot did, and
may keep state across steps and episodes (a human who learns from the robot, a person, a
model fitted to recordings). Per episode:

1. ``draw(rng, rows)`` — before an episode's start, intention and turning back are drawn:
   a human drawn anew per episode (a population member) is chosen here. Most humans do
   nothing;
2. ``begin_episode(starts, intentions, rows)`` — new episodes start in ``rows``;
3. ``act(observations, active)`` — the human's actions: ``observations`` has ``state``,
   ``start``, ``intention`` (ι, after turning back), ``last_human_action`` and
   ``action_mask``, and ``robot_action`` (the robot's action in this very step) where the
   seat knows it before the human acts (the benchmark, the robot envs, ``play``);
4. ``observe(states, robot_actions, human_actions, next_states, active)`` — one joint step;
   after it the seat asks ``revised_intentions()`` whether a human changed its mind (an
   inconsistent human), and applies the new ι (:func:`hri_envs.task.episode.revise_intention`);
5. ``end_episode(rows)`` — the episodes in ``rows`` ended.

Randomness is the seat's to give, so that seeds reproduce: ``seed(rng)`` hands the human
one generator shared by its rows (the envs, at every reset, from their ``np_random``) or
one generator per row (the benchmark: ``(seed, run, 1)``). Turning back halfway is an
episode rule (:func:`hri_envs.task.episode.turn_back`) that the seat applies where the
human says: :attr:`BatchHuman.turn_state` and :attr:`BatchHuman.turn_back`. Any other
change of intention is the human's own: it reports the new ι after a step
(:meth:`BatchHuman.revised_intentions`, :meth:`Human.revised_intention`), the seat applies it,
and from the next step on the seat's ι (the human's observation, a privileged robot's, the
reward's ``reached_intention``) is the new one. Humans that never change their mind report
nothing (the default), so the seats behave exactly as before.

Two flavours share these names, as for the robot: :class:`Human` handles one stream of
episodes with plain ints and is what a user writes; :class:`BatchHuman` advances
``n_runs`` streams at once with arrays and is what the seats drive; :class:`BatchedHumans`
turns a list of :class:`Human` into one. The scripted humans' lookup tables
(:class:`~hri_envs.humans.tables.TableHumans`) are one fast implementation.

A human who copies the robot's last motion when it can::

    class Copycat(Human):
        def begin_episode(self, start, intention):
            self.last = 0

        def act(self, observation):
            a = self.last
            return a if observation["action_mask"][a] else 0  # 0 = wait

        def observe(self, state, robot_action, human_action, next_state):
            self.last = robot_action

Run it in a study with ``hri-bench study hanger --population mymodule:Copycat``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from hri_envs.checks import integer_action, integer_or_none
from hri_envs.errors import ActionError, ConfigError
from hri_envs.task.graph import TaskGraph

__all__ = ["BatchHuman", "BatchedHumans", "Human", "Rows", "all_rows", "checked_actions"]

#: Which runs a call concerns: an int index array, or None for all of them.
Rows = np.ndarray | None


def all_rows(rows: Rows, n_runs: int) -> np.ndarray:
    """``rows`` as an int index array (None: ``0 .. n_runs - 1``)."""
    return np.arange(n_runs) if rows is None else np.asarray(rows, dtype=np.int64)


class Human(ABC):
    """A human partner for one stream of episodes (see the module docstring).

    Attributes:
        rng: The generator to draw from; the seat sets it (:meth:`seed`) before episodes
            start, so a subclass draws from ``self.rng`` and seeds reproduce.
    """

    name: ClassVar[str] = "human"
    rng: np.random.Generator = np.random.default_rng(0)

    def seed(self, rng: np.random.Generator) -> None:
        """Draw from ``rng`` from now on."""
        self.rng = rng

    def begin_episode(self, start: int, intention: int) -> None:
        """A new episode starts on support ``start``; the human means to reach ``intention``."""

    @abstractmethod
    def act(self, observation: Mapping[str, Any]) -> int:
        """The human's action (keys ``state``, ``start``, ``intention``,
        ``last_human_action``, ``action_mask`` and, where the seat knows it,
        ``robot_action``).
        """

    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        """One joint step of the current episode."""

    def revised_intention(self) -> int | None:
        """The intention the human holds after the last :meth:`observe` if it changed its mind
        in that step, else None (the default: ι changes only by the seat's turning back).
        """
        return None

    def end_episode(self) -> None:
        """The episode ended."""


def _revises(human: Human) -> bool:
    """Whether ``human`` may report a change of mind: its :meth:`Human.revised_intention` is
    not the default (overridden by its class, or set on the instance).
    """
    method = getattr(human, "revised_intention", None)
    return getattr(method, "__func__", None) is not Human.revised_intention


class BatchHuman(ABC):
    """A human partner advancing ``n_runs`` independent streams of episodes in lockstep.

    Every method takes arrays with a leading run axis; ``active`` (bool, (n_runs,)) marks
    the runs whose episode is still going, and only those may consume randomness.

    Args:
        graph: The task graph the human acts on.
        n_runs: Streams advanced together (the benchmark's runs, the vector env's envs).

    Attributes:
        rng: The generator shared by all rows (after ``seed(generator)``).
        rngs: One generator per row (after ``seed([...])``), else None.
    """

    name: ClassVar[str] = "human"

    def __init__(self, graph: TaskGraph, n_runs: int = 1) -> None:
        if isinstance(n_runs, bool) or not isinstance(n_runs, int | np.integer) or n_runs < 1:
            raise ConfigError(f"n_runs must be a whole number >= 1, got {n_runs!r}",
                              field="n_runs")
        self.graph = graph
        self.n_runs = int(n_runs)
        self.rng = np.random.default_rng(0)
        self.rngs: list[np.random.Generator] | None = None

    # ----------------------------------------------------------------- randomness
    def seed(self, rng: np.random.Generator | Sequence[np.random.Generator]) -> None:
        """Draw from ``rng``: one generator for every row, or a sequence of one per row."""
        if isinstance(rng, np.random.Generator):
            self.rng, self.rngs = rng, None
            return
        rngs = list(rng)
        if len(rngs) != self.n_runs or not all(isinstance(r, np.random.Generator)
                                               for r in rngs):
            raise ConfigError(f"seed() takes a numpy Generator or one per run "
                              f"({self.n_runs}), got {rng!r}", field="rng")
        self.rngs = rngs

    # ----------------------------------------------------------------- episode rules
    @property
    def turn_state(self) -> np.ndarray | None:
        """Where this human turns back: (K, K) ``turn_state[start, ι]`` shared by the rows,
        or (n_runs, K, K) per row; -1 (or None, the default) for never. The seat switches ι
        to the start support on entering it, in episodes drawn to turn back.
        """
        return None

    @property
    def turn_back(self) -> np.ndarray:
        """(n_runs,) each row's probability per episode of turning back (default 0)."""
        return np.zeros(self.n_runs)

    # ----------------------------------------------------------------- protocol
    def draw(self, rng: np.random.Generator, rows: Rows = None) -> None:
        """Choose the humans of the next episode of ``rows`` (a population draws a new
        member), before its start, intention and turning back are drawn; default nothing.
        """

    def begin_episode(self, starts: np.ndarray, intentions: np.ndarray, rows: Rows = None
                      ) -> None:
        """New episodes start in ``rows`` at ``starts`` with intentions ``intentions``
        (arrays of ``len(rows)``, or (n_runs,) when ``rows`` is None).
        """

    @abstractmethod
    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """(n_runs,) the human's actions; entries of inactive runs are ignored."""

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """One joint step in every active run (``human_actions`` as the human took them)."""

    def revised_intentions(self) -> np.ndarray | None:
        """(n_runs,) int, the intention each row's human holds after the last :meth:`observe`
        where it changed its mind in that step, -1 where it did not; None (the default) when
        no row did. Seats call it after every :meth:`observe` and apply the changes.
        """
        return None

    def end_episode(self, rows: Rows = None) -> None:
        """The episodes of ``rows`` ended."""


class BatchedHumans(BatchHuman):
    """Runs a list of single-stream :class:`Human` objects as one :class:`BatchHuman`.

    With one generator (:meth:`seed`) every human draws from it; with one per row, each
    from its own. Whether any of them may change its mind is read from the list given here.
    """

    def __init__(self, graph: TaskGraph, humans: Sequence[Human]) -> None:
        if not humans or not all(isinstance(h, Human) for h in humans):
            raise ConfigError(f"BatchedHumans takes a non-empty list of Human objects, got "
                              f"{humans!r}", field="humans")
        super().__init__(graph, len(humans))
        self.humans = list(humans)
        self.name = humans[0].name  # type: ignore[misc]
        # Most humans never change their mind (Human.revised_intention as it is): then there
        # is nothing to ask after each step.
        self._may_revise = any(_revises(h) for h in self.humans)

    def seed(self, rng: np.random.Generator | Sequence[np.random.Generator]) -> None:
        """Hand each human its generator (the shared one, or its row's)."""
        super().seed(rng)
        for i, human in enumerate(self.humans):
            human.seed(self.rng if self.rngs is None else self.rngs[i])

    def begin_episode(self, starts: np.ndarray, intentions: np.ndarray, rows: Rows = None
                      ) -> None:
        """Start one episode per human of ``rows``."""
        for i, start, goal in zip(all_rows(rows, self.n_runs), np.asarray(starts).reshape(-1),
                                  np.asarray(intentions).reshape(-1), strict=True):
            self.humans[i].begin_episode(int(start), int(goal))

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Ask each active human for an action.

        Raises:
            ActionError: A human returned something other than an integer (0.5, ``True``,
                ``"3"``), naming the row and the value.
        """
        out = np.zeros(self.n_runs, dtype=np.int64)
        for i in np.flatnonzero(active):
            out[i] = integer_action(self.humans[i].act({k: v[i] for k, v in observations.items()}),
                                    f"act() of the human in row {i}")
        return out

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Pass the step to each active human."""
        for i in np.flatnonzero(active):
            self.humans[i].observe(int(states[i]), int(robot_actions[i]),
                                   int(human_actions[i]), int(next_states[i]))

    def revised_intentions(self) -> np.ndarray | None:
        """Each human's :meth:`Human.revised_intention` (-1 where None); None if none changed
        (at once when no human's class, nor the human itself, overrides the method).
        """
        if not self._may_revise:
            return None
        out = np.full(self.n_runs, -1, dtype=np.int64)
        for i, human in enumerate(self.humans):
            new = human.revised_intention()
            if new is not None:
                number = integer_or_none(new)
                if number is None or not 0 <= number < self.graph.n_intentions:
                    raise ActionError(f"revised_intention() of the human in row {i} returned "
                                      f"{new!r}; it is None or a support index in "
                                      f"[0, {self.graph.n_intentions})")
                out[i] = number
        return out if (out >= 0).any() else None

    def end_episode(self, rows: Rows = None) -> None:
        """Tell each human of ``rows`` that its episode ended."""
        for i in all_rows(rows, self.n_runs):
            self.humans[i].end_episode()


def checked_actions(actions: Any, n_runs: int, n_actions: int,
                    who: str = "the human") -> np.ndarray:
    """The (n_runs,) int64 actions a :class:`BatchHuman` returned, checked: an integer array
    of that shape with every entry in [0, n_actions); an :class:`ActionError` naming ``who``
    otherwise (a float array is refused, not truncated).
    """
    arr = np.asarray(actions)
    if arr.shape != (n_runs,) or arr.dtype.kind not in "iu":
        raise ActionError(f"act() of {who} returned {arr.dtype} of shape {arr.shape}; it must "
                          f"give one integer action per row, shape ({n_runs},)")
    bad = (arr < 0) | (arr >= n_actions)
    if bad.any():
        raise ActionError(f"act() of {who} returned action {arr[bad][0]}; actions are "
                          f"integers in [0, {n_actions})")
    return arr.astype(np.int64, copy=False)
