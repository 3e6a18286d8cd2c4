"""The ``"mjwarp"`` backend inside the envs: a
:class:`~hri_envs.physics.panda.episode.PhysicsEpisode`
whose simulation is one world of a :class:`~hri_envs.physics.panda.warp.worlds.WarpWorlds`.

A single env (``gymnasium.make("hri_envs/HangerPanda-v0", backend="mjwarp")``,
``hanger_v0.parallel_env(backend="mjwarp")``) owns a one-world :class:`WarpWorlds`; the
vector env (:class:`~hri_envs.physics.panda.warp.vector.PandaVectorEnv`) gives each of its envs
one world of a shared one and steps them together (:attr:`WarpSim.pending`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

import mujoco
import numpy as np

from hri_envs.physics.panda.episode import PhysicsEpisode
from hri_envs.physics.panda.sim import StepResult
from hri_envs.physics.panda.warp.worlds import WarpWorlds
from hri_envs.physics.scene.seats import Seats
from hri_envs.physics.scene.warp.handout import Handout
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import TaskGraph

__all__ = ["WarpPhysicsEpisode", "WarpSim"]


class WarpSim:
    """One world of a :class:`WarpWorlds`, with the interface of a
    :class:`~hri_envs.physics.panda.sim.PandaSim` that :class:`PhysicsEpisode` uses.

    Args:
        worlds: The worlds.
        index: This one's index among them.

    Attributes:
        pending: A result of this world's next step already simulated together with other
            worlds (:meth:`step` returns it once), or None.
        on_frame, frame_every: As :class:`PandaSim`'s (videos): ``on_frame`` is called every
            ``frame_every`` physics steps of this world's runs.
    """

    def __init__(self, worlds: WarpWorlds, index: int) -> None:
        self.worlds, self.index = worlds, index
        self.pending: StepResult | None = None
        self.on_frame: Callable[[], None] | None = None
        self.frame_every = 50
        self.dt_control = worlds.dt_control
        self.control_every = worlds.k
        self.state = 0

    @property
    def model(self) -> mujoco.MjModel:
        """The C template's model (for pictures)."""
        return self.worlds.template.model

    @property
    def data(self) -> mujoco.MjData:
        """The C template's data, set to this world's state (for pictures)."""
        w = self.worlds.worlds[self.index]
        if w.scenario is not None and self.worlds.template.scenario is not w.scenario:
            self.worlds.template.set_scenario(w.scenario)
        return self.worlds.sync_template(self.index)

    @property
    def seats(self) -> Seats:
        """The seats of this world's layout."""
        w = self.worlds.worlds[self.index]
        if w.scenario is not None and self.worlds.template.scenario is not w.scenario:
            self.worlds.template.set_scenario(w.scenario)
        return self.worlds.template.seats

    def reset(self, start: int, scenario: Scenario | None = None,
              rng: np.random.Generator | None = None, state: int | None = None) -> int:
        """Place this world at an episode's start (:meth:`WarpWorlds.reset_world`)."""
        self.pending = None
        self.state = self.worlds.reset_world(self.index, start, scenario, rng, state)
        return self.state

    def step(self, s: int, a_r: int, a_h: int) -> StepResult:
        """The abstract step of this world (the pending one, or simulated alone now)."""
        res, self.pending = self.pending, None
        if res is None:
            n = self.worlds.n
            active = np.zeros(n, dtype=bool)
            active[self.index] = True
            states, ar, ah = (np.zeros(n, dtype=np.int64) for _ in range(3))
            states[self.index], ar[self.index], ah[self.index] = s, a_r, a_h
            hook = self.worlds.on_period
            self.worlds.on_period = self._frame if self.on_frame is not None else hook
            try:
                out = self.worlds.step(states, ar, ah, active)[self.index]
            finally:
                self.worlds.on_period = hook
            assert out is not None
            res = out
        self.state = res.state
        return res

    def _frame(self, ran: np.ndarray) -> None:
        every = max(1, round(self.frame_every / self.control_every))
        if ran[self.index] and self.worlds.period[self.index] % every == 0 \
                and self.on_frame is not None:
            self.on_frame()


class WarpPhysicsEpisode(PhysicsEpisode):
    """One running episode on MuJoCo Warp (the ``"mjwarp"`` backend); everything else is
    :class:`~hri_envs.physics.panda.episode.PhysicsEpisode`'s.
    """

    name: ClassVar[str] = "mjwarp"
    #: A vector env's worlds for the episodes it builds (``with SHARED.sharing(sims):``).
    SHARED: ClassVar[Handout[WarpSim]] = Handout()

    @classmethod
    def make_sim(cls, graph: TaskGraph, options: dict[str, Any]) -> WarpSim:
        """A one-world :class:`WarpWorlds` (Warp's default device), or a vector env's world
        handed out (:attr:`SHARED`).
        """
        return cls.SHARED.take() or WarpSim(WarpWorlds(graph, 1, options=options), 0)

    def show(self, layout: tuple[tuple[float, float], ...] | None, title: str,
             fps: float) -> None:
        """MuJoCo's passive viewer on this world (its state copied into the C template)."""
        self.sim.data  # noqa: B018  (copies the world's state into the viewer's data)
        super().show(layout, title, fps)
