"""Headless ``rgb_array`` rendering of the physics scene, and episode videos.

MuJoCo chooses its OpenGL backend from ``MUJOCO_GL`` when it is first imported;
:func:`select_gl_backend` (called by :mod:`hri_envs.physics` before importing MuJoCo) picks
EGL when ``libEGL`` is present and OSMesa otherwise, unless the user chose already.
"""

from __future__ import annotations

import ctypes.util
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError, MissingExtraError
from hri_envs.physics.scene.camera import CameraPose, check_camera, fit_view, parts, project

__all__ = ["EpisodePictures", "RenderSettings", "SceneRenderer", "select_gl_backend",
           "write_video"]

#: Labels are anchored this far above each support's seat [m].
LABEL_LIFT_M = 0.12
#: The goal's mark (only when asked): a translucent sphere at the goal's seat.
GOAL_RADIUS_M, GOAL_RGBA = 0.07, (0.1, 0.8, 0.2, 0.45)
#: The labels' fill colours (RGB): a support's, the goal's.
LABEL_FILL, GOAL_FILL = (250, 250, 240), (150, 230, 150)
#: How the overview's azimuth is chosen (:class:`ViewScore`): the height [px] of the small
#: segmented pictures it is judged on, the weight of each part's log pixel count (each
#: support's: 1), and the credit for labels apart by at least LABEL_GAP picture heights.
SCORE_HEIGHT_PX = 90
PART_WEIGHTS = {"object": 2.0, "arm": 1.0, "robot": 1.0}
LABEL_GAP, LABEL_WEIGHT = 0.12, 3.0


class ViewScore:
    """How well a camera pose shows a scene: from a small segmented picture, the sum over
    the parts the picture should show (the object, the human's arm, the robot, each support:
    :func:`~hri_envs.physics.scene.camera.parts`) of ``weight x log(1 + pixels seen)``, plus up to
    :data:`LABEL_WEIGHT` as the least gap between two supports' labels grows to
    :data:`LABEL_GAP` picture heights. A part hidden behind another, or drawn small, and
    labels on top of each other score low.

    Args:
        model: The compiled scene.
        aspect: The picture's width / height.
    """

    def __init__(self, model: Any, aspect: float) -> None:
        import mujoco

        self._mujoco, self.model = mujoco, model
        self.height, self.width = SCORE_HEIGHT_PX, max(16, round(SCORE_HEIGHT_PX * aspect))
        self.renderer = mujoco.Renderer(model, self.height, self.width)
        self.renderer.enable_segmentation_rendering()
        self.parts = parts(model)
        self.camera = mujoco.MjvCamera()
        self.data: Any = None
        self.seats = np.zeros((0, 3))

    def __call__(self, pose: CameraPose) -> float:
        """The score of ``pose`` for the state and seats set last (:attr:`data`,
        :attr:`seats`).
        """
        cam = self.camera
        cam.lookat[:], cam.distance = pose.lookat, pose.distance
        cam.azimuth, cam.elevation = pose.azimuth, pose.elevation
        self.renderer.update_scene(self.data, camera=cam)
        seg = self.renderer.render()
        geoms = seg[..., 0][seg[..., 1] == int(self._mujoco.mjtObj.mjOBJ_GEOM)]
        seen = np.bincount(geoms[geoms >= 0], minlength=self.model.ngeom)
        total = sum(PART_WEIGHTS.get(name, 1.0) * np.log1p(seen[mask].sum())
                    for name, mask in self.parts.items())
        xy, _ = project(self.seats + [0.0, 0.0, LABEL_LIFT_M], pose,
                        float(self.model.vis.global_.fovy), self.width, self.height)
        gaps = np.linalg.norm(xy[:, None] - xy[None], axis=2)[np.triu_indices(len(xy), 1)]
        spread = min(1.0, gaps.min() / (LABEL_GAP * self.height)) if gaps.size else 1.0
        return float(total + LABEL_WEIGHT * spread)

    def close(self) -> None:
        """Release the GL context."""
        self.renderer.close()


def select_gl_backend() -> str:
    """Set ``MUJOCO_GL`` to "egl" (if libEGL exists) or "osmesa" unless it is set; return it."""
    if "MUJOCO_GL" not in os.environ:
        os.environ["MUJOCO_GL"] = "egl" if ctypes.util.find_library("EGL") else "osmesa"
    return os.environ["MUJOCO_GL"]


@dataclass(frozen=True)
class RenderSettings:
    """An env's checked picture arguments (:meth:`check`).

    Attributes:
        camera: A view name or a mapping of the free camera's numbers
            (:func:`~hri_envs.physics.scene.camera.check_camera`).
        goal: Whether the human's goal is marked (for a viewer; never by default).
        width, height: The picture's size in pixels.
    """

    camera: str | dict[str, Any] = "overview"
    goal: bool = False
    width: int = 640
    height: int = 480

    @classmethod
    def check(cls, camera: Any = None, render_goal: Any = False,
              render_size: Any = (640, 480)) -> RenderSettings:
        """The settings of an env's ``camera``, ``render_goal`` and ``render_size``
        (``(width, height)``) arguments.

        Raises:
            ConfigError: A value not allowed, naming the argument and what it allows.
        """
        view = check_camera(camera)
        if not isinstance(render_goal, bool | np.bool_):
            raise ConfigError(f"render_goal must be True or False, got {render_goal!r}",
                              field="render_goal")
        if not isinstance(render_size, tuple | list) or len(render_size) != 2 or any(
                isinstance(v, bool) or not isinstance(v, int | np.integer)
                or not 16 <= v <= 4096 for v in render_size):
            raise ConfigError(f"render_size must be (width, height), whole numbers of pixels "
                              f"in [16, 4096], got {render_size!r}", field="render_size")
        return cls(view, bool(render_goal), int(render_size[0]), int(render_size[1]))


class SceneRenderer:
    """Offscreen renderer of a physics scene, its supports labelled by name.

    The camera (:mod:`hri_envs.physics.scene.camera`) is a named view fitted to the scene by
    :meth:`aim` (call it when an episode starts: the supports, the object and both agents
    in the picture) or a mapping of MuJoCo's free-camera numbers. Each support's name is
    drawn above its seat; :meth:`render` marks the human's goal only when asked.

    Args:
        model: The compiled scene.
        supports: (K, 3) support (seat) positions.
        height, width: Image size in pixels.
        camera: A view of :data:`~hri_envs.physics.scene.camera.VIEWS` or a mapping of
            :data:`~hri_envs.physics.scene.camera.CAMERA_KEYS` (checked by
            :func:`~hri_envs.physics.scene.camera.check_camera`; None: "overview").
        names: The supports' names, drawn as labels (None: no labels).
        data: The scene's state to fit the camera to now (None: at the first :meth:`aim`).

    Raises:
        ConfigError: ``camera`` is not allowed.
        RuntimeError: No offscreen OpenGL context.
    """

    def __init__(self, model: object, supports: np.ndarray, height: int = 360,
                 width: int = 480, camera: Any = None, names: Sequence[str] | None = None,
                 data: object | None = None) -> None:
        import mujoco

        self._mujoco = mujoco
        self.view = check_camera(camera)
        self.names = list(names) if names is not None else None
        self.model = model
        frame = model.vis.global_  # type: ignore[attr-defined]
        # the offscreen buffer must hold the picture (a visual setting; nothing simulated)
        frame.offwidth, frame.offheight = max(frame.offwidth, width), max(frame.offheight,
                                                                          height)
        try:
            self.renderer = mujoco.Renderer(model, height, width)
        except Exception as exc:  # no GL context: say how to get one
            raise RuntimeError(
                f"MuJoCo cannot create an offscreen OpenGL context with MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL')!r} ({exc}); install EGL (libegl1) or OSMesa "
                "(libosmesa6) and set MUJOCO_GL=egl or MUJOCO_GL=osmesa before importing"
            ) from exc
        self.camera = mujoco.MjvCamera()
        self.supports = np.asarray(supports, dtype=np.float64)
        self.pose: CameraPose | None = None
        self._score: ViewScore | None = None
        if data is not None:
            self.aim(data, supports)

    @property
    def fovy(self) -> float:
        """The vertical field of view [deg]."""
        return float(self.model.vis.global_.fovy)  # type: ignore[attr-defined]

    def aim(self, data: object, supports: np.ndarray) -> CameraPose:
        """Fit the camera to the scene in ``data`` with the supports at ``supports`` (at the
        start of an episode: the start state never depends on the human's goal).
        """
        self.supports = np.asarray(supports, dtype=np.float64)
        aspect = self.renderer.width / self.renderer.height
        if self._score is None:
            self._score = ViewScore(self.model, aspect)
        self._score.data, self._score.seats = data, self.supports
        self.pose = fit_view(self.model, data, self.supports, self.view, aspect, self._score)
        self.camera.lookat[:] = self.pose.lookat
        self.camera.distance = self.pose.distance
        self.camera.azimuth, self.camera.elevation = self.pose.azimuth, self.pose.elevation
        return self.pose

    def render(self, data: object, goal: int | None = None) -> np.ndarray:
        """An RGB image (height, width, 3) uint8 of the state in ``data``, the supports
        labelled; ``goal``: the index of a support to mark as the human's goal (None: no
        mark, the default everywhere: the goal is the human's hidden intention).
        """
        if self.pose is None:
            self.aim(data, self.supports)
        self.renderer.update_scene(data, camera=self.camera)
        if goal is not None:
            self._goal_marker(self.supports[goal])
        image = np.asarray(self.renderer.render(), dtype=np.uint8)
        if self.names is None:
            return image
        return self._labels(image, goal)

    def label_positions(self) -> np.ndarray:
        """(K, 2) pixel positions (column, row) of the supports' labels' anchors."""
        assert self.pose is not None
        xy, _ = project(self.supports + [0.0, 0.0, LABEL_LIFT_M], self.pose, self.fovy,
                        self.renderer.width, self.renderer.height)
        return xy

    def _goal_marker(self, seat: np.ndarray) -> None:
        scene = self.renderer.scene
        if scene.ngeom >= scene.maxgeom:
            return
        mujoco = self._mujoco
        mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE,
                            np.array([GOAL_RADIUS_M, 0.0, 0.0]), np.asarray(seat, float),
                            np.eye(3).ravel(), np.array(GOAL_RGBA, dtype=np.float32))
        scene.ngeom += 1

    def _labels(self, image: np.ndarray, goal: int | None) -> np.ndarray:
        try:
            from PIL import Image, ImageDraw, ImageFont
        except ImportError as exc:
            raise MissingExtraError(["PIL"], "labelling the supports") from exc
        assert self.names is not None
        picture = Image.fromarray(image)
        draw = ImageDraw.Draw(picture)
        size = max(10, round(self.renderer.height / 22))
        font = ImageFont.load_default(size=size)
        pad = max(2, size // 5)
        placed: list[tuple[float, float, float, float]] = []
        anchors = self.label_positions()
        for k in sorted(range(len(self.names)), key=lambda i: -anchors[i][1]):
            text = f"{self.names[k]}: goal" if k == goal else self.names[k]
            col, row = anchors[k]
            left, top, right, bottom = draw.textbbox((col, row), text, font=font, anchor="mb")
            box = (left - pad, top - pad, right + pad, bottom + pad)
            for other in sorted(placed, key=lambda o: -o[3]):  # lift it above any it hides
                if box[0] < other[2] and other[0] < box[2] and box[1] < other[3] \
                        and other[1] < box[3]:
                    lift = box[3] - other[1] + 1
                    box, row = (box[0], box[1] - lift, box[2], box[3] - lift), row - lift
            placed.append(box)
            draw.rounded_rectangle(box, radius=pad, outline=(40, 40, 40),
                                   fill=GOAL_FILL if k == goal else LABEL_FILL)
            draw.text((col, row), text, font=font, anchor="mb", fill=(20, 20, 20))
        return np.asarray(picture, dtype=np.uint8)

    def close(self) -> None:
        """Release the GL contexts."""
        self.renderer.close()
        if self._score is not None:
            self._score.close()
            self._score = None


class EpisodePictures:
    """The pictures of an env's episodes: a :class:`SceneRenderer` made on first use, its
    camera fitted again whenever an episode starts.

    Args:
        settings: The env's checked picture arguments.
    """

    def __init__(self, settings: RenderSettings) -> None:
        self.settings = settings
        self.renderer: SceneRenderer | None = None
        self._episode: Any = None

    def draw(self, model: object, data: object, seats: np.ndarray, names: Sequence[str],
             episode: Any, starts: bool, goal: int) -> np.ndarray:
        """A picture of the state in ``data``.

        Args:
            model: The compiled scene.
            data: Its state.
            seats: (K, 3) the supports' seats.
            names: The supports' names.
            episode: What tells this episode from the last (e.g. its start and layout).
            starts: The episode has just started (its camera is fitted again).
            goal: The human's goal, marked only if the settings ask for it.
        """
        cfg = self.settings
        if self.renderer is None:
            self.renderer = SceneRenderer(model, seats, cfg.height, cfg.width,
                                          camera=cfg.camera, names=names)
        if starts or self._episode != episode:
            self.renderer.aim(data, seats)
            self._episode = episode
        return self.renderer.render(data, goal if cfg.goal else None)

    def close(self) -> None:
        """Release the renderer."""
        if self.renderer is not None:
            self.renderer.close()
            self.renderer = None


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
