"""What the object and the supports look like in the scene, and what they collide with.

A scenario's physical design names its :class:`SceneShapes` (``PhysicsDesign.shapes``), so
the scene builder (:mod:`hri_envs.physics.scene.build`) never asks which scenario it builds:
:class:`HangerShapes` (a wire hanger, hook bars, a peg and a rail) and :class:`WheelShapes`
(a wheel's rim, plates on posts, a rack's peg). A new scenario with a physics backend writes
its own subclass.

Collision geometry is invisible (group 3) and only where the scenario's waypoints and
straight-line motions keep clear of it; a resting object is held by its seat
(:mod:`hri_envs.physics.scene.seats`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import mujoco
import numpy as np

from hri_envs.task.geometry import Scenario, Support

__all__ = ["DARK", "GREY", "HangerShapes", "SceneShapes", "WheelShapes", "add_visual"]

_WIRE, GREY, DARK = (0.85, 0.6, 0.2, 1.0), (0.6, 0.6, 0.62, 1.0), (0.3, 0.3, 0.33, 1.0)
_HANGER_BRACKET_M = 0.22  # [m] below a hanger bar, the upper post without collision geometry
_STAND_POST_BELOW_M = 0.05  # [m] a wheel stand's post ends this far below the lowest rim
_CAPSULE, _CYLINDER, _BOX = (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
                             mujoco.mjtGeom.mjGEOM_BOX)


def add_visual(body: mujoco.MjsBody, **kwargs: object) -> mujoco.MjsGeom:
    """A geom that is only seen (it collides with nothing)."""
    return body.add_geom(contype=0, conaffinity=0, **kwargs)


class SceneShapes(ABC):
    """The scenario-specific geometry of a scene, added in the builder's order.

    ``kw`` are the keyword arguments of every collision geom (contact bits, group, contact
    parameters), given by the builder.
    """

    @abstractmethod
    def object_visuals(self, obj: mujoco.MjsBody, scenario: Scenario) -> None:
        """The object's picture, in the object frame."""

    @abstractmethod
    def object_collision(self, obj: mujoco.MjsBody, scenario: Scenario,
                         kw: dict[str, Any]) -> None:
        """The object's collision geoms (against the floor and the supports)."""

    @abstractmethod
    def support_visuals(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario) -> None:
        """Support ``sup``'s picture, in its (mocap) body's frame at the seat."""

    @abstractmethod
    def support_collision(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario,
                          kw: dict[str, Any]) -> None:
        """Support ``sup``'s collision geoms."""

    def world_visuals(self, spec: mujoco.MjSpec, scenario: Scenario) -> None:
        """Fixed parts joining supports (none by default)."""

    def world_collision(self, spec: mujoco.MjSpec, scenario: Scenario,
                        kw: dict[str, Any]) -> None:
        """Their collision geoms (none by default)."""


def _hanger_bar(sup: Support) -> tuple[np.ndarray, np.ndarray]:
    """A hanger support's bar in its body frame: (post end, free end) [m].

    The bar points from the post (12 cm behind the seat) out towards the mounting waypoint
    and ends 4 cm past the seat, 1.2 cm below it (the hook rests on its top).
    """
    out = sup.mounting - sup.position
    d = np.array([out[0], out[1], 0.0])
    d /= max(float(np.linalg.norm(d)), 1e-9)
    below = np.array([0.0, 0.0, 0.012])
    return -0.12 * d - below, 0.04 * d - below


def _rail(scenario: Scenario) -> list[float]:
    """The rail joining B and C (fromto [m], world frame)."""
    b, c = scenario.supports[1].position, scenario.supports[2].position
    ext = (c - b) / np.linalg.norm(c - b) * 0.08
    return [*(b - ext - [0, -0.03, 0.012]), *(c + ext - [0, -0.03, 0.012])]


class HangerShapes(SceneShapes):
    """A wire hanger on hook bars (B, C, on a rail) and a peg (A), each on a post."""

    def object_visuals(self, obj: mujoco.MjsBody, scenario: Scenario) -> None:
        """The wire: hook, neck, shoulders and bar (object frame: x up, the plane x-y)."""
        wire = [
            (0.0, 0.0, 0.0, 0.02, 0.0, 0.03), (0.02, 0.0, 0.03, 0.0, 0.0, 0.05),
            (0.0, 0.0, 0.0, -0.08, 0.0, 0.0), (-0.08, 0.0, 0.0, -0.16, -0.2, 0.0),
            (-0.08, 0.0, 0.0, -0.16, 0.2, 0.0), (-0.16, -0.2, 0.0, -0.16, 0.2, 0.0),
        ]
        for seg in wire:
            add_visual(obj, type=_CAPSULE, fromto=list(seg), size=[0.006, 0, 0], rgba=_WIRE)

    def object_collision(self, obj: mujoco.MjsBody, scenario: Scenario,
                         kw: dict[str, Any]) -> None:
        """Its neck (from 4.5 cm below the hook's seat point, so that a seated hook's bar and
        the take-off along it stay clear), shoulders and bar; the hook itself is left to the
        seat law.
        """
        for seg in ((-0.045, 0.0, 0.0, -0.08, 0.0, 0.0), (-0.08, 0.0, 0.0, -0.16, -0.2, 0.0),
                    (-0.08, 0.0, 0.0, -0.16, 0.2, 0.0), (-0.16, -0.2, 0.0, -0.16, 0.2, 0.0)):
            obj.add_geom(type=_CAPSULE, fromto=list(seg), size=[0.01, 0, 0], **kw)

    def support_visuals(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario) -> None:
        """The bar and the post down to the floor."""
        z = sup.position[2]
        a, b = _hanger_bar(sup)
        add_visual(body, type=_CYLINDER, fromto=[*a, *b], size=[0.01, 0, 0], rgba=GREY)
        add_visual(body, type=_BOX, pos=[*(a - [0, 0, z / 2]), ], size=[0.02, 0.02, z / 2],
                   rgba=DARK)

    def support_collision(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario,
                          kw: dict[str, Any]) -> None:
        """The bar up to the seat and the post's lower part."""
        z = sup.position[2]
        a, _ = _hanger_bar(sup)
        # The bar up to the seat (the picture's free tip beyond it is left out: at A the
        # hanger hangs in the bar's plane, and its wire, turned a little by the human's
        # hand, caught on a longer bar when moved down its column, which the scenario's
        # waypoints assume clear).
        tip = -np.array([0.0, 0.0, 0.012])
        body.add_geom(name=f"{body.name}_bar", type=_CAPSULE, fromto=[*a, *tip],
                      size=[0.01, 0, 0], **kw)
        # The post's lower part only: at A the hanger hangs in the plane of its peg, and
        # its shoulders would cross the upper post (the bracket is left out).
        low = z - _HANGER_BRACKET_M
        body.add_geom(name=f"{body.name}_post", type=_BOX, pos=list(a - [0, 0, z - low / 2]),
                      size=[0.02, 0.02, low / 2], **kw)

    def world_visuals(self, spec: mujoco.MjSpec, scenario: Scenario) -> None:
        """The rail joining B and C."""
        add_visual(spec.worldbody, type=_CYLINDER, fromto=_rail(scenario), size=[0.01, 0, 0],
                   rgba=GREY)

    def world_collision(self, spec: mujoco.MjSpec, scenario: Scenario,
                        kw: dict[str, Any]) -> None:
        """The rail (a world geom: it never moves)."""
        spec.worldbody.add_geom(name="rail", type=_CAPSULE, fromto=_rail(scenario),
                                size=[0.01, 0, 0], **kw)


class WheelShapes(SceneShapes):
    """A wheel's rim, stands (a plate on a post) and a rack (a peg through the hub)."""

    def object_visuals(self, obj: mujoco.MjsBody, scenario: Scenario) -> None:
        """The disc, the hub and the rim as 16 capsules."""
        radius = scenario.object_radius
        add_visual(obj, type=_CYLINDER, size=[radius, 0.02, 0], rgba=(0.15, 0.15, 0.15, 0.35))
        add_visual(obj, type=_CYLINDER, size=[0.06, 0.04, 0], rgba=GREY)
        n = 16
        ang = np.linspace(0.0, 2 * np.pi, n + 1)
        for a0, a1 in zip(ang[:-1], ang[1:], strict=True):
            seg = [radius * np.cos(a0), radius * np.sin(a0), 0, radius * np.cos(a1),
                   radius * np.sin(a1), 0]
            add_visual(obj, type=_CAPSULE, fromto=seg, size=[0.03, 0, 0],
                       rgba=(0.1, 0.1, 0.1, 1.0))

    def object_collision(self, obj: mujoco.MjsBody, scenario: Scenario,
                         kw: dict[str, Any]) -> None:
        """The rim as 16 capsules (the hub is open, so the rack's peg passes through it; a
        lying wheel's rim is outside a stand's plate).
        """
        r, n = scenario.object_radius, 16
        ang = np.linspace(0.0, 2 * np.pi, n + 1)
        for a0, a1 in zip(ang[:-1], ang[1:], strict=True):
            obj.add_geom(type=_CAPSULE, size=[0.02, 0, 0], fromto=[
                r * np.cos(a0), r * np.sin(a0), 0, r * np.cos(a1), r * np.sin(a1), 0], **kw)

    def support_visuals(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario) -> None:
        """A stand: plate under the lying wheel, post to the floor; the rack: a peg through
        the hub from a post behind the wheel.
        """
        z = sup.position[2]
        if sup.blocks_below:
            add_visual(body, type=_CYLINDER, pos=[0, 0, -0.035], size=[0.22, 0.01, 0],
                       rgba=GREY)
            add_visual(body, type=_CYLINDER, pos=[0, 0, -(z + 0.035) / 2], size=[0.03, z / 2, 0],
                       rgba=DARK)
        else:
            add_visual(body, type=_CYLINDER, fromto=[0, -0.15, 0, 0, 0.12, 0],
                       size=[0.02, 0, 0], rgba=GREY)
            add_visual(body, type=_BOX, pos=[0, -0.17, -z / 2 + 0.1],
                       size=[0.04, 0.02, z / 2 + 0.1], rgba=DARK)

    def support_collision(self, body: mujoco.MjsBody, sup: Support, scenario: Scenario,
                          kw: dict[str, Any]) -> None:
        """A stand's post below the wheel's reach; the rack's peg behind the hanging wheel."""
        z = sup.position[2]
        if sup.blocks_below:
            # The post below the reach of the wheel at any waypoint only (5 cm under the
            # lowest rim): the scenario moves waypoints beneath a stand's top just an object
            # radius + 5 cm aside, joins them to those above by straight lines that sweep the
            # rim over the stand's top, and moves a vertical wheel over to another column
            # through the stands between; so the top (plate, hub holder) and the upper post
            # are left to the seat law.
            top = (float(np.min(scenario.heights)) - scenario.object_radius
                   - _STAND_POST_BELOW_M)
            body.add_geom(name=f"{body.name}_post", type=_CYLINDER, pos=[0, 0, top / 2 - z],
                          size=[0.015, top / 2, 0], **kw)
        else:
            # The peg behind the hanging wheel only: its free end passes through the hub,
            # where the lying wheel at the rack's mounting waypoint also has its rim.
            body.add_geom(name=f"{body.name}_peg", type=_CAPSULE,
                          fromto=[0, -0.15, 0, 0, -0.045, 0], size=[0.02, 0, 0], **kw)
            body.add_geom(name=f"{body.name}_post", type=_BOX, pos=[0, -0.17, -z / 2 + 0.1],
                          size=[0.04, 0.02, z / 2 + 0.1], **kw)
