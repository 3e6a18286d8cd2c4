"""The 3D scenes the page draws: the model descriptions it loads, and the graph tasks' poses.

* :class:`SceneStore` keeps the scene descriptions (:func:`hri_bench.people.scene3d.describe`)
  the server's sessions use, by key, compressed once; ``GET /api/scene/KEY`` serves them.
  They are public (the scene every participant of the task sees), never a session's.
* :func:`graph_view` is a graph task's picture: the v0 scene of the discrete Panda backend
  (:class:`~hri_envs.physics.panda.sim.PandaSim`) in the state the graph is in (the object at the
  abstract state's pose, the robot's hand on its grip when it holds, the human's on the
  handle when they hold), as the drawn bodies' poses and the camera fitted at the episode's
  start (:mod:`hri_bench.people.scene3d`). Poses are computed once per (layout, state) and
  kept.
* :func:`built` says whether the page's 3D library is built (``make web``: three.js in
  ``static/vendor``). Without it the page shows the graph backend's 2D picture and says how
  to build the 3D view; the physical tasks need it.
"""

from __future__ import annotations

import functools
import gzip
import json
import threading
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from hri_bench.core.pictures import picture
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import Layout, episode_geometry

__all__ = ["STORE", "VENDOR", "SceneStore", "built", "graph_view", "warm"]

#: The page's vendored libraries (``make web``).
VENDOR = Path(__file__).parent / "static" / "vendor"
#: The files of the 3D library the page loads.
VENDOR_FILES = ("three.module.js", "three.core.js")
#: The page's canvas width / height, which the camera is fitted for.
ASPECT = 1.5


def built() -> bool:
    """Whether the page's 3D library is built (``make web``)."""
    return all((VENDOR / name).is_file() for name in VENDOR_FILES)


class SceneStore:
    """Scene descriptions by key, each as JSON and gzip-compressed JSON; at most
    ``capacity`` kept (the least recently added dropped first).
    """

    def __init__(self, capacity: int = 64) -> None:
        self.capacity = capacity
        self._lock = threading.Lock()
        self._docs: OrderedDict[str, tuple[bytes, bytes]] = OrderedDict()

    def add(self, doc: dict[str, Any]) -> str:
        """Keep a description (its ``key`` computed if missing); returns its key."""
        from hri_bench.people import scene3d  # noqa: PLC0415 (the physics: when asked)

        key = str(doc.get("key") or scene3d.scene_key(doc))
        with self._lock:
            if key in self._docs:
                self._docs.move_to_end(key)
                return key
        text = json.dumps({**doc, "key": key}, separators=(",", ":")).encode()
        packed = gzip.compress(text, compresslevel=6)
        with self._lock:
            self._docs[key] = (text, packed)
            while len(self._docs) > self.capacity:
                self._docs.popitem(last=False)
        return key

    def add_text(self, key: str, text: bytes) -> None:
        """Keep a description already encoded (as a worker sends it)."""
        with self._lock:
            if key in self._docs:
                return
        packed = gzip.compress(text, compresslevel=6)
        with self._lock:
            self._docs[key] = (text, packed)
            while len(self._docs) > self.capacity:
                self._docs.popitem(last=False)

    def __contains__(self, key: object) -> bool:
        with self._lock:
            return key in self._docs

    def get(self, key: str) -> tuple[bytes, bytes] | None:
        """``(json, gzip)`` of a description, or None."""
        with self._lock:
            return self._docs.get(key)


#: The server's scenes (one process serves one app).
STORE = SceneStore()


class _GraphScene:
    """One scenario's v0 scene and the poses of its states (thread-safe)."""

    def __init__(self, graph: TaskGraph) -> None:
        from hri_bench.people import scene3d  # noqa: PLC0415
        from hri_envs.physics.panda.sim import PandaSim  # noqa: PLC0415 (MuJoCo: when asked)

        self.graph = graph
        self.sim = PandaSim(self.graph)
        model = self.sim.model
        self.bodies = scene3d.drawn_bodies(model)
        self.doc = scene3d.describe(model, labels=self.graph.support_names,
                                    rotation_axis=scene3d.rotation_axis(
                                        self.graph.scenario.orientations))
        self.key = self.doc["key"]
        self._lock = threading.Lock()
        self._score: Any = None

    def _place(self, layout: Layout | None, state: int) -> None:
        """Put the sim in ``state`` (lock held)."""
        from hri_envs.physics.scene.ik import IKFailure  # noqa: PLC0415

        scenario = episode_geometry(self.graph, layout)
        start = max(0, int(self.graph.support[state]))
        try:
            self.sim.reset(start, scenario, state=state)
        except IKFailure:  # the robot cannot reach its pose there: it waits at home
            self.sim.reset(start, scenario, state=int(self.graph.support_state(start, 0)))

    @functools.lru_cache(maxsize=4096)  # noqa: B019 (one per scenario, kept for the server)
    def poses(self, layout: Layout | None, state: int) -> tuple[float, ...]:
        """The drawn bodies' poses in ``state`` with the supports at ``layout``."""
        from hri_bench.people import scene3d  # noqa: PLC0415

        with self._lock:
            self._place(layout, state)
            return tuple(scene3d.body_poses(self.sim.data, self.bodies))

    @functools.lru_cache(maxsize=1024)  # noqa: B019
    def camera(self, layout: Layout | None, start: int) -> str:
        """The camera fitted to an episode's start (as JSON text, to be shared).

        The renderer that judges the views holds an OpenGL context, which is current in
        one thread at a time: it is made and used in one thread of its own
        (:data:`_GL_THREAD`), whichever session's thread asks (a second session's thread
        once failed with an EGL error).
        """
        return _GL_THREAD.submit(self._camera, layout, start).result()

    def _camera(self, layout: Layout | None, start: int) -> str:
        from hri_bench.people import scene3d  # noqa: PLC0415

        with self._lock:
            self._place(layout, int(self.graph.support_state(start, 0)))
            if self._score is None:
                self._score = scene3d.view_score(self.sim.model, ASPECT) or False
            return json.dumps(scene3d.camera(self.sim.model, self.sim.data,
                                             self.sim.seats.pos, ASPECT,
                                             self._score or None))


#: The one thread the graph scenes' offscreen renderers are made and used in.
_GL_THREAD = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hri-bench-gl")


@functools.cache
def _scene(graph: TaskGraph) -> _GraphScene:
    scene = _GraphScene(graph)
    STORE.add(scene.doc)
    return scene


def graph_view(graph: TaskGraph, layout: Layout | None, state: int, start: int
               ) -> dict[str, Any]:
    """What a graph task's view carries to draw ``state``: ``scene`` (the description's key),
    ``poses`` and ``camera`` (fitted at the episode's start support ``start``) when the 3D
    view is built, else ``picture`` (the graph backend's side view, a PNG data URL).
    """
    if not built():
        return {"picture": picture(graph, layout, state)}
    scene = _scene(graph)
    STORE.add(scene.doc)  # kept while the server runs (a store full of others drops it)
    return {"scene": scene.key, "poses": list(scene.poses(layout, int(state))),
            "camera": json.loads(scene.camera(layout, int(start)))}


def warm(graph: TaskGraph, layout: Layout | None, start: int) -> None:
    """Compute an episode's first view ahead (the scene, its camera and start state)."""
    if built():
        scene = _scene(graph)
        scene.camera(layout, int(start))
        scene.poses(layout, int(scene.graph.support_state(start, 0)))
    else:
        picture(graph, layout, int(graph.support_state(start, 0)))
