"""The Passive agent (Alg. 2), the Imitator (Alg. 3) and the Oracle (upper bound), and the
start-and-lift bookkeeping every baseline shares (:class:`Tracking`).

All three are batched :class:`~agents.protocol.BatchAgent` implementations: arrays with a
leading run axis, one independent stream of episodes per run.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from agents.learning import mdp
from agents.protocol import BatchAgent, Trace
from hri_envs.humans.scripted import PreferredActions
from hri_envs.task import episode as rules
from hri_envs.task import mdp as task_mdp
from hri_envs.task.graph import BOTH, ROBOT_BIT, TAKE_OFF, TOGGLE, WAIT, TaskGraph

__all__ = ["Imitator", "Oracle", "Passive", "Tracking"]


class Tracking(BatchAgent):
    """The bookkeeping the baselines share: each run's start support, whether the object has
    left it, and the Passive baseline's action from them (the base class of every baseline
    of this package).
    """

    def __init__(self, graph: TaskGraph, n_runs: int) -> None:
        super().__init__(n_runs)
        self.graph = graph
        self.start = np.zeros(n_runs, dtype=np.int64)
        self.lifted = np.zeros(n_runs, dtype=bool)

    def begin_episode(self, starts: np.ndarray) -> None:
        """Keep each run's start support; no run has lifted the object yet."""
        self.start = np.asarray(starts, dtype=np.int64).reshape(self.n_runs).copy()
        self.lifted = np.zeros(self.n_runs, dtype=bool)

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Note the active runs whose object has left its start support."""
        self.lifted |= active & rules.left_start(self.graph, next_states, self.start)

    def passive(self, states: np.ndarray) -> np.ndarray:
        """(B,) the Passive baseline's action in each run's state."""
        rows = np.arange(self.n_runs)
        return task_mdp.passive_actions(self.graph, self.start, self.lifted)[rows, states]

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Nothing to learn by default."""


class Passive(Tracking):
    """Algorithm 2: grasp at the start, let go at the goal, gravity compensation in between.

    As an extension (so that Table 2's episode 8 can end), the start counts as a goal once
    the object has left it.
    """

    name: ClassVar[str] = "passive"

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The passive baseline action."""
        return self.passive(np.asarray(observations["state"], dtype=np.int64))


class Imitator(Tracking):
    """Algorithm 3: repeat the human's most recent action seen in the same state from the
    same start support; behave passively where nothing was observed yet.

    Attributes:
        table: (B, K, S) int, the imitated action per (start, state), -1 where unseen.
    """

    name: ClassVar[str] = "imitator"

    def __init__(self, graph: TaskGraph, n_runs: int = 1) -> None:
        super().__init__(graph, n_runs)
        self.table = np.full((n_runs, graph.n_intentions, graph.n_states), -1, dtype=np.int64)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The remembered action, else the passive one."""
        states = np.asarray(observations["state"], dtype=np.int64)
        seen = self.table[np.arange(self.n_runs), self.start, states]
        return np.where(seen >= 0, seen, self.passive(states))

    def end_episode(self, traces: Sequence[Trace], intentions: np.ndarray) -> None:
        """Store the human's (non-wait) actions along the loop-free trace."""
        for b, trace in enumerate(traces):
            kept = mdp.remove_loops(trace.states)[:-1]
            start = int(self.graph.support[trace.states[0]])
            for s, a in zip(trace.states[kept], trace.human_actions[kept], strict=True):
                if a != WAIT:
                    self.table[b, start, s] = a


class Oracle(Tracking):
    """Knows the human's current intention and scripted preference: the upper bound.

    It takes the human's preferred action in free space and handles its own grasp at the
    supports. It needs the true intention in ``observations["intention"]`` (the benchmark
    provides it to agents with ``privileged = True``).
    """

    name: ClassVar[str] = "oracle"
    privileged: ClassVar[bool] = True

    def __init__(self, graph: TaskGraph, human: PreferredActions, n_runs: int = 1) -> None:
        super().__init__(graph, n_runs)
        self.human = human

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The preferred action for the true intention."""
        if "intention" not in observations:
            raise KeyError("the Oracle needs observations['intention'] (it is privileged)")
        g = self.graph
        states = np.asarray(observations["state"], dtype=np.int64)
        goal = np.asarray(observations["intention"], dtype=np.int64)
        preferred = self.human.preferred_action(states, self.start, goal)
        sup, mu = g.support[states], g.grasp[states]
        holds = (mu & ROBOT_BIT) > 0
        arrived = (sup == goal) & rules.arrived(g, states, self.start, self.lifted)
        at_support = np.where(
            arrived,
            np.where(holds, TOGGLE, WAIT),
            np.where(~holds, TOGGLE, np.where(mu == BOTH, TAKE_OFF, WAIT)),
        )
        return np.where(sup >= 0, at_support, preferred)
