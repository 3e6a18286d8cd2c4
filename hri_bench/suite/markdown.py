"""Text from files and users, made safe in the leaderboards' Markdown.

Agent names (``module:Class``, ``sb3:PATH``), submission names, file names, population and
track names come from users or files: every leaderboard text (``hri-bench suite`` v1, v2,
v3, ``hri-bench leaderboard``) puts them through :func:`escape` (or :func:`code`), so that
none can start a heading, close a table row, or inject HTML (``<img>``). The names of the
project's own agents and tracks contain none of the characters it changes, so they read as
before.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["code", "escape", "number", "with_ci"]


def escape(text: object) -> str:
    """``text`` safe in a Markdown table cell, heading or list item: no markup, no new rows
    or lines, no HTML (backslash, ``|`` and ``#`` escaped, ``<`` and ``>`` as entities, a
    backtick as ``'``, line breaks as spaces).
    """
    return (str(text).replace("\\", "\\\\").replace("|", "\\|").replace("<", "&lt;")
            .replace(">", "&gt;").replace("`", "'").replace("\r", " ").replace("\n", " ")
            .replace("#", "\\#"))


def code(text: object) -> str:
    """``text`` as inline code: :func:`escape`, in backticks."""
    return f"`{escape(text)}`"


def number(x: float | None, digits: int = 3) -> str:
    """A leaderboard's number: ``digits`` decimals, "–" for None."""
    return "–" if x is None else f"{x:.{digits}f}"


def with_ci(entry: Mapping[str, Any] | None, stat: str = "mean") -> str:
    """An entry's ``stat`` ("mean": its ``ci95``; "iqm": its ``iqm_ci95``) with its 95 % CI,
    "value [low, high]"; "n/a" for no entry.
    """
    if entry is None:
        return "n/a"
    lo, hi = entry["iqm_ci95" if stat == "iqm" else "ci95"]
    return f"{number(entry[stat])} [{number(lo)}, {number(hi)}]"
