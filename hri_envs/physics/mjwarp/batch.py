"""The ``"mjwarp"`` backend for the benchmark: every run of a batch in its own world, all
stepped together (``hri-bench study --backend mjwarp``).

The random streams are :class:`~hri_envs.physics.batch.PhysicsBatch`'s (run ``r``'s human
noise from ``(seed, r, 3)``, the wheel's layouts from ``(seed, r, 4)``), so run ``r`` meets
the same humans, noise and layouts as on the C backend; only the physics differs (float32,
MuJoCo Warp, mink-warp), which tests/test_mjwarp.py bounds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from hri_envs.envs.backends import BatchBackend, BatchStep
from hri_envs.physics.episode import STEP_FIGURES, STEP_MEANS, step_figures
from hri_envs.physics.ik import IKFailure
from hri_envs.physics.mjwarp.worlds import WarpWorlds
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import episode_scenario, scenario_spec

__all__ = ["WarpPhysicsBatch"]


class WarpPhysicsBatch(BatchBackend):
    """Runs simulated on the Panda, one world per run, on MuJoCo Warp.

    The per-episode extras are those of :class:`~hri_envs.physics.batch.PhysicsBatch`.

    Args:
        graph, runs, seed: As :class:`~hri_envs.envs.backends.BatchBackend`.
        physics: Validated ``physics`` options.
    """

    extras: ClassVar[tuple[str, ...]] = STEP_FIGURES
    step_means: ClassVar[tuple[str, ...]] = STEP_MEANS

    def __init__(self, graph: TaskGraph, runs: Sequence[int] | np.ndarray, seed: int,
                 physics: Mapping[str, Any] | None = None) -> None:
        super().__init__(graph, runs, seed, physics)
        self.worlds = WarpWorlds(graph, len(self.runs), options=self.physics)
        self._noise = [np.random.default_rng([self.seed, int(r), 3]) for r in self.runs]
        self._layouts = [np.random.default_rng([self.seed, int(r), 4]) for r in self.runs]
        self._sample_layout = scenario_spec(graph.name).layout

    def begin(self, rows: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Reset the worlds of ``rows`` to their starts (new stand layouts on the wheel)."""
        bad = np.zeros(len(rows), dtype=bool)
        for j, i in enumerate(rows):
            layout = (None if self._sample_layout is None
                      else self._sample_layout(self._layouts[i]))
            scenario = episode_scenario(self.graph.name, layout)
            try:
                self.worlds.reset_world(int(i), int(start[j]), scenario, self._noise[i])
            except IKFailure:
                bad[j] = True
        return bad

    def transition(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                   active: np.ndarray) -> BatchStep:
        """Simulate the joint actions of the active runs together."""
        results = self.worlds.step(state, a_r, a_h, active)
        next_state, seen = state.copy(), np.zeros_like(a_h)
        fault = np.zeros(len(state), dtype=bool)
        extras = {k: np.zeros(len(state)) for k in self.extras}
        for i in np.flatnonzero(active):
            res = results[i]
            assert res is not None
            next_state[i], seen[i], fault[i] = res.state, res.human_action, res.fault is not None
            for key, value in step_figures(res, int(a_h[i])).items():
                extras[key][i] = value
        return BatchStep(next_state, seen, fault, extras, extras["physical_fault"] > 0)
