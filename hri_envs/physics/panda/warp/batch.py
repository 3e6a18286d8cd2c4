"""The ``"mjwarp"`` backend for the benchmark: every run of a batch in its own world, all
stepped together (``hri-bench study --backend mjwarp``).

The random streams are :class:`~hri_envs.physics.panda.batch.PhysicsBatch`'s (run ``r``'s human
noise from ``(seed, r, 3)``, the wheel's layouts from ``(seed, r, 4)``), so run ``r`` meets
the same humans, noise and layouts as on the C backend; only the physics differs (float32,
MuJoCo Warp, mink-warp), which tests/test_mjwarp.py bounds.
"""

from __future__ import annotations

import numpy as np

from hri_envs.envs.backends import BatchBackend, BatchStep
from hri_envs.physics.panda.batch import PhysicsBatch
from hri_envs.physics.panda.warp.worlds import WarpWorlds
from hri_envs.physics.scene.ik import IKFailure

__all__ = ["WarpPhysicsBatch"]


class WarpPhysicsBatch(PhysicsBatch):
    """Runs simulated on the Panda, one world per run, on MuJoCo Warp: a
    :class:`~hri_envs.physics.panda.batch.PhysicsBatch` (its random streams, scenarios and
    per-episode extras) whose runs are stepped together.

    Args:
        graph, runs, seed: As :class:`~hri_envs.envs.backends.BatchBackend`.
        physics: Validated ``physics`` options.
    """

    def _open(self) -> None:
        self.worlds = WarpWorlds(self.graph, len(self.runs), options=self.physics)

    groups = BatchBackend.groups  # every run together

    def begin(self, rows: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Reset the worlds of ``rows`` to their starts."""
        bad = np.zeros(len(rows), dtype=bool)
        for j, i in enumerate(rows):
            try:
                self.worlds.reset_world(int(i), int(start[j]), self._scenario(int(i)),
                                        self._noise[i])
            except IKFailure:
                bad[j] = True
        return bad

    def transition(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                   active: np.ndarray) -> BatchStep:
        """Simulate the joint actions of the active runs together."""
        results = self.worlds.step(state, a_r, a_h, active)
        stepped = {}
        for i in np.flatnonzero(active):
            res = results[i]
            assert res is not None  # an active world has stepped
            stepped[int(i)] = res
        return self._batch_step(stepped, state, a_h)
