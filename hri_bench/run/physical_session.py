"""The host's side of a physical robot of your own (:mod:`hri_bench.run.physical_host`).

Run inside a :mod:`hri_bench.run.agent_host` process, which hands every ``physical.*``
message to a :class:`PhysicalSession`: it imports the ``module:Class`` (refusing a class that
declares ``privileged = True``), makes the robot for a run and answers ``begin`` / ``act`` /
``end`` with what the robot returns. Nothing here knows the benchmark's objects.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent
from hri_envs.errors import ActionError, ConfigError
from hri_envs.imports import import_class
from hri_envs.physics.carry.robot_view import EpisodeOutcome, RobotTask

__all__ = ["PhysicalSession", "describe_class", "task_from_message"]

_KEYWORDS = ("rng", "scenario")


def _load(spec: str) -> type[PhysicalAgent]:
    cls: type[PhysicalAgent] = import_class(spec, "physical robot", "agents", (PhysicalAgent,))
    if getattr(cls, "privileged", False):
        raise ConfigError(f"physical robot {spec!r} declares privileged = True: a reference "
                          "reads the simulation, which a robot of your own never gets; "
                          "remove it to rank the robot", field="agents")
    return cls


def _keywords(cls: type) -> list[str]:
    """The constructor keywords of :data:`_KEYWORDS` that ``cls`` names."""
    params = inspect.signature(cls).parameters
    return [k for k in _KEYWORDS if k in params]


def describe_class(spec: str) -> dict[str, Any]:
    """``module:Class`` imported here: ``module``, ``class``, ``name`` and the constructor
    keywords it is given (``rng``, ``scenario``: those its constructor names).

    Raises:
        ConfigError: It does not import, is not a :class:`PhysicalAgent`, or is privileged.
    """
    cls = _load(spec)
    name = vars(cls).get("name") if isinstance(vars(cls).get("name"), str) else None
    return {"module": cls.__module__, "class": cls.__qualname__,
            "name": name or cls.__name__, "keywords": _keywords(cls)}


def task_from_message(header: Mapping[str, Any], arrays: Mapping[str, np.ndarray]
                      ) -> RobotTask:
    """The :class:`RobotTask` :func:`hri_bench.run.physical_host.task_message` sent (the
    scenario's graph, geometry and design rebuilt from its public name and layout).
    """
    from hri_envs.physics.scene.design import design_for  # noqa: PLC0415
    from hri_envs.task.scenarios import episode_geometry, scenario_graph  # noqa: PLC0415

    name = str(header["scenario"])
    graph = scenario_graph(name)  # the message's edge: the name resolved once
    layout = None if header["layout"] is None else tuple(
        (float(x), float(y)) for x, y in header["layout"])
    return RobotTask(
        scenario=name, graph=graph, geometry=episode_geometry(graph, layout),
        start=int(header["start"]), seats=np.asarray(arrays["seats"], dtype=float),
        layout=layout, dt=float(header["dt"]), time_limit_s=float(header["time_limit_s"]),
        max_step_m=float(header["max_step_m"]), max_step_rad=float(header["max_step_rad"]),
        design=design_for(graph),
        layout_names={k: slice(int(a), int(b)) for k, (a, b) in header["layout_names"].items()},
        robot_holds=bool(header["robot_holds"]))


def _action(value: Any) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "biuf" or arr.shape != (7,):
        raise ActionError(f"act() returned {arr.dtype} of shape {arr.shape}; expected 7 "
                          "numbers in [-1, 1]")
    return arr.astype(np.float64)


class PhysicalSession:
    """The host's side: the robot of the current run and its messages."""

    def __init__(self) -> None:
        self.agent: PhysicalAgent | None = None

    def run(self, kind: str, header: Mapping[str, Any], arrays: Mapping[str, np.ndarray]
            ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """Handle one ``physical.*`` message; its answer."""
        if kind == "physical.describe":
            return {"describe": describe_class(header["spec"])}, {}
        if kind == "physical.init":
            self.agent = None
            cls = _load(header["spec"])
            rng = np.random.default_rng(int.from_bytes(bytes(arrays["entropy"]), "big"))
            given = {"rng": rng, "scenario": str(header["scenario"])}
            self.agent = cls(**{k: given[k] for k in _keywords(cls)})
            return {}, {}
        agent = self.agent
        if agent is None:
            raise RuntimeError("no robot: init failed or never came")
        if kind == "physical.begin":
            agent.begin_episode(task_from_message(header, arrays))
            return {}, {}
        if kind == "physical.act":
            out = {"action": _action(agent.act(np.asarray(arrays["obs"])))}
            if header.get("belief"):
                b = agent.belief()
                if b is not None:
                    out["belief"] = np.asarray(b, dtype=float)
            return {}, out
        if kind == "physical.end":
            agent.end_episode(EpisodeOutcome(
                int(header["placed"]), int(header["intention"]), header.get("fault"),
                bool(header["truncated"]), dict(header.get("metrics") or {})))
            return {}, {}
        raise RuntimeError(f"unknown message {kind!r}")
