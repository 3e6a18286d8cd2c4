"""Three agents that try to read their way up a leaderboard (issue 41), as ``module:Class``.

Each plays a reference's policy when its cheat works and waits (as
:class:`tests.helpers_agents.AlwaysWait`) when it does not, so a test tells which by its
rewards:

* :class:`ReadsFrames` looks for the human object and the episode's intention ι in the
  frames of the functions that called it (``make_agent``'s ``human``, the episode loop's
  ``eps.intention``) and plays ``informed``;
* :class:`DeclaresPrivileged` sets ``privileged = True`` and is handed ι (it moves only
  when it is);
* :class:`RebuildsHumans` rebuilds each run's human from the study's seed and its run
  indices (its constructor's keywords, or the caller's frames) and the public test split,
  and plays ``qmdp``: the human's model, intention-blind.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from agents.protocol import BatchAgent

#: The population :class:`RebuildsHumans` targets (one headline track of suite v3).
TARGET = "test-v2-scripted"


def _find(name: str, test: Any = None) -> Any:
    """The first local ``name`` (passing ``test``) in the frames above this one."""
    frame = sys._getframe(1)
    while frame is not None:
        value = frame.f_locals.get(name)
        if value is not None and (test is None or test(value)):
            return value
        frame = frame.f_back
    return None


class _Waits(BatchAgent):
    def __init__(self, graph, n_runs, **kwargs):
        super().__init__(n_runs)
        self.graph, self.kwargs, self.inner = graph, kwargs, None

    def begin_episode(self, starts):
        if self.inner is not None:
            self.inner.begin_episode(starts)

    def act(self, observations, active):
        if self.inner is None:
            return np.zeros(self.n_runs, dtype=np.int64)
        return self.inner.act(observations, active)

    def observe(self, states, robot_actions, human_actions, next_states, active):
        if self.inner is not None:
            self.inner.observe(states, robot_actions, human_actions, next_states, active)

    def end_episode(self, traces, intentions):
        if self.inner is not None:
            self.inner.end_episode(traces, intentions)

    def _settings(self) -> dict[str, Any]:
        return {k: self.kwargs[k] for k in ("r0", "max_steps", "reward", "episodes")}


class ReadsFrames(_Waits):
    """Reads the human and ι from its callers' frames, then plays ``informed``."""

    name = "reads-frames"

    def __init__(self, graph, n_runs, **kwargs):
        super().__init__(graph, n_runs, **kwargs)
        human = _find("human", lambda h: hasattr(h, "n_runs") or hasattr(h, "preference"))
        if human is not None:
            from hri_bench.run.agents import AGENTS, AgentContext

            self.inner = AGENTS["informed"].make(AgentContext(
                graph, human, tuple(range(n_runs)), 0, self.kwargs["r0"], {},
                self.kwargs["max_steps"], self.kwargs["reward"], self.kwargs["episodes"]))

    def act(self, observations, active):
        loop = _find("self", lambda s: hasattr(s, "eps") and hasattr(s.eps, "intention"))
        if self.inner is None or loop is None:
            return np.zeros(self.n_runs, dtype=np.int64)
        return self.inner.act({**observations, "intention": loop.eps.intention}, active)


class DeclaresPrivileged(_Waits):
    """Declares ``privileged = True``; moves (its first valid motion) only when it is
    handed ι, so its rewards tell whether it was.
    """

    name = "declares-privileged"
    privileged = True

    def act(self, observations, active):
        out = np.zeros(self.n_runs, dtype=np.int64)
        if "intention" not in observations:
            return out
        mask = np.asarray(observations["action_mask"])
        moves = mask[:, 1:].argmax(1) + 1
        return np.where(mask[np.arange(self.n_runs), moves] > 0, moves, 0).astype(np.int64)


class RebuildsHumans(_Waits):
    """Rebuilds each run's human of :data:`TARGET` from the seed and its runs, then plays
    ``qmdp`` with their models.
    """

    name = "rebuilds-humans"

    def __init__(self, graph, n_runs, **kwargs):
        super().__init__(graph, n_runs, **kwargs)
        seed = kwargs.get("seed", _find("seed", lambda s: isinstance(s, int)))
        runs = kwargs.get("runs", _find("runs", lambda r: len(r) == n_runs))
        self.recovered = 0
        if seed is None or runs is None:
            return
        from baselines.product import QMDP
        from hri_bench.run.study import StudyConfig, unit_humans

        cfg = StudyConfig(graph.name, population=TARGET, runs=int(max(runs)) + 1, seed=seed)
        humans, _ = unit_humans(cfg, "", [int(r) for r in runs])
        self.recovered = len(runs)
        self.inner = QMDP(graph, humans, n_runs, **self._settings())
