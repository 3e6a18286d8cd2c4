"""Where the physics scenes' pictures look from, and where a point of the world lands in them.

A camera is a named view (:data:`VIEWS`) or a mapping of MuJoCo's free-camera numbers
(``lookat``, ``distance``, ``azimuth``, ``elevation``: :data:`CAMERA_KEYS`). A named view
is *fitted* to the scene when an episode starts (:func:`fit_view`): it looks across the line
from the robot to the human, from the side away from the supports (so that both agents are
seen side by side in front of the supports), and stands back just far enough to hold every
support, the object, the robot and the human in the picture. The agents move while they
carry the object, so the parts of the scene that can move (the object, the human, a mobile
robot) are also framed as if carried to every support, standing around it in any direction.
A mapping overrides these numbers (the ones it leaves out are the overview's).

The fit reads the scene at the episode's start only: its supports and where the start puts
the agents, never the human's goal (the start state does not depend on it), so a policy that
learns from pixels sees nothing of the intention in the camera's motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hri_envs.errors import ConfigError

__all__ = ["CAMERA_KEYS", "VIEWS", "CameraPose", "check_camera", "fit_view", "project",
           "scene_points"]

#: Named views: elevation [deg] (negative looks down) and whether the azimuth is chosen
#: (the overview: the azimuth, every 15 degrees, from which the most of the object, the
#: agents' hands and the supports' seats are seen unhidden, then the one that sets the
#: supports and the agents farthest apart) or fixed across the robot-human line ("side":
#: low, the two agents side by side; "top": from above).
VIEWS: dict[str, tuple[float, bool]] = {
    "overview": (-30.0, True),
    "side": (-8.0, False),
    "top": (-89.0, False),
}

#: The keys of a camera given as a mapping (MuJoCo's free camera, ``mujoco.MjvCamera``).
CAMERA_KEYS: tuple[str, ...] = ("lookat", "distance", "azimuth", "elevation")

#: Body names the scenes give the robot's base, the object and the human (the human is the
#: root body whose name starts with this prefix): the line the views look across.
ROBOT_BODY, OBJECT_BODY, HUMAN_PREFIX = "panda_mount", "object", "human"
#: The human's torso (the rest of the human is their arm, which the overview must show).
TORSO_BODY = "human_torso"

#: The fitted distance is this factor above the tightest one (a margin around the scene).
_MARGIN = 1.06
#: The parts that move are framed turned about the object by these angles [deg].
_TURNS_DEG: tuple[float, ...] = (-30.0, 0.0, 30.0)


@dataclass(frozen=True)
class CameraPose:
    """MuJoCo's free camera: where it looks, from how far, from which direction [deg]."""

    lookat: tuple[float, float, float]
    distance: float
    azimuth: float
    elevation: float


def check_camera(camera: Any, field: str = "camera") -> str | dict[str, Any]:
    """``camera`` as a view name or a mapping of :data:`CAMERA_KEYS` (None: "overview").

    Raises:
        ConfigError: An unknown view or key, or a value not allowed (named in the message).
    """
    allowed = (f"{', '.join(map(repr, VIEWS))} or a mapping of "
               f"{', '.join(CAMERA_KEYS)}")
    if camera is None:
        return "overview"
    if isinstance(camera, str):
        if camera not in VIEWS:
            raise ConfigError(f"unknown camera {camera!r}; allowed: {allowed}", field=field)
        return camera
    if not isinstance(camera, Mapping):
        raise ConfigError(f"camera must be {allowed}, got {camera!r}", field=field)
    bad = sorted(map(repr, set(camera) - set(CAMERA_KEYS)))
    if bad:
        raise ConfigError(f"unknown camera key(s) {', '.join(bad)}; allowed: "
                          f"{', '.join(CAMERA_KEYS)}", field=field)
    out: dict[str, Any] = {}
    for key, value in camera.items():
        if key == "lookat":
            try:
                point = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError):
                point = None
            if point is None or point.shape != (3,) or not np.all(np.isfinite(point)):
                raise ConfigError(f"camera 'lookat' must be 3 finite numbers (x, y, z) [m], "
                                  f"got {value!r}", field=field)
            out[key] = tuple(float(v) for v in point)
            continue
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value):
            raise ConfigError(f"camera {key!r} must be a finite number, got {value!r}",
                              field=field)
        if key == "distance" and not value > 0:
            raise ConfigError(f"camera 'distance' must be > 0 [m], got {value!r}", field=field)
        if key == "elevation" and not -90.0 <= value <= 90.0:
            raise ConfigError(f"camera 'elevation' must be in [-90, 90] degrees, got "
                              f"{value!r}", field=field)
        out[key] = float(value)
    return out


def axes(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The free camera's forward, right and up unit vectors (as MuJoCo sets them)."""
    az, el = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az),
                        math.sin(el)])
    up = np.array([-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)])
    return forward, np.cross(forward, up), up


def _roots(model: Any) -> dict[str, int]:
    import mujoco  # noqa: PLC0415

    names = {}
    for body in range(1, model.nbody):
        if model.body_rootid[body] == body:
            names[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or ""] = body
    return names


def scene_points(model: Any, data: Any, seats: np.ndarray) -> np.ndarray:
    """(N, 3) points a fitted view holds: the corners of every visible geom's box but the
    floor's, and those of the geoms that can move (bodies on a free or sliding root, or a
    mocap body) as if the object were carried to each support and the agents stood around
    it in any direction (turned about the object, every 360 / :data:`_TURNS` degrees).
    """
    movers = {model.jnt_bodyid[j] for j in range(model.njnt)
              if model.jnt_type[j] in (0, 2) and model.body_rootid[model.jnt_bodyid[j]]
              == model.jnt_bodyid[j]} | {b for b in range(model.nbody)
                                         if model.body_mocapid[b] >= 0}
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    fixed: list[np.ndarray] = []
    moving: list[np.ndarray] = []
    for g in range(model.ngeom):
        body = model.geom_bodyid[g]
        if body == 0 or model.geom_rgba[g][3] == 0 or model.geom_group[g] > 2:
            continue
        box = model.geom_aabb[g]
        corners = data.geom_xpos[g] + (box[:3] + signs * box[3:]) @ \
            data.geom_xmat[g].reshape(3, 3).T
        (moving if model.body_rootid[body] in movers else fixed).append(corners)
    points = np.concatenate(fixed + moving)
    roots = _roots(model)
    if moving and OBJECT_BODY in roots:
        held = np.concatenate(moving)
        here = data.xpos[roots[OBJECT_BODY]]
        rel = held - here
        turns = np.radians(np.asarray(_TURNS_DEG, dtype=float))[:, None]
        cos, sin = np.cos(turns), np.sin(turns)
        around = np.stack([cos * rel[:, 0] - sin * rel[:, 1], sin * rel[:, 0] + cos * rel[:, 1],
                           np.broadcast_to(rel[:, 2], cos.shape[:1] + rel.shape[:1])],
                          axis=-1).reshape(-1, 3)
        points = np.concatenate([points, *(seat + around for seat in seats)])
    points[:, 2] = np.maximum(points[:, 2], 0.0)  # nothing below the floor is seen
    return points


def side_azimuth(model: Any, data: Any, seats: np.ndarray) -> float:
    """The azimuth [deg] that looks across the robot-human line, the supports beyond."""
    roots = _roots(model)
    human = next((b for name, b in roots.items() if name.startswith(HUMAN_PREFIX)), None)
    robot, obj = roots.get(ROBOT_BODY), roots.get(OBJECT_BODY)
    if robot is None or human is None or obj is None:
        return 90.0
    line = (data.xpos[human] - data.xpos[robot])[:2]
    ahead = (seats.mean(axis=0) - data.xpos[obj])[:2]
    base = math.degrees(math.atan2(line[1], line[0]))
    for azimuth in (base + 90.0, base - 90.0):
        forward = axes(azimuth, 0.0)[0][:2]
        if float(forward @ ahead) >= 0.0:
            break
    return (azimuth + 180.0) % 360.0 - 180.0


def fit(points: np.ndarray, azimuth: float, elevation: float, fovy: float,
        aspect: float) -> tuple[np.ndarray, float]:
    """The lookat point and distance that hold ``points`` in a picture of vertical field of
    view ``fovy`` [deg] and ``aspect`` (width / height), seen from ``azimuth``, ``elevation``.
    """
    forward, right, up = axes(azimuth, elevation)
    ty = math.tan(math.radians(fovy) / 2.0) / _MARGIN
    tx = ty * aspect
    lookat = (points.min(axis=0) + points.max(axis=0)) / 2.0
    distance = 1.0
    for _ in range(4):  # centre the projected points, then stand back to hold them
        rel = points - lookat
        x, y, z = rel @ right, rel @ up, rel @ forward
        distance = float(max(np.max(np.abs(x) / tx - z), np.max(np.abs(y) / ty - z), 0.1))
        depth = distance + z
        u, v = x / depth, y / depth
        du, dv = (u.min() + u.max()) / 2.0, (v.min() + v.max()) / 2.0
        lookat = lookat + distance * (du * right + dv * up)
    return lookat, distance


def parts(model: Any) -> dict[str, np.ndarray]:
    """The parts a view should show, each as a boolean mask over the model's geoms: the
    object, the robot, the human's arm (the human but the torso) and each support.
    """
    import mujoco  # noqa: PLC0415

    def name(body: int) -> str:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or ""

    body, root = model.geom_bodyid, model.body_rootid[model.geom_bodyid]
    roots = _roots(model)
    human = next((b for n, b in roots.items() if n.startswith(HUMAN_PREFIX)), -1)
    visible = (model.geom_rgba[:, 3] > 0) & (model.geom_group <= 2)
    out = {"object": (root == roots.get(OBJECT_BODY, -1)),
           "robot": (root == roots.get(ROBOT_BODY, -1)),
           "arm": (root == human) & np.array([name(b) != TORSO_BODY for b in body])}
    out.update({n: root == b for n, b in roots.items() if n.startswith("support")})
    return {k: v & visible for k, v in out.items()}


def fit_view(model: Any, data: Any, seats: np.ndarray, camera: str | Mapping[str, Any],
             aspect: float, score: Callable[[CameraPose], float] | None = None
             ) -> CameraPose:
    """The camera pose of a checked ``camera`` (:func:`check_camera`) for the scene now.

    Args:
        model: The compiled scene.
        data: Its state (at the start of an episode).
        seats: (K, 3) the supports' seats.
        camera: A view name or a mapping of :data:`CAMERA_KEYS`.
        aspect: The picture's width / height.
        score: How well a pose shows the scene (higher is better), to choose the
            overview's azimuth; None: the overview looks from 35 degrees off the side.
    """
    name = camera if isinstance(camera, str) else "overview"
    given = {} if isinstance(camera, str) else dict(camera)
    elevation, choose = VIEWS[name]
    elevation = given.get("elevation", elevation)
    fovy = float(model.vis.global_.fovy)
    points = scene_points(model, data, seats)
    side = side_azimuth(model, data, seats)
    if "azimuth" in given or not choose:
        azimuths = [given.get("azimuth", side)]
    elif score is None:
        azimuths = [side - 35.0]
    else:
        azimuths = [side + turn for turn in range(0, 360, 15)]
    best: tuple[float, CameraPose] | None = None
    for azimuth in azimuths:
        lookat, distance = fit(points, azimuth, elevation, fovy, aspect)
        x, y, z = (float(v) for v in given.get("lookat", lookat))
        pose = CameraPose((x, y, z),
                          float(given.get("distance", distance)),
                          float((azimuth + 180.0) % 360.0 - 180.0), float(elevation))
        if len(azimuths) == 1 or score is None:
            return pose
        value = score(pose)
        if best is None or value > best[0]:
            best = (value, pose)
    assert best is not None
    return best[1]


def project(points: np.ndarray, pose: CameraPose, fovy: float, width: int,
            height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2: column, row) of world ``points`` in the picture of ``pose``,
    and whether each is in front of the camera.
    """
    forward, right, up = axes(pose.azimuth, pose.elevation)
    eye = np.asarray(pose.lookat) - pose.distance * forward
    rel = np.atleast_2d(points) - eye
    depth = rel @ forward
    focal = (height / 2.0) / math.tan(math.radians(fovy) / 2.0)
    safe = np.where(depth > 1e-9, depth, 1e-9)
    col = width / 2.0 + focal * (rel @ right) / safe
    row = height / 2.0 - focal * (rel @ up) / safe
    return np.stack([col, row], axis=1), depth > 1e-9
