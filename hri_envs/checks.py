"""Type-strict checks of user-given numbers and flags, shared by every layer.

Python lets ``True`` count as 1 and lets ``"3" < 1`` fail with a ``TypeError`` far from
the input; these checks turn both into a :class:`~hri_envs.errors.ConfigError` that names
the field and says what is allowed, before anything is simulated. Nothing is converted
silently: a float is not a whole number (``10.5`` is refused, not truncated), a bool is not
a number, a string is not a number.

Accepted as numbers: ``int``, ``float`` and numpy's integer and floating scalars (not
``bool``, ``np.bool_``, ``complex`` or ``str``).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

import numpy as np

from hri_envs.errors import ActionError, ConfigError

__all__ = ["check_flag", "check_real", "check_whole", "integer_action", "integer_or_none",
           "select_named"]

_T = TypeVar("_T")

_INT64_MIN, _INT64_MAX = int(np.iinfo(np.int64).min), int(np.iinfo(np.int64).max)


def _describe(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_whole(value: Any, field: str, *, minimum: int | None = None,
                maximum: int | None = None, label: str | None = None,
                allowed: str | None = None) -> int:
    """``value`` as an ``int`` if it is a whole number in ``[minimum, maximum]``.

    Args:
        value: An ``int`` or numpy integer (``bool`` and floats such as ``10.0`` are refused).
        field: The parameter's name, set as the error's ``field``.
        minimum: The smallest allowed value (None: no bound).
        maximum: The largest allowed value (None: no bound).
        label: How the message names the value (default: ``field``).
        allowed: The message's description of what is allowed (default: built from the
            bounds, e.g. "a whole number >= 1").

    Raises:
        ConfigError: Anything else; the message names ``label`` and the allowed range.
    """
    ok = isinstance(value, int | np.integer) and not isinstance(value, bool)
    if ok and ((minimum is not None and value < minimum)
               or (maximum is not None and value > maximum)):
        ok = False
    if not ok:
        if allowed is None:
            bounds = [f">= {minimum:,}" if minimum is not None else "",
                      f"<= {maximum:,}" if maximum is not None else ""]
            allowed = " ".join(["a whole number", " and ".join(b for b in bounds if b)]).strip()
        raise ConfigError(f"{label or field} must be {allowed}, got {_describe(value)}",
                          field=field)
    return int(value)


def check_real(value: Any, field: str, *, low: float = -math.inf, high: float = math.inf,
               low_open: bool = False, high_open: bool = False, allow_inf: bool = False,
               label: str | None = None, allowed: str | None = None) -> float:
    """``value`` as a ``float`` if it is a real number in the interval from ``low`` to
    ``high``.

    Args:
        value: An ``int``, ``float`` or numpy integer or floating scalar (not ``bool``).
        field: The parameter's name, set as the error's ``field``.
        low: The interval's lower end.
        high: Its upper end.
        low_open: Exclude ``low`` itself.
        high_open: Exclude ``high`` itself.
        allow_inf: Accept ``inf`` (within the interval); NaN is never accepted.
        label: How the message names the value (default: ``field``).
        allowed: The message's description of what is allowed (default: built from the
            interval, e.g. "a finite number > 0").

    Raises:
        ConfigError: Anything else; the message names ``label`` and what is allowed.
    """
    number = math.nan
    if isinstance(value, int | float | np.integer | np.floating) and not isinstance(
            value, bool | np.bool_):
        number = float(value)
    ok = not math.isnan(number) and (allow_inf or math.isfinite(number))
    ok = ok and (number > low if low_open else number >= low)
    ok = ok and (number < high if high_open else number <= high)
    if not ok:
        if allowed is None:
            if low > -math.inf and high < math.inf:
                allowed = (f"in {'(' if low_open else '['}{low:g}, {high:g}"
                           f"{')' if high_open else ']'}")
            else:
                allowed = "a number" if allow_inf else "a finite number"
                if low > -math.inf:
                    allowed += f" {'>' if low_open else '>='} {low:g}"
                if high < math.inf:
                    allowed += f" {'<' if high_open else '<='} {high:g}"
        raise ConfigError(f"{label or field} must be {allowed}, got {_describe(value)}",
                          field=field)
    return number


def check_flag(value: Any, field: str, *, label: str | None = None) -> bool:
    """``value`` as a ``bool`` if it is ``True`` or ``False`` (or a numpy bool).

    Raises:
        ConfigError: Anything else (``1``, ``"yes"``, None), naming ``label``.
    """
    if not isinstance(value, bool | np.bool_):
        raise ConfigError(f"{label or field} must be True or False, got {_describe(value)}",
                          field=field)
    return bool(value)


def integer_or_none(value: Any) -> int | None:
    """``value`` as an ``int`` if it is an integer that fits int64 (a Python or numpy
    integer, not ``bool``), else None: an action of 0.5, ``True`` or ``"3"`` is None, never
    rounded, read as 1 or parsed (the agents' and humans' action checks build on it).
    """
    if type(value) is int:
        number = value
    elif isinstance(value, bool | np.bool_):
        return None
    else:
        try:
            number = operator.index(value)
        except TypeError:
            return None
    return number if _INT64_MIN <= number <= _INT64_MAX else None


def integer_action(value: Any, who: str, where: str = "") -> int:
    """``value`` as an ``int`` action (:func:`integer_or_none`), or an :class:`ActionError`
    naming ``who`` (e.g. "act() of agent 'x'"), the value and ``where`` (e.g. " for run 3"):
    bool, float and str are refused, not rounded.
    """
    number = integer_or_none(value)
    if number is None:
        raise ActionError(f"{who} returned {_describe(value)} ({type(value).__name__}){where}; "
                          "an action is an integer (int or numpy integer; bool, float and str "
                          "are refused, not rounded)")
    return number


def select_named(table: Mapping[str, _T], names: str | Sequence[str] | None, field: str,
                 what: str, of: str = "") -> list[_T]:
    """The entries of ``table`` that ``names`` names (comma-separated or a list; None: all),
    in ``table``'s order.

    Raises:
        ConfigError: No name, or one not in ``table`` (``field``; the message says ``what``
            they are, ``of`` what, and lists the allowed).
    """
    if names is None:
        return list(table.values())
    wanted = [n.strip() for n in names.split(",")] if isinstance(names, str) else list(names)
    wanted = [n for n in wanted if n]
    unknown = [n for n in wanted if n not in table]
    if unknown or not wanted:
        raise ConfigError(f"unknown {what} {', '.join(map(str, unknown)) or '(none given)'}"
                          f"{of}; allowed: {', '.join(table)}", field=field)
    return [v for k, v in table.items() if k in wanted]
