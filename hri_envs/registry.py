"""One registry for every kind a user can add: scenarios, backends, human families, reward
rules, agents and prefixed populations (docs/extending.md).

Each kind keeps its registry in its own module, as a :class:`Registry` of its spec type, and
its ``register_*`` function is that registry's :meth:`Registry.register`. So every kind has
the same contract:

* :meth:`~Registry.register` takes a spec of the kind's type with a name, runs the kind's
  check on it (the cheap one that must hold before anything uses it; the conformance checks
  of :mod:`hri_envs.conformance` and :mod:`agents.conformance` go further), refuses a name
  that is another spec's unless told ``replace=True``, and returns the spec;
* :meth:`~Registry.get` returns a registered spec, or raises a
  :class:`~hri_envs.errors.ConfigError` naming the registered ones;
* ``name in registry``, iterating (the names, in the order registered), ``len``,
  :meth:`~Registry.names`, :meth:`~Registry.items` read it; :meth:`~Registry.find` is the
  look-up that answers None for an unknown name.

Registering an equal spec under its name again changes nothing (a module imported twice
registers twice), so it is not refused.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from hri_envs.errors import ConfigError

__all__ = ["Registry"]

Spec = TypeVar("Spec")


class Registry(Generic[Spec]):
    """Specs of one kind, by name.

    Args:
        kind: What the specs are, for messages ("scenario", "backend", ...).
        spec_type: The spec's class; :meth:`register` refuses anything else.
        field: The :attr:`~hri_envs.errors.ConfigError.field` of its errors (the keyword
            or option that names one: ``"scenario"``, ``"agents"``, ...).
        check: ``check(spec)`` raises a :class:`ConfigError` for a spec that cannot be
            registered; None: the type and the name are all there is to check.
        key: The spec's attribute that names it (``"name"``; a prefixed population's
            ``"prefix"``).
    """

    def __init__(self, kind: str, spec_type: type[Spec], *, field: str,
                 check: Callable[[Spec], None] | None = None, key: str = "name") -> None:
        self.kind = kind
        self.spec_type = spec_type
        self.field = field
        self.check = check
        self.key = key
        self._specs: dict[str, Spec] = {}

    def register(self, spec: Spec, *, replace: bool = False) -> Spec:
        """Make ``spec`` known by its name; returns it.

        Args:
            spec: A spec of :attr:`spec_type` with a non-empty name.
            replace: Replace a spec registered under the same name (tests, reloads);
                otherwise that is refused.

        Raises:
            ConfigError: ``spec`` is not of the kind's type or has no name, fails the
                kind's check, or its name is another spec's and ``replace`` is False.
        """
        name = getattr(spec, self.key, None) if isinstance(spec, self.spec_type) else None
        if not (isinstance(name, str) and name):
            raise ConfigError(f"a {self.kind} is registered as a {self.spec_type.__name__} "
                              f"with a {self.key}, got {spec!r}", field=self.field)
        old = self._specs.get(name)
        if old is not None and not replace and old != spec:
            raise ConfigError(f"{self.kind} {name!r} is registered already; choose another "
                              f"{self.key}, or pass replace=True to replace it",
                              field=self.field)
        if self.check is not None:
            self.check(spec)
        self._specs[name] = spec
        return spec

    def unregister(self, name: str) -> Spec:
        """Forget ``name`` (a test's own entry); returns its spec.

        Raises:
            ConfigError: ``name`` is not registered.
        """
        spec = self.get(name)
        del self._specs[name]
        return spec

    def get(self, name: str) -> Spec:
        """The spec registered as ``name``.

        Raises:
            ConfigError: ``name`` is not registered; the message lists the names that are.
        """
        spec = self.find(name)
        if spec is None:
            raise ConfigError(f"unknown {self.kind} {name!r}; allowed: {', '.join(self)}",
                              field=self.field)
        return spec

    def find(self, name: object) -> Spec | None:
        """The spec registered as ``name``, None for any other name (or a non-string)."""
        return self._specs.get(name) if isinstance(name, str) else None

    def names(self) -> tuple[str, ...]:
        """The registered names, in the order registered."""
        return tuple(self._specs)

    def items(self) -> list[tuple[str, Spec]]:
        """(name, spec) pairs, in the order registered."""
        return list(self._specs.items())

    def values(self) -> list[Spec]:
        """The specs, in the order registered."""
        return list(self._specs.values())

    def __getitem__(self, name: str) -> Spec:
        return self.get(name)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._specs

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(self._specs))

    def __len__(self) -> int:
        return len(self._specs)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self)})"
