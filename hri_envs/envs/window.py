"""``render_mode="human"``: a window that shows the episode as it runs.

The graph backend shows its ``rgb_array`` picture in a matplotlib window
(:class:`FrameWindow`); the physics backend opens MuJoCo's passive viewer instead (see
:meth:`hri_envs.physics.panda.episode.PhysicsEpisode.show`). Both need a display: where there is
none, :func:`check_display` raises :class:`~hri_envs.errors.DisplayUnavailableError` when the
env is built, before anything is simulated.
"""

from __future__ import annotations

import os
import sys
from typing import Any

import numpy as np

from hri_envs.errors import DisplayUnavailableError, MissingExtraError

__all__ = ["FrameWindow", "check_display", "display_available"]

_INSTEAD = ("use render_mode='rgb_array' (frames as arrays) or 'ansi' (text) instead, or run "
            "under a virtual display: xvfb-run -a python ...")


def display_available() -> bool:
    """Whether a window can be opened: always on macOS and Windows, else with an X11 or
    Wayland display (``DISPLAY`` or ``WAYLAND_DISPLAY`` set).
    """
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def check_display() -> None:
    """Raise :class:`~hri_envs.errors.DisplayUnavailableError` when no window can open."""
    if not display_available():
        raise DisplayUnavailableError(
            "render_mode='human' opens a window, but there is no display here (neither "
            f"DISPLAY nor WAYLAND_DISPLAY is set); {_INSTEAD}",
            field="render_mode",
        )


class FrameWindow:
    """A matplotlib window showing RGB frames at a given rate.

    Args:
        title: The window's title.
        fps: Frames per second: :meth:`show` waits 1 / fps [s] after drawing, so that a
            person can follow the episode.
    """

    def __init__(self, title: str, fps: float) -> None:
        self.title, self.fps = title, float(fps)
        self._plt: Any = None
        self._fig: Any = None
        self._image: Any = None

    def show(self, frame: np.ndarray) -> None:
        """Draw ``frame``, (H, W, 3) uint8, opening the window on the first call."""
        if self._fig is None:
            self._open(frame)
        else:
            self._image.set_data(frame)
        self._plt.pause(1.0 / self.fps)

    def _open(self, frame: np.ndarray) -> None:
        check_display()
        try:
            import matplotlib.pyplot as plt
            from matplotlib.backends import BackendFilter, backend_registry
        except ImportError:
            raise MissingExtraError(["matplotlib"], "render_mode='human' on the graph "
                                    "backend") from None
        backend = plt.get_backend()
        if backend.lower() in backend_registry.list_builtin(BackendFilter.NON_INTERACTIVE):
            raise DisplayUnavailableError(
                f"render_mode='human' needs an interactive matplotlib backend, but the backend "
                f"is {backend!r} (set by MPLBACKEND or matplotlib's rc, or no GUI toolkit "
                f"such as tkinter is installed); set MPLBACKEND=TkAgg or QtAgg, or {_INSTEAD}",
                field="render_mode")
        self._plt = plt
        self._fig, ax = plt.subplots(figsize=(frame.shape[1] / 100, frame.shape[0] / 100))
        ax.set_axis_off()
        self._fig.subplots_adjust(0, 0, 1, 1)
        manager = self._fig.canvas.manager
        if manager is not None:
            manager.set_window_title(self.title)
        self._image = ax.imshow(frame)
        plt.show(block=False)

    def close(self) -> None:
        """Close the window (if it was opened)."""
        if self._fig is not None:
            self._plt.close(self._fig)
            self._fig = self._image = None
