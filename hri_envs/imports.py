"""A user's own code, imported by name: ``module:Class`` agents and humans, and the modules
whose import registers scenarios, families, reward rules, agents or backends.

* :func:`import_object`, :func:`import_class`: the object ``module:attribute`` names.
* :func:`import_modules`: modules imported for their registrations (``hri-bench --import
  MODULE``, a study's recorded ``imports``); :func:`imported_modules` lists them in order.
* :func:`load_plugins`: every installed package's entry point of the group
  :data:`PLUGIN_GROUP` (``hri_envs.plugins``), imported the same way; ``hri-bench`` loads
  them when it starts (docs/extending.md, "Your modules in hri-bench").

A module is imported as ``python -m`` would find it: with the current directory on the
path, so that ``hri-bench study ... --agents mypkg.agents:MyAgent`` works from the folder
that holds ``mypkg`` (the console script's own folder is what Python puts first otherwise).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
import os
import re
import sys
from collections.abc import Iterable
from typing import Any

from hri_envs.errors import ConfigError

__all__ = ["PLUGIN_GROUP", "import_class", "import_modules", "import_object",
           "imported_modules", "load_plugins", "with_cwd_on_path"]

#: The entry point group of installed packages' registrations (``[project.entry-points.
#: "hri_envs.plugins"]``): each entry names a module whose import registers (or a function
#: of one, called without arguments).
PLUGIN_GROUP = "hri_envs.plugins"
#: A dotted module name.
_MODULE = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")
#: The modules imported for their registrations, in order (:func:`imported_modules`).
_IMPORTED: list[str] = []
#: The entry points :func:`load_plugins` loaded (``name = value``); None: not looked yet.
_PLUGINS: list[str] | None = None


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


def import_modules(names: Iterable[str], field: str = "imports") -> tuple[str, ...]:
    """Import each module of ``names`` for its registrations (``register_scenario``,
    ``register_family``, ``register_reward_rule``, ``register_agent``, ``register_backend``)
    and remember it (:func:`imported_modules`); a module imported so before is not again.

    Args:
        names: Dotted module names, importable from the current folder or the environment.
        field: The :class:`ConfigError` field (the parameter that named them).

    Returns:
        ``names`` as a tuple.

    Raises:
        ConfigError: A name is not a dotted module name, or its module cannot be imported
            (whatever it raised, a ``SystemExit`` included; the message names it).
    """
    if isinstance(names, str) or not isinstance(names, Iterable):
        raise ConfigError(f"{field} must be a list of module names (e.g. ['mylab.humans']), "
                          f"got {names!r}", field=field)
    names = tuple(names)
    for name in names:
        if not isinstance(name, str) or not _MODULE.fullmatch(name):
            raise ConfigError(f"{field} must name modules (dotted names such as "
                              f"'mylab.humans'), got {name!r}", field=field)
        if name in _IMPORTED:
            continue
        with_cwd_on_path()
        try:
            importlib.import_module(name)
        except (Exception, SystemExit) as exc:  # the user's module may raise anything
            raise ConfigError(f"cannot import module {name!r}: {type(exc).__name__}: {exc}; "
                              "give a module importable from the current folder or the "
                              "environment", field=field) from exc
        _IMPORTED.append(name)
    return names


def imported_modules() -> tuple[str, ...]:
    """The modules imported for their registrations so far (:func:`import_modules`,
    :func:`load_plugins`), in order: what a study records to be replayed.
    """
    return tuple(_IMPORTED)


def load_plugins() -> tuple[str, ...]:
    """Load every installed package's entry point of the group :data:`PLUGIN_GROUP`, once
    per process: each names a module, imported for its registrations (as
    :func:`import_modules`, and listed by :func:`imported_modules`), or a function of one
    (``"mylab.plugin:register"``), called without arguments.

    Returns:
        The entry points loaded by this process, as ``"name = value"``.

    Raises:
        ConfigError: An entry point cannot be loaded, or its function raised (the message
            names it and its distribution; ``field="plugins"``).
    """
    global _PLUGINS
    if _PLUGINS is not None:
        return tuple(_PLUGINS)
    loaded_now: list[str] = []
    for entry in sorted(importlib.metadata.entry_points(group=PLUGIN_GROUP),
                        key=lambda e: (e.name, e.value)):
        dist = getattr(getattr(entry, "dist", None), "name", None)
        where = f"entry point {entry.name} = {entry.value} of the group {PLUGIN_GROUP!r}" + (
            f", from {dist}" if dist else "")
        try:
            loaded = entry.load()
            if entry.attr and callable(loaded):
                loaded()
        except (Exception, SystemExit) as exc:  # an installed package may raise anything
            raise ConfigError(f"cannot load the plugin ({where}): {type(exc).__name__}: "
                              f"{exc}; fix or uninstall it", field="plugins") from exc
        if entry.module not in _IMPORTED:
            _IMPORTED.append(entry.module)
        loaded_now.append(f"{entry.name} = {entry.value}")
    _PLUGINS = loaded_now
    return tuple(_PLUGINS)
