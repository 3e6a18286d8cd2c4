"""Importing MuJoCo Warp, Warp and mink-warp (the ``mjwarp`` extra), and Warp's kernel cache.

Warp compiles its kernels the first time they run (MuJoCo Warp's step and mink-warp's IK:
about 1.5 minutes of one core for this scene on the CPU device) and keeps them in its kernel
cache, a folder that every later process on the machine reads (a few seconds). The cache is
Warp's own: ``$WARP_CACHE_PATH`` if set, else ``~/.cache/warp/<warp version>``
(:func:`kernel_cache_dir` says which). ``make test`` runs every test that uses this backend in
one process, so a machine without a cache compiles once.
"""

from __future__ import annotations

import importlib.util
from types import ModuleType

from hri_envs.errors import MissingExtraError

__all__ = ["WARP_MODULES", "kernel_cache_dir", "require_warp"]

#: The modules the ``mjwarp`` extra installs.
WARP_MODULES: tuple[str, ...] = ("warp", "mujoco_warp", "mink_warp")


def require_warp() -> tuple[ModuleType, ModuleType, ModuleType]:
    """``(warp, mujoco_warp, mink_warp)``, initialised quietly.

    Raises:
        MissingExtraError: The ``mjwarp`` extra is not installed (with the install command).
    """
    missing = [m for m in WARP_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        raise MissingExtraError(missing, "backend='mjwarp'")
    import warp as wp

    wp.config.quiet = True  # no line per compiled module
    wp.init()
    import mink_warp
    import mujoco_warp

    return wp, mujoco_warp, mink_warp


def kernel_cache_dir() -> str:
    """The folder of Warp's kernel cache in this process."""
    wp, _, _ = require_warp()
    return str(wp.config.kernel_cache_dir)
