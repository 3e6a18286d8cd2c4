"""Where the Franka Emika Panda model comes from, and how it is loaded into an ``MjSpec``.

The Panda's kinematic chain and meshes are read, at run time, from the MJCF shipped inside
the ``gymnasium-robotics`` wheel (``envs/assets/kitchen_franka/franka_assets``, Apache-2.0,
itself derived from Vikash Kumar's ``franka`` model). Nothing is copied into this repository
and nothing is downloaded: the package is located with :mod:`importlib` without importing
it. The chain's position actuators and heavy joint damping are not used; the physics
backend adds its own torque motors (see :mod:`hri_envs.physics.scene.build`).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from hri_envs.errors import BackendUnavailableError, MissingExtraError, install_command

__all__ = ["PANDA_ARM_JOINTS", "PANDA_FINGER_JOINTS", "franka_asset_dir", "panda_xml"]

#: The seven arm joints of the chain, base to wrist.
PANDA_ARM_JOINTS: tuple[str, ...] = tuple(f"robot:panda0_joint{i}" for i in range(1, 8))
#: The two finger slide joints.
PANDA_FINGER_JOINTS: tuple[str, ...] = (
    "robot:panda0_finger_joint1",
    "robot:panda0_finger_joint2",
)


def franka_asset_dir() -> Path:
    """Directory holding ``chain.xml``, ``assets.xml`` and ``meshes/`` of the Panda.

    Raises:
        BackendUnavailableError: gymnasium-robotics is not installed (the message gives the
            install command), or its wheel lacks the Franka assets.
    """
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or spec.origin is None:
        raise MissingExtraError(["gymnasium_robotics"], "the MuJoCo backend's Franka Panda "
                                "model")
    path = Path(spec.origin).parent / "envs" / "assets" / "kitchen_franka" / "franka_assets"
    if not (path / "chain.xml").is_file():
        raise BackendUnavailableError(
            f"gymnasium-robotics at {path.parent.parent.parent} has no Franka Panda assets "
            f"(expected {path / 'chain.xml'}); reinstall it with {install_command(['mujoco'])}",
            field="backend"
        )
    return path


def panda_xml() -> str:
    """An MJCF document with the Panda chain under a body named ``panda_mount``.

    The mount body is placed (and, for the wheel, given prismatic joints) by the scene
    builder; ``chain.xml`` and ``assets.xml`` are included by absolute path.
    """
    root = franka_asset_dir()
    meshdir = os.fspath(root / "meshes")
    return (
        '<mujoco model="panda">'
        f'<include file="{os.fspath(root / "assets.xml")}"/>'
        f'<compiler angle="radian" meshdir="{meshdir}"/>'
        '<worldbody><body name="panda_mount">'
        f'<include file="{os.fspath(root / "chain.xml")}"/>'
        "</body></worldbody></mujoco>"
    )
