"""Optional extras: say in one line which ``pip install`` a missing package needs.

The benchmark's plots and progress bars need the ``bench`` extra, the physics backend
``mujoco``, saved SB3 models ``rl`` and the Ray executor ``ray`` (pyproject.toml). Commands
check what they will need before simulating anything (:func:`require`), and ``hri-bench``
turns a :class:`ModuleNotFoundError` of such a package met later into the same one line
(:func:`install_hint`).
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable

from hri_envs.errors import MissingExtraError

__all__ = ["EXTRA_OF", "install_hint", "require"]

#: Top-level module -> the hri-envs extra that installs it.
EXTRA_OF: dict[str, str] = {
    "matplotlib": "bench", "tqdm": "bench",
    "mujoco": "mujoco", "mink": "mujoco", "gymnasium_robotics": "mujoco", "imageio": "mujoco",
    "stable_baselines3": "rl", "sb3_contrib": "rl", "torch": "rl",
    "ray": "ray",
}


def _installed(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def _message(modules: Iterable[str], what: str) -> str:
    mods = sorted(set(modules))
    extras = sorted({EXTRA_OF[m] for m in mods})
    return (f"{what} needs {', '.join(mods)}: pip install 'hri-envs[{','.join(extras)}]'")


def require(modules: Iterable[str], what: str) -> None:
    """Raise :class:`MissingExtraError` unless every module in ``modules`` is installed.

    Args:
        modules: Top-level module names, keys of :data:`EXTRA_OF`.
        what: The feature that needs them, for the message (e.g. "plotting").
    """
    missing = [m for m in modules if not _installed(m)]
    if missing:
        raise MissingExtraError(_message(missing, what))


def install_hint(exc: ImportError) -> str | None:
    """One line naming the extra for a failed import of a known package, else None."""
    name = (getattr(exc, "name", None) or "").split(".")[0]
    return _message([name], "this command") if name in EXTRA_OF else None
