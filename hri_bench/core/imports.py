"""``module:Class`` names on the command line: agents and humans of your own.

The module is imported as ``python -m`` would find it: with the current directory on the
path, so that ``hri-bench study ... --agents mypkg.agents:MyAgent`` works from the folder
that holds ``mypkg`` (the console script's own folder is what Python puts first otherwise).
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from typing import Any

from hri_envs.errors import ConfigError

__all__ = ["import_class", "import_object"]


def import_object(spec: str, what: str, field: str) -> Any:
    """The object ``spec`` (``"module:attribute"``) names.

    Args:
        spec: ``module:attribute``.
        what: What it should be, for the message (e.g. "agent").
        field: The :class:`ConfigError` field (the option that named it).

    Raises:
        ConfigError: The module cannot be imported (whatever it raised, a ``SystemExit``
            included) or has no such attribute.
    """
    module, _, attr = spec.partition(":")
    here = os.getcwd()
    if here not in sys.path and "" not in sys.path:
        sys.path.append(here)
    try:
        return getattr(importlib.import_module(module), attr)
    except (Exception, SystemExit) as exc:  # the user's module may raise anything on import
        raise ConfigError(f"cannot import {what} {spec!r}: {type(exc).__name__}: {exc}; give "
                          "'module:Class' with a module importable from the current directory "
                          "or the environment", field=field) from exc


def import_class(spec: str, what: str, field: str, bases: tuple[type, ...]) -> type:
    """The class ``spec`` names (:func:`import_object`), checked to subclass one of ``bases``.

    Raises:
        ConfigError: It cannot be imported, or is not such a class (the message names the
            allowed bases).
    """
    cls = import_object(spec, what, field)
    if not (inspect.isclass(cls) and issubclass(cls, bases)):
        names = " or ".join(f"{b.__module__}.{b.__name__}" for b in bases)
        raise ConfigError(f"{what} {spec!r} is not a subclass of {names}; only subclasses of "
                          "those are allowed", field=field)
    return cls
