"""Worlds a vector env has built, handed to the single envs it builds from them.

A vector env on MuJoCo Warp steps N worlds together, but builds its N envs with the single
env's constructor, which would make a one-world simulation each. Within
:meth:`Handout.sharing`, the constructor takes the vector env's worlds instead, in order.
The handout is per thread, so envs built meanwhile in another thread make their own.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Generic, TypeVar

__all__ = ["Handout"]

T = TypeVar("T")


class Handout(Generic[T]):
    """Simulations handed out in order within :meth:`sharing` (this thread only)."""

    def __init__(self) -> None:
        self._local = threading.local()

    @contextmanager
    def sharing(self, sims: Sequence[T]) -> Iterator[None]:
        """Within the block, :meth:`take` returns ``sims`` one after the other."""
        self._local.sims = list(sims)
        try:
            yield
        finally:
            self._local.sims = []

    def take(self) -> T | None:
        """The next simulation handed out, or None outside :meth:`sharing` (or once all are
        taken): build your own.
        """
        sims: list[T] = getattr(self._local, "sims", [])
        return sims.pop(0) if sims else None
