"""The library's exceptions, under one root: :class:`HriEnvsError`.

Every message says what *is* allowed. The classes also derive from the built-in exception
callers caught before this module existed (``ValueError``, ``NotImplementedError``,
``RuntimeError``, ``ImportError``), so existing ``except`` clauses keep working::

    HriEnvsError
    ├── ConfigError (ValueError)
    │   ├── BackendUnavailableError (NotImplementedError)
    │   └── DisplayUnavailableError (RuntimeError)
    ├── ActionError (ValueError)
    ├── LearnerStateError (ValueError)
    ├── MissingExtraError (ImportError)
    ├── ResetNeeded (RuntimeError)
    └── PhysicsFault (RuntimeError)
        └── hri_envs.physics.scene.ik.IKFailure

This module imports nothing from the package, so that every layer (down to
:mod:`hri_envs.task`) can use it without import cycles.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable

__all__ = [
    "EXTRA_OF",
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "DisplayUnavailableError",
    "HriEnvsError",
    "LearnerStateError",
    "MissingExtraError",
    "PhysicsFault",
    "ResetNeeded",
    "install_command",
]

#: Top-level module -> the hri-envs extra that installs it (pyproject.toml).
EXTRA_OF: dict[str, str] = {
    "matplotlib": "bench", "tqdm": "bench", "scipy": "bench", "numba": "bench",
    "tyro": "bench", "jsonschema": "bench",
    "mujoco": "mujoco", "mink": "mujoco", "gymnasium_robotics": "mujoco", "imageio": "mujoco",
    "imageio_ffmpeg": "mujoco", "PIL": "mujoco",
    "fastapi": "web", "uvicorn": "web", "pyarrow": "web", "minari": "web", "selenium": "web",
    "stable_baselines3": "rl", "sb3_contrib": "rl", "torch": "rl",
    "ray": "ray",
    "jax": "jax", "jaxlib": "jax", "optax": "jax",
    "warp": "mjwarp", "mujoco_warp": "mjwarp", "mink_warp": "mjwarp",
    "myo_sim": "arm",
}


def _installed(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def install_command(extras: Iterable[str]) -> str:
    """The command that installs ``extras`` into the project's environment, run in the
    hri-envs checkout (the constraints file pins the CPU build of PyTorch).
    """
    return (f".venv/bin/pip install -c constraints.txt -e '.[{','.join(sorted(set(extras)))}]' "
            "(in the hri-envs checkout)")


class HriEnvsError(Exception):
    """Root of every exception the library raises on purpose (``except HriEnvsError``)."""


class ConfigError(HriEnvsError, ValueError):
    """An invalid configuration, argument or reset option.

    Args:
        message: What is wrong and what is allowed.
        field: The offending parameter or field (e.g. ``"human_passive"``), when there is
            one; front ends such as ``hri-bench`` map it to their own option names.
    """

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class ActionError(HriEnvsError, ValueError):
    """An action outside an agent's action space (or of the wrong type or shape)."""


class BackendUnavailableError(ConfigError, NotImplementedError):
    """The requested simulation backend cannot run here (e.g. the MuJoCo extra is missing).

    It is both a :class:`ValueError` (an unusable configuration) and a
    :class:`NotImplementedError`, so either ``except`` clause catches it.
    """


class DisplayUnavailableError(ConfigError, RuntimeError):
    """``render_mode="human"`` cannot open a window here (no display, or no GUI toolkit).

    A :class:`ConfigError` about ``render_mode`` (the message says what to use instead) and a
    :class:`RuntimeError`: the same settings work on a machine with a display.
    """


class LearnerStateError(HriEnvsError, ValueError):
    """A saved learner state cannot be loaded (wrong scenario, corrupted, other format)."""


class MissingExtraError(HriEnvsError, ImportError):
    """A feature needs an optional extra that is not installed; the message names the
    missing packages and gives the command that installs them (:func:`install_command`).

    Args:
        modules: The missing top-level modules (keys of :data:`EXTRA_OF`).
        what: The feature that needs them (e.g. "plotting").
    """

    def __init__(self, modules: Iterable[str], what: str) -> None:
        self.modules = sorted(set(modules))
        extras = [EXTRA_OF.get(m, m) for m in self.modules]
        super().__init__(f"{what} needs {', '.join(self.modules)}: {install_command(extras)}",
                         name=self.modules[0] if self.modules else None)

    @classmethod
    def require(cls, modules: Iterable[str], what: str) -> None:
        """Raise one unless every module of ``modules`` can be imported."""
        missing = [m for m in modules if not _installed(m)]
        if missing:
            raise cls(missing, what)

    @classmethod
    def from_import(cls, exc: ImportError, what: str) -> MissingExtraError | None:
        """The error for a failed import of a package an extra installs (None: another)."""
        name = (getattr(exc, "name", None) or "").split(".")[0]
        return cls([name], what) if name in EXTRA_OF else None


class ResetNeeded(HriEnvsError, RuntimeError):
    """``step()`` was called before ``reset()`` or after the episode ended (Gymnasium's
    ``error.ResetNeeded``): call ``reset()`` first.
    """

    def __init__(self, message: str = "the episode has ended (or never started); call "
                 "reset() before step()") -> None:
        super().__init__(message)


class PhysicsFault(HriEnvsError, RuntimeError):
    """Base of the physics simulation's faults (e.g. :class:`~hri_envs.physics.scene.ik.IKFailure`).

    A :class:`RuntimeError`: the configuration was valid, but the simulation cannot go on.
    """
