"""Physical robots of your own in a process of their own (the physical suite's isolation).

The continuous counterpart of :mod:`hri_bench.run.agent_host` / :mod:`hri_bench.run.isolation`:
a ``module:Class`` robot (an :class:`agents.physical.PhysicalAgent`) runs in the same kind of
host process, spoken to in the same fixed message format (:mod:`hri_bench.run.wire`; nothing
pickled), and is told what a robot may know and nothing else:

* ``physical.init``: the scenario's name and the run's random stream (a keyed hash of the
  suite seed and the run: :func:`hri_bench.run.physical.agent_stream`'s entropy; never the
  seed, the run, the human or the intention). The class is made with ``rng=`` when its
  constructor names it, ``scenario=`` likewise, else with nothing;
* ``physical.begin``: the episode's public facts, from which the host rebuilds the
  :class:`~hri_envs.physics.carry.robot_view.RobotTask` (the scenario's graph and design are
  public; the start, the layout, the seats, the step, the limits and the observation's
  layout travel);
* ``physical.act``: the observation → the action (and the belief, if asked);
* ``physical.end``: the outcome (where the object rested, the goal revealed in hindsight, the
  fault, the episode's figures).

A class that declares ``privileged = True`` is refused: a reference needs the simulation,
which never leaves the benchmark's process.
"""

from __future__ import annotations

import os
import weakref
from collections.abc import Mapping
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent
from hri_bench.run import isolation
from hri_bench.run.physical_session import PhysicalSession, describe_class
from hri_envs.physics.carry.robot_view import EpisodeOutcome, RobotTask
from hri_envs.task.graph import TaskGraph

__all__ = ["IsolatedPhysicalAgent", "describe_physical", "task_message"]


#: What each ``module:Class`` is, asked once per process (:func:`describe_physical`).
_DESCRIBED: dict[str, dict[str, Any]] = {}


def describe_physical(spec: str) -> dict[str, Any]:
    """What ``module:Class`` is, imported in a host: ``module``, ``class``, ``name`` and the
    constructor keywords it is given (asked once per process, like
    :func:`hri_bench.run.isolation.describe`).
    """
    if spec not in _DESCRIBED:
        if os.environ.get(isolation.IN_PROCESS) == "1":
            _DESCRIBED[spec] = describe_class(spec)
        else:
            host = isolation.acquire_host(spec)
            try:
                _DESCRIBED[spec] = isolation.ask_host(
                    spec, host, {"kind": "physical.describe", "spec": spec})[0]["describe"]
            finally:
                isolation.release_host(spec, host)
    return _DESCRIBED[spec]


def task_message(task: RobotTask) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A :class:`RobotTask` as a message (what the host rebuilds it from)."""
    return ({"scenario": task.scenario, "start": int(task.start),
             "layout": None if task.layout is None else [list(p) for p in task.layout],
             "dt": task.dt, "time_limit_s": task.time_limit_s, "max_step_m": task.max_step_m,
             "max_step_rad": task.max_step_rad, "robot_holds": bool(task.robot_holds),
             "layout_names": {k: [s.start, s.stop] for k, s in task.layout_names.items()}},
            {"seats": np.asarray(task.seats, dtype=float)})


class IsolatedPhysicalAgent(PhysicalAgent):
    """A ``module:Class`` physical robot for one run, in its host process.

    Args:
        spec: ``module:Class``.
        graph: The scenario's task graph (its name is what the host is told).
        entropy: (32,) the run's stream's entropy (never the seed or the run).
    """

    def __init__(self, spec: str, graph: TaskGraph, entropy: np.ndarray) -> None:
        info = describe_physical(spec)
        self.spec, self.name = spec, info["name"]  # type: ignore[misc]
        self._local: PhysicalSession | None = None
        if os.environ.get(isolation.IN_PROCESS) == "1":  # a debugger's: same messages, here
            self._local = PhysicalSession()
        else:
            self._host = isolation.acquire_host(spec)
            weakref.finalize(self, isolation.release_host, spec, self._host)
        self._ask({"kind": "physical.init", "spec": spec, "scenario": graph.name},
                  {"entropy": np.asarray(entropy, dtype=np.uint8)})
        self._belief: np.ndarray | None = None

    def _ask(self, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None = None
             ) -> dict[str, np.ndarray]:
        if self._local is not None:
            return self._local.run(str(header["kind"]), header, dict(arrays or {}))[1]
        return isolation.ask_host(self.spec, self._host, header, arrays)[1]

    def begin_episode(self, task: RobotTask) -> None:
        """Sends the episode's public facts."""
        header, arrays = task_message(task)
        self._ask({"kind": "physical.begin", **header}, arrays)

    def act(self, observation: np.ndarray) -> np.ndarray:
        """One round trip: the observation out, the action (and belief) back."""
        back = self._ask({"kind": "physical.act", "belief": True},
                         {"obs": np.asarray(observation, dtype=np.float32)})
        self._belief = back.get("belief")
        return back["action"].astype(np.float32)

    def belief(self) -> np.ndarray | None:
        """The belief the last :meth:`act` brought."""
        return self._belief

    def end_episode(self, outcome: EpisodeOutcome) -> None:
        """The outcome (answered: an error of the robot's learning is reported here)."""
        self._ask({"kind": "physical.end", "placed": outcome.placed,
                   "intention": outcome.intention, "fault": outcome.fault,
                   "truncated": outcome.truncated, "metrics": {
                       k: (v if not isinstance(v, float) or np.isfinite(v) else None)
                       for k, v in outcome.metrics.items()}})
