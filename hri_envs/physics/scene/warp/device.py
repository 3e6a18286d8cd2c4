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

    wp.config.quiet = True  # type: ignore[attr-defined,unused-ignore]
    # Nothing here is differentiated: kernels are compiled without their adjoints (MuJoCo
    # Warp's own modules already are; mink-warp's and any other are not by default).
    wp.config.enable_backward = False  # type: ignore[attr-defined,unused-ignore]
    if hasattr(wp, "LOG_WARNING"):  # no line per module compiled or loaded
        wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)
    wp.init()
    import mink_warp
    import mujoco_warp

    _plain_index_on_the_host()
    return wp, mujoco_warp, mink_warp


def _upper_trid_index(n: int, i: int, j: int) -> int:
    """``mujoco_warp._src.math.upper_trid_index``, the same arithmetic in plain Python."""
    if j < i:
        i, j = j, i
    return (i * (2 * n - i - 1)) // 2 + j


def _plain_index_on_the_host() -> None:
    """MuJoCo Warp's collision driver calls ``upper_trid_index``, a Warp function, from Python
    on every step (about 70 calls per step for this scene), and a Warp function called from
    Python goes through Warp's argument matching: 40 % of a step's time on the CPU device
    (43 against 25 ms per step, one world, measured in this project). The collision modules
    get the same function in plain Python (an integer formula: the contacts do not change);
    they call it on the host only. With CUDA graphs on a GPU the host code runs once anyway.
    """
    from mujoco_warp._src import collision_convex, collision_primitive

    for module in (collision_convex, collision_primitive):
        if hasattr(module, "upper_trid_index"):
            module.upper_trid_index = _upper_trid_index


def kernel_cache_dir() -> str:
    """The folder of Warp's kernel cache in this process."""
    wp, _, _ = require_warp()
    return str(wp.config.kernel_cache_dir)
