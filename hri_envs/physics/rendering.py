"""Headless ``rgb_array`` rendering of the physics scene, and episode videos.

MuJoCo chooses its OpenGL backend from ``MUJOCO_GL`` when it is first imported;
:func:`select_gl_backend` (called by :mod:`hri_envs.physics` before importing MuJoCo) picks
EGL when ``libEGL`` is present and OSMesa otherwise, unless the user chose already.
"""

from __future__ import annotations

import ctypes.util
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hri_envs.errors import ConfigError, MissingExtraError

__all__ = ["SceneRenderer", "select_gl_backend", "write_video"]


def select_gl_backend() -> str:
    """Set ``MUJOCO_GL`` to "egl" (if libEGL exists) or "osmesa" unless it is set; return it."""
    if "MUJOCO_GL" not in os.environ:
        os.environ["MUJOCO_GL"] = "egl" if ctypes.util.find_library("EGL") else "osmesa"
    return os.environ["MUJOCO_GL"]


class SceneRenderer:
    """Offscreen renderer with a camera framing the scenario's supports.

    Args:
        model: The compiled scene.
        supports: (K, 3) support positions, to aim the camera.
        height, width: Image size in pixels.
    """

    def __init__(self, model: object, supports: np.ndarray, height: int = 360,
                 width: int = 480) -> None:
        import mujoco

        self._mujoco = mujoco
        try:
            self.renderer = mujoco.Renderer(model, height, width)
        except Exception as exc:  # no GL context: say how to get one
            raise RuntimeError(
                f"MuJoCo cannot create an offscreen OpenGL context with MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL')!r} ({exc}); install EGL (libegl1) or OSMesa "
                "(libosmesa6) and set MUJOCO_GL=egl or MUJOCO_GL=osmesa before importing"
            ) from exc
        self.camera = mujoco.MjvCamera()
        self.aim(supports)

    def aim(self, supports: np.ndarray) -> None:
        """Frame the supports (and the space in front of them)."""
        lo, hi = supports.min(axis=0), supports.max(axis=0)
        extent = float(np.linalg.norm(hi - lo))
        self.camera.lookat[:] = (lo + hi) / 2.0 - [0.15 * extent, 0.0, 0.15 * extent]
        self.camera.distance = 1.15 * extent + 0.6
        self.camera.azimuth, self.camera.elevation = 200.0, -22.0

    def render(self, data: object) -> np.ndarray:
        """An RGB image (height, width, 3) uint8 of the current state."""
        self.renderer.update_scene(data, camera=self.camera)
        return np.asarray(self.renderer.render(), dtype=np.uint8)

    def close(self) -> None:
        """Release the GL context."""
        self.renderer.close()


def write_video(frames: Sequence[np.ndarray], path: str | os.PathLike[str],
                fps: float = 10.0) -> Path:
    """Write frames as a GIF (``.gif``) or, with imageio-ffmpeg installed, a video file."""
    try:
        import imageio.v3 as iio
    except ImportError as exc:
        raise MissingExtraError(["imageio"], "writing videos") from exc
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not frames:
        raise ConfigError("frames must hold at least one frame, got none", field="frames")
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, np.stack(frames), duration=1000.0 / fps, loop=0)
    else:
        iio.imwrite(path, np.stack(frames), fps=fps)
    return path
