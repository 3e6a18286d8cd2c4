"""The environments' exceptions: a re-export of :mod:`hri_envs.errors`.

``HriEnvError`` is the old name of the library's root exception
:class:`~hri_envs.errors.HriEnvsError`, kept as an alias.
"""

from __future__ import annotations

from hri_envs.errors import (
    ActionError,
    BackendUnavailableError,
    ConfigError,
    DisplayUnavailableError,
    HriEnvsError,
)

__all__ = [
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "DisplayUnavailableError",
    "HriEnvError",
    "HriEnvsError",
]


#: The old name of the root exception.
HriEnvError = HriEnvsError
