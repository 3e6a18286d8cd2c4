"""The physics backend's compiled kernels (numba): one cache per version of their sources.

numba's ``cache=True`` keeps a compiled function on disk and compiles it anew when *its own*
source file changes, not when a function it calls from another file does: a cached caller
would go on running the old code of an edited callee. The continuous envs' kernels call
each other across modules (:mod:`~hri_envs.physics.carry.lawmath` from the laws, the laws from
:mod:`~hri_envs.physics.carry.stages`), so :func:`kernel` compiles with ``cache=True``
into a directory named by a hash of all of :data:`SOURCES` (and this file): editing any of
them starts a fresh cache, compiled once (about 25 s of one core; ``make test`` does it
beside mypy: :func:`preload`).

The cache lives in ``hri_envs/physics/__pycache__/kernels-<hash>`` (or, when that is not
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

__all__ = ["SOURCES", "cache_dir", "kernel", "preload"]

#: The modules (in this package) whose functions are compiled with :func:`kernel`.
SOURCES: tuple[str, ...] = ("lawmath.py", "laws.py", "human/laws.py", "stages.py",
                            "interaction.py", "mjc.py")
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
    digest = hashlib.sha256()
    for name in (*SOURCES, os.path.basename(__file__)):
        with open(os.path.join(here, name), "rb") as f:
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


def preload() -> None:
    """Compile (or load) the kernels one step of each continuous scenario uses, with the
    torque-driven arm (``make test`` runs it before the tests' processes would each compile
    them at once).
    """
    from hri_envs.physics.carry.env import CarryEnv  # noqa: PLC0415

    for scenario in ("hanger", "wheel"):
        env = CarryEnv(scenario)
        env.reset(seed=0)
        env.sim.human_grip_reference()
        env.step([0.0] * 7)
        env.close()
