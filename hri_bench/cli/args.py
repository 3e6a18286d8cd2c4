"""Argument types shared by the commands' parsers: a value parsed and checked, with a
message saying what is allowed (exit 2 through argparse).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

__all__ = ["bounded", "whole"]


def bounded(kind: type, allowed: str, ok: Callable[[Any], bool]) -> Callable[[str], Any]:
    """An argparse ``type`` parsing ``kind`` and checking it with ``ok``, with a message
    saying what is ``allowed``.
    """

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {value}")
        return value

    return parse


#: A whole number >= 0 (a seed, a count that may be 0).
whole = bounded(int, "a whole number >= 0", lambda v: v >= 0)
