"""The MuJoCo scene as the page draws it in 3D: the model's visual geoms once, poses per step.

The page of ``hri-bench serve`` draws the server's own compiled model with three.js
(``static/view3d.js``). :func:`describe` turns a model into a JSON document sent once
(``GET /api/scene/KEY``, cached by its content hash ``KEY``): every visible geom (group 0-2,
not transparent) with its body, type, size, pose in its body and colour, and the meshes
those geoms use (the Panda's, from the gymnasium-robotics package the model loads them
from: nothing of them is kept in this repository), their vertices quantised to 16 bits over
each mesh's bounding box and their triangles, both base64. Each step then carries only
:func:`body_poses`: every drawn body's position and orientation (``xpos``, ``xquat``).

The camera (:func:`camera`) is the renderer's fit (:func:`hri_envs.physics.scene.camera.fit_view`:
it looks across the line from the robot to the human and stands back to hold the supports,
the object and both agents, wherever they carry it), made when an episode starts; the
supports' labels are anchored where the renderer puts them (:data:`~hri_envs.physics.
scene.rendering.LABEL_LIFT_M` above each seat).
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from hri_envs.physics.scene.camera import axes, fit_view
from hri_envs.physics.scene.rendering import LABEL_LIFT_M

__all__ = ["DRAWN_GROUPS", "GEOM_TYPES", "body_poses", "camera", "describe", "drawn_bodies",
           "rotation_axis", "scene_key", "view_score"]

#: MuJoCo geom type (``mjtGeom``) -> the name the page draws it by (height fields are
#: not drawn; none of the scenes has one).
GEOM_TYPES: dict[int, str] = {0: "plane", 2: "sphere", 3: "capsule", 4: "ellipsoid",
                              5: "cylinder", 6: "box", 7: "mesh"}
#: Geom groups the page draws (MuJoCo's viewer shows 0-2 by default; the scenes keep
#: collision geometry in group 3 and sensor sites in 4).
DRAWN_GROUPS = 2
#: Decimals of the poses sent each step (0.1 mm, 1e-4 of a quaternion's unit).
POSE_DECIMALS = 4


def _visible(model: Any) -> list[int]:
    """The geoms the page draws: of a drawn group, not transparent, of a drawn type."""
    return [g for g in range(model.ngeom)
            if model.geom_group[g] <= DRAWN_GROUPS and model.geom_rgba[g][3] > 0
            and int(model.geom_type[g]) in GEOM_TYPES]


def drawn_bodies(model: Any) -> list[int]:
    """The bodies (not the world) that carry a drawn geom, in index order: the order of
    :func:`body_poses`.
    """
    return sorted({int(model.geom_bodyid[g]) for g in _visible(model)} - {0})


def _b64(array: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")


def _mesh(model: Any, mesh: int) -> dict[str, Any]:
    """A mesh's vertices (uint16 over its bounding box, little-endian) and triangles."""
    v0, nv = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
    f0, nf = int(model.mesh_faceadr[mesh]), int(model.mesh_facenum[mesh])
    vert = np.asarray(model.mesh_vert[v0:v0 + nv], dtype=np.float64)
    low, high = vert.min(axis=0), vert.max(axis=0)
    span = np.where(high - low > 1e-12, high - low, 1.0)
    quantised = np.round((vert - low) / span * 65535.0).astype("<u2")
    faces = np.asarray(model.mesh_face[f0:f0 + nf])
    index = "<u2" if nv <= 65536 else "<u4"
    return {"offset": low.round(6).tolist(), "scale": (span / 65535.0).tolist(),
            "vertices": _b64(quantised), "faces": _b64(faces.astype(index)),
            "index": "uint16" if index == "<u2" else "uint32"}


def _r(values: Any, digits: int = 6) -> list[float]:
    return [round(float(v), digits) for v in np.asarray(values).ravel()]


def describe(model: Any, *, labels: Sequence[str] = (), rotation_axis: Sequence[float]
             | None = None) -> dict[str, Any]:
    """The JSON document of ``model``'s visual geoms the page builds its 3D scene from.

    Args:
        model: A compiled MuJoCo model (its current geom sizes and colours: a human's body
            written into it changes them).
        labels: The supports' names, for the page's labels.
        rotation_axis: The world axis the task's ``rotate`` turns the object about (the
            page's rotation keys turn the hand's target about it), or None.

    Returns:
        ``{"key", "bodies", "geoms", "meshes", "fovy", "labels", "rotation_axis"}``:
        ``bodies`` the drawn bodies' names in the order of :func:`body_poses`; each geom
        ``{"body"`` (an index into ``bodies``, -1 for the world), ``"type"``, ``"size"``,
        ``"pos"``, ``"quat"`` (w, x, y, z, in its body), ``"rgba"``, and for a mesh
        ``"mesh"`` (an index into ``meshes``)``}``; ``key`` is :func:`scene_key` of the rest.
    """
    import mujoco  # noqa: PLC0415 (the physics extra; its models come with it)

    bodies = drawn_bodies(model)
    index = {b: i for i, b in enumerate(bodies)}
    meshes: list[dict[str, Any]] = []
    mesh_index: dict[int, int] = {}
    geoms = []
    for g in _visible(model):
        kind = GEOM_TYPES[int(model.geom_type[g])]
        geom = {"body": index.get(int(model.geom_bodyid[g]), -1), "type": kind,
                "size": _r(model.geom_size[g]), "pos": _r(model.geom_pos[g]),
                "quat": _r(model.geom_quat[g]), "rgba": _r(model.geom_rgba[g], 3)}
        if kind == "mesh":
            mesh = int(model.geom_dataid[g])
            if mesh not in mesh_index:
                mesh_index[mesh] = len(meshes)
                meshes.append(_mesh(model, mesh))
            geom["mesh"] = mesh_index[mesh]
        geoms.append(geom)
    doc = {"bodies": [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
                      for b in bodies],
           "geoms": geoms, "meshes": meshes, "fovy": float(model.vis.global_.fovy),
           "labels": list(labels),
           "rotation_axis": None if rotation_axis is None else _r(rotation_axis)}
    return {"key": scene_key(doc), **doc}


def scene_key(doc: dict[str, Any]) -> str:
    """The first 20 hex digits of the sha256 of a description without its key."""
    text = json.dumps({k: v for k, v in doc.items() if k != "key"}, sort_keys=True,
                      separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def body_poses(data: Any, bodies: Sequence[int]) -> list[float]:
    """The drawn bodies' poses now, flat: ``x, y, z, qw, qx, qy, qz`` per body, rounded to
    :data:`POSE_DECIMALS`.
    """
    rows = np.concatenate([data.xpos[list(bodies)], data.xquat[list(bodies)]], axis=1)
    return [round(float(v), POSE_DECIMALS) for v in rows.ravel()]


def view_score(model: Any, aspect: float) -> Any:
    """The renderer's judge of a view (:class:`~hri_envs.physics.scene.rendering.ViewScore`: small
    segmented pictures drawn offscreen), or None where MuJoCo has no offscreen OpenGL (then
    :func:`camera` looks from the overview's fixed side).
    """
    try:
        from hri_envs.physics.scene.rendering import ViewScore  # noqa: PLC0415

        return ViewScore(model, aspect)
    except Exception:  # no GL context on this machine: the fixed side
        return None


def camera(model: Any, data: Any, seats: np.ndarray, aspect: float,
           score: Any = None) -> dict[str, Any]:
    """The page's camera for the scene in ``data`` (an episode's start): the renderer's
    overview fitted to the scene (:func:`~hri_envs.physics.scene.camera.fit_view`; its azimuth
    chosen by ``score``, :func:`view_score`, as the renderer chooses it), as an eye, the point
    it looks at and the vertical field of view [deg]; and where the supports' labels are
    anchored.
    """
    seats = np.asarray(seats, dtype=float)
    if score is not None:
        score.data, score.seats = data, seats
    pose = fit_view(model, data, seats, "overview", aspect, score)
    forward = axes(pose.azimuth, pose.elevation)[0]
    eye = np.asarray(pose.lookat) - pose.distance * forward
    return {"eye": _r(eye, 4), "target": _r(pose.lookat, 4),
            "fovy": float(model.vis.global_.fovy),
            "labels": [_r(np.asarray(s) + [0.0, 0.0, LABEL_LIFT_M], 4) for s in seats],
            "seats": [_r(s, 4) for s in seats]}


def rotation_axis(orientations: np.ndarray) -> list[float]:
    """The world axis the scenario's ``rotate`` turns the object about (unit), from its two
    orientations.
    """
    from hri_envs.physics.scene.kinematics import rotation_error  # noqa: PLC0415

    v = rotation_error(np.asarray(orientations[1]), np.asarray(orientations[0]))
    n = float(np.linalg.norm(v))
    return [0.0, 0.0, 1.0] if n < 1e-9 or not math.isfinite(n) else _r(v / n)
