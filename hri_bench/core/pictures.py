"""The task's picture for the page: the graph backend's side view as a PNG.

:class:`hri_envs.envs.render.SideView` draws the scenario (once per layout) and the object
in a state (what the envs' ``render_mode="rgb_array"`` shows); :func:`png` encodes it
(zlib only, no imaging library). A picture depends on the scenario, the supports' layout
and the state alone, so :func:`picture` caches the encoded pictures: after the first visit
of a state, a step costs a dictionary look-up, and a first visit about 2 ms.
"""

from __future__ import annotations

import base64
import functools
import struct
import zlib

import numpy as np

from hri_envs.envs.render import SideView
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import Layout, episode_geometry

__all__ = ["picture", "png"]


def png(rgb: np.ndarray, level: int = 3) -> bytes:
    """A PNG file of an (H, W, 3) uint8 image (8-bit RGB, no filter)."""
    h, w, _ = rgb.shape
    rows = np.concatenate([np.zeros((h, 1), np.uint8),
                           np.ascontiguousarray(rgb, dtype=np.uint8).reshape(h, w * 3)], axis=1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), level)) + chunk(b"IEND", b""))


@functools.lru_cache(maxsize=256)
def _view(graph: TaskGraph, layout: Layout | None) -> SideView:
    return SideView(episode_geometry(graph, layout), graph)


@functools.lru_cache(maxsize=8192)
def picture(graph: TaskGraph, layout: Layout | None, state: int) -> str:
    """The side view of ``graph`` (supports at ``layout``) in ``state`` as a PNG data URL."""
    rgb = _view(graph, layout).draw(int(state))
    return "data:image/png;base64," + base64.b64encode(png(rgb)).decode("ascii")
