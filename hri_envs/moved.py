"""Old module names that still import, for one release, with a ``DeprecationWarning``.

When a module moves, its old name keeps working for one release: :class:`MovedModules`, a
finder at the front of :data:`sys.meta_path`, answers an import of the old name (or of a
module under it) with the module under its new name, the *same* module object, so that no
state is duplicated, and warns ``"<old> moved to <new>; the old name goes in the next
release"``. An old module whose names went to several modules (:class:`Scattered`) is
answered by a module that forwards each name to where it is now.

:mod:`hri_envs` registers its old names, :mod:`hri_bench` the benchmark's; CHANGELOG.md lists
them under "Deprecated". The new modules are named by strings and imported only when an old
name is, so a package that registers its old names imports nothing above itself.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["MovedModules", "Scattered", "old_names", "register"]


@dataclass(frozen=True)
class Scattered:
    """An old module whose public names went to more than one module.

    Attributes:
        home: The module most of them went to; a name not in ``elsewhere`` is looked up
            there.
        elsewhere: The others, old name -> ``"module:attribute"``.
        public: The old module's ``__all__``.
    """

    home: str
    elsewhere: Mapping[str, str] = field(default_factory=dict)
    public: Sequence[str] = ()

    def where(self, name: str) -> tuple[str, str]:
        """(module, attribute) that old name ``name`` is now."""
        module, _, attr = self.elsewhere.get(name, f"{self.home}:{name}").partition(":")
        return module, attr

    def description(self) -> str:
        """Where the names went, for the warning."""
        moved = ", ".join(f"{name} is {'.'.join(self.where(name))}" for name in self.elsewhere)
        return self.home + (f" ({moved})" if moved else "")


class _Alias(importlib.abc.Loader):
    """Loads an old name as the module under its new name: imported there, not copied."""

    def __init__(self, new: str) -> None:
        self.new = new
        self._own_spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        module = importlib.import_module(self.new)
        self._own_spec = module.__spec__
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        # The import system has set the old name's spec on the module; give it its own back.
        module.__spec__ = self._own_spec


class _Forward(importlib.abc.Loader):
    """Loads an old name as a module that looks each of its names up where it is now."""

    def __init__(self, scattered: Scattered) -> None:
        self.scattered = scattered

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None  # a plain module

    def exec_module(self, module: types.ModuleType) -> None:
        scattered = self.scattered

        def __getattr__(name: str) -> Any:  # noqa: N807 (a module's __getattr__)
            where, attr = scattered.where(name)
            return getattr(importlib.import_module(where), attr)

        def __dir__() -> list[str]:  # noqa: N807
            return sorted({*scattered.public, *scattered.elsewhere})

        vars(module).update(__getattr__=__getattr__, __dir__=__dir__,
                            __all__=list(scattered.public))


class MovedModules(importlib.abc.MetaPathFinder):
    """Finds old module names: ``moved`` maps each old name to its new one (a package's
    modules follow it) or to a :class:`Scattered`.
    """

    def __init__(self, moved: Mapping[str, str | Scattered]) -> None:
        self.moved = dict(moved)

    def new_name(self, fullname: str) -> str | Scattered | None:
        """What ``fullname`` is now (None: it did not move)."""
        if fullname in self.moved:
            return self.moved[fullname]
        head, _, _ = fullname.rpartition(".")
        while head:
            new = self.moved.get(head)
            if isinstance(new, str):
                return new + fullname[len(head):]
            head, _, _ = head.rpartition(".")
        return None

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: types.ModuleType | None = None
                  ) -> importlib.machinery.ModuleSpec | None:
        """A spec loading the module ``fullname`` is now, with the warning; None for a name
        that did not move.
        """
        new = self.new_name(fullname)
        if new is None:
            return None
        where = new.description() if isinstance(new, Scattered) else new
        warnings.warn(f"{fullname} moved to {where}; the old name goes in the next release",
                      DeprecationWarning, stacklevel=2)
        loader = _Forward(new) if isinstance(new, Scattered) else _Alias(new)
        return importlib.machinery.ModuleSpec(fullname, loader)


def old_names(package: str, home: str, names: Sequence[str]) -> Callable[[str], Any]:
    """The ``__getattr__`` of a package that took the name of a module that moved: the old
    module's public ``names`` are looked up in ``home``, with the warning.

    A module whose new place is a package of the same name cannot be redirected by
    :class:`MovedModules` (the name is the package's now); its names can.
    """
    def __getattr__(name: str) -> Any:  # noqa: N807 (a module's __getattr__)
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        warnings.warn(f"{package}.{name} moved to {home}.{name}; the old name goes in the "
                      f"next release", DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(home), name)

    return __getattr__


def register(moved: Mapping[str, str | Scattered]) -> MovedModules:
    """Put a finder for ``moved`` at the front of :data:`sys.meta_path` (before the finder
    that would load a moved package's old modules a second time from its new folder).
    """
    finder = MovedModules(moved)
    sys.meta_path[:] = [f for f in sys.meta_path  # once, when a package is imported again
                        if not (isinstance(f, MovedModules) and f.moved == finder.moved)]
    sys.meta_path.insert(0, finder)
    return finder
