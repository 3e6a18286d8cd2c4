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
    └── PhysicsFault (RuntimeError)
        └── hri_envs.physics.ik.IKFailure

This module imports nothing from the package, so that every layer (down to
:mod:`hri_envs.task`) can use it without import cycles.
"""

from __future__ import annotations

__all__ = [
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "DisplayUnavailableError",
    "HriEnvsError",
    "LearnerStateError",
    "MissingExtraError",
    "PhysicsFault",
]


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
    """A feature needs an optional extra that is not installed; the message gives the
    ``pip install 'hri-envs[EXTRA]'`` command.
    """


class PhysicsFault(HriEnvsError, RuntimeError):
    """Base of the physics simulation's faults (e.g. :class:`~hri_envs.physics.ik.IKFailure`).

    A :class:`RuntimeError`: the configuration was valid, but the simulation cannot go on.
    """
