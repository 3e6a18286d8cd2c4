"""The physics backend for the benchmark: :class:`PhysicsBatch`, which the one simulation
loop (:func:`hri_bench.run.runner.simulate`) drives for ``hri-bench study --backend mujoco``.

The physics is not batched: one :class:`PandaSim` simulates the runs one after the other
within each episode (the loop then sees one active run at a time, which the batched agent
protocol allows), and the agent learns from all runs' episodes at once at the end of the
episode, exactly as on the graph. Every random draw of run ``r`` derives from ``(seed, r)``:
the human's action draws from ``(seed, r, 1)`` as on the graph (in the loop), the human's
force noise from ``(seed, r, 3)``, the wheel's stand layouts from ``(seed, r, 4)``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import numpy as np

from hri_envs.envs.backends import BatchBackend, BatchStep
from hri_envs.physics.panda.episode import STEP_FIGURES, STEP_MEANS, step_figures
from hri_envs.physics.panda.sim import PandaSim, StepResult
from hri_envs.physics.scene.ik import IKFailure
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import episode_geometry, spec_of

__all__ = ["PhysicsBatch"]


class PhysicsBatch(BatchBackend):
    """Runs simulated on the Panda, one run at a time.

    The per-episode extras are ``linear_impulse`` [N s] and ``angular_impulse`` [N m s]
    (the human's interaction wrench as the wrist sensor sees it, integrated over the
    episode, paper Fig. 6), ``linear_impulse_true`` and ``angular_impulse_true`` (the same
    from the true wrench),
    ``duration_s`` (simulated seconds), ``graph_agrees`` (the fraction of the episode's
    steps whose observed next state is the graph's prediction), ``inference_accuracy``
    (the fraction whose inferred human action is the true one), ``hold_accuracy`` (the
    fraction whose handle sensor told rightly whether the human holds) and ``physical_fault``
    (1 if the episode ended in a physical failure, which earns that step r⁻). Any fault, or
    a start the robot cannot reach, truncates the run's episode.

    Args:
        graph, runs, seed: As :class:`BatchBackend`.
        physics: Validated ``physics`` options (e.g. ``{"preset": "weak-human"}``).
    """

    extras: ClassVar[tuple[str, ...]] = STEP_FIGURES
    step_means: ClassVar[tuple[str, ...]] = STEP_MEANS

    def __init__(self, graph: TaskGraph, runs: Sequence[int] | np.ndarray, seed: int,
                 physics: Mapping[str, Any] | None = None) -> None:
        super().__init__(graph, runs, seed, physics)
        self._noise = [np.random.default_rng([self.seed, int(r), 3]) for r in self.runs]
        self._layouts = [np.random.default_rng([self.seed, int(r), 4]) for r in self.runs]
        self._sample_layout = spec_of(graph).layout
        self._open()

    def _open(self) -> None:
        """Build the simulator (a subclass: its own, e.g. N worlds on MuJoCo Warp)."""
        self.sim = PandaSim(self.graph, options=self.physics)

    def groups(self) -> list[np.ndarray]:
        """One run at a time: the simulator holds one run's state."""
        return [np.array([i]) for i in range(len(self.runs))]

    def _scenario(self, i: int) -> Scenario:
        """Row ``i``'s scenario for its next episode (a new stand layout on the wheel)."""
        layout = None if self._sample_layout is None else self._sample_layout(self._layouts[i])
        return episode_geometry(self.graph, layout)

    def begin(self, rows: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Reset the simulator to run ``rows[0]``'s start."""
        (i,) = rows
        try:
            self.sim.reset(int(start[0]), self._scenario(int(i)), self._noise[i])
        except IKFailure:
            return np.ones(1, dtype=bool)
        return np.zeros(1, dtype=bool)

    def transition(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                   active: np.ndarray) -> BatchStep:
        """Simulate the joint action of the one active run."""
        return self._batch_step({int(i): self.sim.step(int(state[i]), int(a_r[i]), int(a_h[i]))
                                 for i in np.flatnonzero(active)}, state, a_h)

    def _batch_step(self, results: Mapping[int, StepResult], state: np.ndarray,
                    a_h: np.ndarray) -> BatchStep:
        """The loop's step from the physical steps ``results`` of the active rows."""
        next_state, seen = state.copy(), np.zeros_like(a_h)
        fault = np.zeros(len(state), dtype=bool)
        extras = {k: np.zeros(len(state)) for k in self.extras}
        for i, res in results.items():
            next_state[i], seen[i], fault[i] = res.state, res.human_action, res.fault is not None
            for key, value in step_figures(res, int(a_h[i])).items():
                extras[key][i] = value
        return BatchStep(next_state, seen, fault, extras, extras["physical_fault"] > 0)
