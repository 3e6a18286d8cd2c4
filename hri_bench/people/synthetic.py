"""Scripted humans through the page's input protocol: synthetic people for the physical tasks.

Where no people's recordings exist, a physical human model is fitted and scored on
*synthetic* people recorded through the same path as people: a server of the physical task
(``hri-bench serve --physical``'s app, with the env and the robot in a session process each),
joined over HTTP as the page joins, and led over its websocket with ``hand`` messages at
25 Hz. Each synthetic participant is the continuous envs' reference human
(:class:`~hri_envs.physics.carry.human.intention.IntentionHuman`: their route to the goal, a
minimum-jerk reference along it with their speed, reaction and hesitation, yielding to a
robot that leads their way) of a member of a physical population, and sends as its hand's
target where that reference puts the hand (:class:`ScriptedLeader`); the server seats the
member's body and arm. The dataset is marked synthetic (``dataset.json``, ``session.json``
and every row), and its participants are ``s0001``, ...

* :func:`lead` plays one session as a client (also what ``benchmarks/serve_load.py
  --physical`` runs, many at once, measuring the time from an input to its frame);
* :func:`record_synthetic` serves the app in this process on a free port of 127.0.0.1 and
  records sessions of a population's members (``benchmarks/people_physical_fit.py``
  records them for the fitted physical human, :mod:`hri_bench.people.physical_fit`).
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import threading
import time
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hri_envs.physics.carry.human.intention import HumanParams, IntentionHuman, route_states
from hri_envs.physics.carry.human.whole_arm import handle_quat_in_object
from hri_envs.physics.scene.design import design_for
from hri_envs.physics.scene.kinematics import Pose, compose
from hri_envs.physics.scene.observer import StateObserver
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import episode_geometry

__all__ = ["LeadStats", "ScriptedLeader", "join", "lead", "record_synthetic"]

#: The env's step [s].
STEP_S = 0.04


class ScriptedLeader:
    """A reference human who leads the hand's target as the page's participant would.

    Args:
        graph: The scenario's task graph (its physical design: a physical scenario's).
        params: The human (speed, reaction, hesitation and preference shape the target).
    """

    def __init__(self, graph: TaskGraph, params: HumanParams) -> None:
        self.scenario, self.params = graph.name, params
        self.graph = graph
        self.design = design_for(self.graph)
        self.handle = (np.asarray(self.design.handle_pos, dtype=float),
                       handle_quat_in_object(self.graph.scenario.orientations[0]))
        self.human: IntentionHuman | None = None
        self.object_row = 0

    def begin(self, view: dict[str, Any], scene: dict[str, Any]) -> None:
        """An episode's first frame: plan the route from its start to its goal."""
        flat = view.get("layout") or []
        layout = tuple(zip(flat[::2], flat[1::2], strict=True)) or None
        geometry = episode_geometry(self.graph, layout)
        observer = StateObserver(self.graph, geometry, self.design.lever)
        states = route_states(self.graph, int(view["start"]), int(view["goal"]),
                              self.params.preference)
        self.human = IntentionHuman(self.design, self.params, self.design.lever)
        self.human.plan([Pose(*observer.pose(s)) for s in states])
        self.object_row = scene["bodies"].index("object")

    def target(self, view: dict[str, Any]) -> list[float]:
        """The hand's target for the next step: the reference's hand pose."""
        assert self.human is not None
        poses = np.asarray(view["poses"], dtype=float).reshape(-1, 7)
        obj = poses[self.object_row]
        ref = self.human.advance(STEP_S, obj[:3], obj[3:] / np.linalg.norm(obj[3:]))
        hand = compose(Pose(ref.pos, ref.quat), *self.handle)
        return [round(float(v), 6) for v in (*hand.pos, *hand.quat)]


@dataclass
class LeadStats:
    """What the clients measured.

    Attributes:
        latency_ms: Input sent to its frame received, per step.
        latency_at: When each of ``latency_ms`` was measured (``time.monotonic()``).
        first_ms: ``continue`` (or hello) to an episode's first frame.
        errors: Errors the server sent, and sessions that ended otherwise than done.
        participants: The ids shown at the sessions' ends.
    """

    latency_ms: list[float] = field(default_factory=list)
    latency_at: list[float] = field(default_factory=list)
    first_ms: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    participants: list[str] = field(default_factory=list)


def join(url: str) -> str:
    """Join the study at ``url`` as its page does (its Origin, the page's token, JSON,
    consent); the session's token.
    """
    with urllib.request.urlopen(url, timeout=60) as r:
        page = r.read().decode()
    token = re.search(r'<meta name="hri-bench-token" content="([^"]+)">', page)
    if token is None:
        raise RuntimeError("the page carries no token")
    req = urllib.request.Request(url + "api/sessions", data=b'{"consent": true}',
                                 headers={"Content-Type": "application/json",
                                          "Origin": url.rstrip("/"),
                                          "X-HRI-Bench-Token": token.group(1)},
                                 method="POST")
    with urllib.request.urlopen(req, timeout=60) as r:
        return str(json.loads(r.read())["session"])


def _scene(url: str, key: str) -> dict[str, Any]:
    with urllib.request.urlopen(f"{url}api/scene/{key}", timeout=60) as r:
        doc: dict[str, Any] = json.loads(r.read())
    return doc


async def lead(url: str, leader: Callable[[str], ScriptedLeader], stats: LeadStats, *,
               deadline: float) -> None:
    """Play one session at ``url`` with ``leader(token)`` (the session's token: a recorder
    serving the app itself looks up whom it plays): its targets each step, at most
    25 a second (the page's pace: 40 ms after the last input, or at once if that has
    passed), the latency it sees recorded and sent with the next input, ``continue`` after
    each outcome.
    """
    import websockets  # noqa: PLC0415 (the web extra)

    token = await asyncio.to_thread(join, url)
    scripted = leader(token)
    scenes: dict[str, dict[str, Any]] = {}
    episode, sent_at, latency, asked = None, 0.0, None, time.perf_counter()
    async with websockets.connect(url.replace("http://", "ws://") + "ws", max_size=2**22,
                                  origin=url.rstrip("/")) as ws:  # type: ignore[arg-type]
        await ws.send(json.dumps({"type": "hello", "session": token}))
        while time.monotonic() < deadline:
            m = json.loads(await asyncio.wait_for(ws.recv(), 120))
            now = time.perf_counter()
            if m["type"] == "error":
                stats.errors.append(str(m["error"]))
                continue
            if m["type"] in ("done", "ended"):
                stats.participants.append(m.get("participant", ""))
                if m["type"] == "ended":
                    stats.errors.append(f"ended: {m['reason']} {m.get('error')}")
                return
            if m["type"] == "outcome":
                if not m["last"]:
                    asked = time.perf_counter()
                    await ws.send(json.dumps({"type": "continue", "seq": m["seq"]}))
                continue
            if m["type"] != "lead":
                continue
            if m["episode"] != episode:
                stats.first_ms.append(1000 * (now - asked))
                if m["scene"] not in scenes:
                    scenes[m["scene"]] = await asyncio.to_thread(_scene, url, m["scene"])
                scripted.begin(m, scenes[m["scene"]])
                episode, latency = m["episode"], None
            elif sent_at:
                latency = 1000 * (now - sent_at)
                stats.latency_ms.append(latency)
                stats.latency_at.append(time.monotonic())
            target = scripted.target(m)
            wait = sent_at + STEP_S - time.perf_counter()
            if wait > 0:
                await asyncio.sleep(wait)
            sent_at = time.perf_counter()
            await ws.send(json.dumps({"type": "hand", "seq": m["seq"], "target": target,
                                      "stiffness": 1.0, "input": "scripted",
                                      "latency_ms": latency}))
        stats.errors.append("deadline")


class ServedApp:
    """The app of ``config`` served by uvicorn in a thread of this process, on a free port
    of 127.0.0.1 (``url``), until :meth:`close`.
    """

    def __init__(self, config: Any) -> None:
        import socket  # noqa: PLC0415

        import uvicorn  # noqa: PLC0415

        from hri_bench.people.serve.app import create_app  # noqa: PLC0415

        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.bind(("127.0.0.1", 0))
        sock.listen(64)
        port = sock.getsockname()[1]
        self.app = create_app(config, port=port)
        self.url = f"http://127.0.0.1:{port}/"
        self.server = uvicorn.Server(uvicorn.Config(self.app, log_level="warning",
                                                    ws_max_size=4096, access_log=False,
                                                    lifespan="on"))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]},
                                       daemon=True)
        self.thread.start()
        while not self.server.started:
            if not self.thread.is_alive():
                raise RuntimeError("the server did not start")
            time.sleep(0.05)
        self._sock = sock

    def close(self) -> None:
        """Stop serving (the sessions are stopped and recorded)."""
        self.server.should_exit = True
        self.thread.join(60)
        self._sock.close()


def record_synthetic(scenario: str, dataset: str, *, sessions: int, episodes: int,
                     population: str = "train", agent: str | None = None, seed: int = 0,
                     data: str | os.PathLike[str] | None = None, at_once: int = 2,
                     max_time_s: float | None = None) -> Any:
    """Record ``sessions`` synthetic participants of a physical population through the
    page's protocol (the module docstring) into the synthetic dataset ``dataset``; returns
    it (:class:`~hri_bench.data.datasets.Dataset`). ``at_once`` sessions run together;
    ``max_time_s`` is the episodes' time limit (None: the env's).
    """
    from pathlib import Path  # noqa: PLC0415

    from hri_bench.core.physical_robots import default_robot  # noqa: PLC0415
    from hri_bench.data.datasets import open_dataset  # noqa: PLC0415
    from hri_bench.people.serve.design import ServeConfig  # noqa: PLC0415
    from hri_envs.physics.carry.human.population import physical_population  # noqa: PLC0415

    config = ServeConfig(scenario, agent=agent or default_robot(), episodes=episodes,
                         dataset=dataset, data=None if data is None else Path(data),
                         seed=seed, physical=True, synthetic=True, population=population,
                         max_sessions=max(1, at_once), idle_timeout_s=600.0,
                         max_time_s=max_time_s,
                         agent_timeout_s=600.0)
    pop = physical_population(population, config.graph)
    umask = os.umask(0o077)
    served = ServedApp(config)
    try:
        manager = served.app.state.sessions
        stats = LeadStats()
        deadline = time.monotonic() + 3600.0 * sessions

        def leader_of(token: str) -> ScriptedLeader:
            # the member the server seated for this session (its row of the design)
            index = manager.get(token).design.index
            return ScriptedLeader(config.graph, pop.members[pop.member_index(seed, index)])

        async def run_all() -> None:
            for block in range(0, sessions, at_once):
                await asyncio.gather(*(lead(served.url, leader_of, stats, deadline=deadline)
                                       for _ in range(block, min(sessions, block + at_once))))

        asyncio.run(run_all())
        if stats.errors:
            raise RuntimeError(f"synthetic sessions failed: {stats.errors[:3]}")
    finally:
        served.close()
        os.umask(umask)
    return open_dataset(config.dataset_id, data)
