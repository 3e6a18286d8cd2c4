"""``module:Class`` names: agents and humans of a user's own, imported by name.

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

__all__ = ["import_class", "import_object", "with_cwd_on_path"]


def with_cwd_on_path() -> None:
    """Put the current folder on ``sys.path`` (last) unless it is there: ``module:Class``
    names the user's own modules "importable from the folder you run in", also when the
    program is a console script (whose ``sys.path[0]`` is the script's folder).
    """
    here = os.getcwd()
    if here not in sys.path and "" not in sys.path:
        sys.path.append(here)


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
    with_cwd_on_path()
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
