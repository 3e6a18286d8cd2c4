"""The physics backend's compiled kernels (numba): one cache per version of their sources.

numba's ``cache=True`` keeps a compiled function on disk and compiles it anew when *its own*
source file changes, not when a function it calls from another file does: a cached caller
would go on running the old code of an edited callee. The kernels call each other
across modules (:mod:`~hri_envs.physics.scene.lawmath` from the laws, the laws from the
continuous envs' :mod:`~hri_envs.physics.carry.stages`), so :func:`kernel` compiles with
``cache=True`` into a directory named by a hash of all of :data:`SOURCES` (this file among
them): editing any of them starts a fresh cache, compiled once (about 25 s of one core;
``make test`` does it beside mypy: :func:`hri_envs.physics.carry.stages.preload`).

The cache lives in ``hri_envs/physics/scene/__pycache__/kernels-<hash>`` (or, when that is not
writable, in ``$XDG_CACHE_HOME/hri_envs`` or ``~/.cache/hri_envs``), or under
``NUMBA_CACHE_DIR`` when it is set.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from typing import Any, TypeVar, cast

from numba import njit
from numba.core import config as _config

__all__ = ["SOURCES", "cache_dir", "kernel"]

#: The modules whose functions are compiled with :func:`kernel` (or that compiled code calls
#: into MuJoCo through), and this one; paths under ``hri_envs/physics``.
SOURCES: tuple[str, ...] = ("scene/lawmath.py", "scene/laws.py", "scene/jit.py",
                            "carry/human/laws.py", "carry/stages.py", "carry/interaction.py",
                            "carry/mjc.py", "carry/rules.py")
_F = TypeVar("_F", bound=Callable[..., Any])


def _writable(path: str) -> bool:
    try:
        os.makedirs(path, exist_ok=True)
    except OSError:
        return False
    return os.access(path, os.W_OK)


def cache_dir() -> str:
    """Where the kernels of the current sources are cached."""
    here = os.path.dirname(os.path.abspath(__file__))
    physics = os.path.dirname(here)
    digest = hashlib.sha256()
    for name in SOURCES:
        with open(os.path.join(physics, name), "rb") as f:
            digest.update(f.read())
    tag = "kernels-" + digest.hexdigest()[:16]
    if os.environ.get("NUMBA_CACHE_DIR"):
        return os.path.join(os.environ["NUMBA_CACHE_DIR"], "hri_envs", tag)
    path = os.path.join(here, "__pycache__", tag)
    if _writable(path):
        return path
    home = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(home, "hri_envs", tag)


_CACHE_DIR = cache_dir()


def kernel(fn: _F) -> _F:
    """``numba.njit(cache=True)``, cached in :func:`cache_dir`."""
    config = cast(Any, _config)  # numba's settings (NUMBA_CACHE_DIR), set at its import
    previous = config.CACHE_DIR
    config.CACHE_DIR = _CACHE_DIR  # read by numba's cache locator when caching is enabled
    try:
        return cast(_F, njit(cache=True)(fn))
    finally:
        config.CACHE_DIR = previous
