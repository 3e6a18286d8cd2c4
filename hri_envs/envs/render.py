"""Rendering of an episode: a few lines of text (``ansi``) or a numpy-drawn side view.

The side view needs no plotting library. Its horizontal axis *unfolds* the supports'
columns: column k sits at the summed (x, y) distance along A′ → B′ → C′ ..., so the picture
keeps the real distances between neighbouring columns (and shows the wheel's random stand
layout); the vertical axis is the height z in [m]. Supports are grey posts, waypoints
small dots (mounting points larger), and the object a disc coloured by who holds it with a
tick for its orientation (horizontal for orientation 0, vertical for orientation 1).
"""

from __future__ import annotations

import numpy as np

from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import GRASP_NAMES, TaskGraph

__all__ = ["GRASP_COLOURS", "SideView", "render_ansi", "render_rgb"]

#: RGB per grasp code μ: nobody, human, robot, both.
GRASP_COLOURS = np.array(
    [[150, 150, 150], [230, 130, 30], [40, 110, 220], [40, 170, 80]], dtype=np.uint8
)
_BACKGROUND = (246, 245, 240)
_GROUND = (120, 110, 100)
_POST = (160, 160, 160)
_CAP = (90, 90, 90)
_WAYPOINT = (185, 185, 205)
_MOUNT = (110, 110, 170)
_INK = (20, 20, 20)
# 3 x 5 glyphs for the support labels.
_GLYPHS = {
    "A": ("010", "101", "111", "101", "101"),
    "B": ("110", "101", "110", "101", "110"),
    "C": ("011", "100", "100", "100", "011"),
    "D": ("110", "101", "101", "101", "110"),
    "E": ("111", "100", "110", "100", "111"),
}


def render_ansi(
    graph: TaskGraph,
    *,
    title: str,
    state: int,
    previous: int,
    start: int,
    intention: int | None,
    last_human: int,
    last_robot: int,
    reward: float,
    steps: int,
    max_cycles: int,
) -> str:
    """A few lines describing the episode; ``intention=None`` prints it as hidden."""
    names = graph.support_names
    iota = "hidden" if intention is None else names[intention]
    human = graph.agent_action_label(previous, last_human, robot=False)
    robot = graph.agent_action_label(previous, last_robot, robot=True)
    held = "" if graph.support[state] >= 0 else f" ({GRASP_NAMES[graph.grasp[state]]})"
    return (
        f"{title} | step {steps}/{max_cycles} | start {names[start]} | intention {iota}\n"
        f"state {state}: {graph.state_names[state]}{held}\n"
        f"human: {human} | robot: {robot} | robot reward {reward:+.2f}\n"
    )


def _object_position(scenario: Scenario, graph: TaskGraph, state: int) -> np.ndarray:
    k = int(graph.support[state])
    if k >= 0:
        return scenario.supports[k].position
    return scenario.waypoint_position(int(graph.column[state]), int(graph.height[state]))


def _unfolding(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column: the unfolded coordinate u [m], mounting (x, y) and direction, (K,), (K, 2)."""
    mounts = np.array([s.mounting[:2] for s in scenario.supports])  # (K, 2)
    seg = np.diff(mounts, axis=0)  # (K-1, 2)
    length = np.maximum(np.linalg.norm(seg, axis=1), 1e-9)
    u_col = np.concatenate([[0.0], np.cumsum(length)])
    direction = seg / length[:, None]
    direction = np.concatenate([direction[:1], direction], axis=0)  # (K, 2)
    return u_col, mounts, direction


def _disc(img: np.ndarray, cx: float, cy: float, r: float, colour: tuple[int, ...]) -> None:
    h, w, _ = img.shape
    x0, x1 = max(int(cx - r - 1), 0), min(int(cx + r + 2), w)
    y0, y1 = max(int(cy - r - 1), 0), min(int(cy + r + 2), h)
    if x0 >= x1 or y0 >= y1:
        return
    yy, xx = np.mgrid[y0:y1, x0:x1]
    inside = (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
    img[y0:y1, x0:x1][inside] = colour


def _rect(img: np.ndarray, x0: float, y0: float, x1: float, y1: float,
          colour: tuple[int, ...]) -> None:
    h, w, _ = img.shape
    xa, xb = sorted((int(round(x0)), int(round(x1))))
    ya, yb = sorted((int(round(y0)), int(round(y1))))
    img[max(ya, 0):min(yb + 1, h), max(xa, 0):min(xb + 1, w)] = colour


def _line(img: np.ndarray, x0: float, y0: float, x1: float, y1: float,
          colour: tuple[int, ...], width: int = 2) -> None:
    h, w, _ = img.shape
    n = int(max(abs(x1 - x0), abs(y1 - y0)) * 2) + 2
    t = np.linspace(0.0, 1.0, n)
    xs = np.round(x0 + t * (x1 - x0)).astype(int)
    ys = np.round(y0 + t * (y1 - y0)).astype(int)
    for dy in range(-(width // 2), width - width // 2):
        for dx in range(-(width // 2), width - width // 2):
            ok = (xs + dx >= 0) & (xs + dx < w) & (ys + dy >= 0) & (ys + dy < h)
            img[ys[ok] + dy, xs[ok] + dx] = colour


def _text(img: np.ndarray, x: float, y: float, text: str, colour: tuple[int, ...],
          scale: int = 2) -> None:
    for i, char in enumerate(text):
        for row, bits in enumerate(_GLYPHS.get(char, ())):
            for col, bit in enumerate(bits):
                if bit == "1":
                    px, py = x + (4 * i + col) * scale, y + row * scale
                    _rect(img, px, py, px + scale - 1, py + scale - 1, colour)


class SideView:
    """The side view of a scenario's supports and waypoints, drawn once; :meth:`draw` adds
    the object in a state (what :func:`render_rgb` draws, for many states of one layout).

    Args:
        scenario: The scenario's geometry (with the episode's layout).
        graph: Its task graph.
        height, width: The picture's size in pixels.
    """

    def __init__(self, scenario: Scenario, graph: TaskGraph, *, height: int = 240,
                 width: int = 360) -> None:
        self.scenario, self.graph = scenario, graph
        img = np.empty((height, width, 3), dtype=np.uint8)
        img[:] = _BACKGROUND
        u_col, mounts, direction = _unfolding(scenario)
        n_h = len(scenario.heights)
        waypoints = np.array([scenario.waypoint_position(c, h)
                              for c in range(scenario.n_supports) for h in range(n_h)])  # (K H, 3)
        cols = np.repeat(np.arange(scenario.n_supports), n_h)
        u_wp = u_col[cols] + np.sum((waypoints[:, :2] - mounts[cols]) * direction[cols], axis=1)

        # world (u, z) -> pixels, one scale for both axes
        z_top = max(float(waypoints[:, 2].max()), max(s.position[2] for s in scenario.supports))
        pad = 2.0 * scenario.object_radius
        u_lo, u_hi = min(u_wp.min(), u_col.min()) - pad, max(u_wp.max(), u_col.max()) + pad
        margin_bottom, margin = 22, 8
        scale = min((width - 2 * margin) / (u_hi - u_lo),
                    (height - margin - margin_bottom) / (z_top + pad))
        x_off = (width - scale * (u_hi - u_lo)) / 2.0
        self._u_col, self._mounts, self._direction = u_col, mounts, direction
        self._scale, self._x_off, self._u_lo = scale, x_off, u_lo
        self._height, self._margin_bottom = height, margin_bottom

        _, ground_y = self._px(u_lo, 0.0)
        _rect(img, 0, ground_y, width - 1, ground_y + 2, _GROUND)
        for k, sup in enumerate(scenario.supports):
            x, y = self._px(u_col[k], sup.position[2])
            _rect(img, x - 3, y, x + 3, ground_y, _POST)
            _rect(img, x - 10, y - 2, x + 10, y + 2, _CAP)
            _text(img, x - 2, ground_y + 6, sup.name, _INK)
        mount_xy = {(int(graph.column[s]), int(graph.height[s])) for s in graph.mounting_state}
        for i, (u, z) in enumerate(zip(u_wp, waypoints[:, 2], strict=True)):
            x, y = self._px(u, z)
            mounting = (int(cols[i]), i % n_h) in mount_xy
            _disc(img, x, y, 3.0 if mounting else 2.0, _MOUNT if mounting else _WAYPOINT)
        img.setflags(write=False)
        self.background = img

    def _px(self, u: float, z: float) -> tuple[float, float]:
        return (self._x_off + (u - self._u_lo) * self._scale,
                self._height - self._margin_bottom - z * self._scale)

    def draw(self, state: int) -> np.ndarray:
        """The side view with the object in ``state``; (height, width, 3) uint8."""
        scenario, graph = self.scenario, self.graph
        img = self.background.copy()
        pos = _object_position(scenario, graph, state)
        k = int(graph.support[state])
        c = k if k >= 0 else int(graph.column[state])
        u = (self._u_col[c] if k >= 0
             else self._u_col[c] + float((pos[:2] - self._mounts[c]) @ self._direction[c]))
        x, y = self._px(u, pos[2])
        r = float(np.clip(0.5 * scenario.object_radius * self._scale, 6.0, 18.0))
        colour = tuple(int(v) for v in GRASP_COLOURS[graph.grasp[state]])
        _disc(img, x, y, r + 1.5, _INK)
        _disc(img, x, y, r, colour)
        vertical = int(graph.orientation[state]) % 2 == 1
        dx, dy = (0.0, r + 6.0) if vertical else (r + 6.0, 0.0)
        _line(img, x - dx, y - dy, x + dx, y + dy, _INK, width=2)
        return img


def render_rgb(
    scenario: Scenario, graph: TaskGraph, state: int, *, height: int = 240, width: int = 360
) -> np.ndarray:
    """Side view of the scenario with the object in ``state``; (height, width, 3) uint8."""
    return SideView(scenario, graph, height=height, width=width).draw(state)
