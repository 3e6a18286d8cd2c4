"""Exceptions raised by the environments; every message says what *is* allowed."""

from __future__ import annotations

__all__ = [
    "ActionError",
    "BackendUnavailableError",
    "ConfigError",
    "HriEnvError",
]


class HriEnvError(Exception):
    """Base class of the environments' exceptions."""


class ConfigError(HriEnvError, ValueError):
    """Invalid environment configuration or reset options."""


class ActionError(HriEnvError, ValueError):
    """An action outside an agent's action space."""


class BackendUnavailableError(ConfigError, NotImplementedError):
    """The requested simulation backend cannot run here (e.g. the MuJoCo extra is missing).

    It is both a :class:`ValueError` (an unusable configuration) and a
    :class:`NotImplementedError`, so either ``except`` clause catches it.
    """
