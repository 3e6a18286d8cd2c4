"""The page's input in a physical task: where the participant leads their hand.

The page answers each frame of a physical session (a ``lead`` view) with ::

    {"type": "hand", "seq": n, "target": [x, y, z, qw, qx, qy, qz], "stiffness": s,
     "input": "mouse", "latency_ms": t}

``target`` is the participant's target for their hand's grip frame (world, metres, a unit
quaternion), ``stiffness`` the impedance scale they ask for (0-1), ``input`` what they moved
the target with since the last frame (:data:`~hri_bench.data.physical.INPUTS`), and
``latency_ms`` the time from sending their last input to receiving the frame it produced,
as the page measured it (null when not measured). :func:`check_hand` validates one
(:func:`hri_bench.people.serve.session.parse_message` calls it).
"""

from __future__ import annotations

import math
from typing import Any

from hri_bench.data.physical import INPUTS
from hri_envs.errors import ConfigError

__all__ = ["FIELDS", "MAX_LATENCY_MS", "MAX_REACH_M", "check_hand"]

#: A hand message's fields (besides ``type``).
FIELDS: tuple[str, ...] = ("seq", "target", "stiffness", "input", "latency_ms")
#: The farthest a target may be from the world's origin [m] (the scenes are a few metres).
MAX_REACH_M = 20.0
#: Latencies above this are not believed.
MAX_LATENCY_MS = 600_000.0


def _number(value: Any) -> bool:
    return type(value) in (int, float) and math.isfinite(value)


def _real(value: Any) -> float | None:
    """``value`` if it is a finite JSON number, else None."""
    return float(value) if _number(value) else None


def check_hand(msg: dict[str, Any], error: type[ConfigError] = ConfigError) -> None:
    """Raise ``error`` naming the field unless ``msg``'s hand fields are valid (the module
    docstring); ``seq`` is checked by the caller.
    """
    target = msg.get("target")
    if not (isinstance(target, list) and len(target) == 7 and all(map(_number, target))):
        raise error("target must be 7 finite numbers: x, y, z [m], qw, qx, qy, qz",
                    field="target")
    if math.hypot(*target[:3]) > MAX_REACH_M:
        raise error(f"target must be within {MAX_REACH_M:g} m of the origin", field="target")
    if not 0.5 <= math.hypot(*target[3:]) <= 2.0:
        raise error("target's quaternion must be a unit quaternion (qw, qx, qy, qz)",
                    field="target")
    stiffness = _real(msg.get("stiffness"))
    if stiffness is None or not 0.0 <= stiffness <= 1.0:
        raise error("stiffness must be a number in [0, 1]", field="stiffness")
    if msg.get("input") not in INPUTS:
        raise error(f"input must be one of {', '.join(INPUTS)}", field="input")
    latency = _real(msg.get("latency_ms"))
    if msg.get("latency_ms") is not None and (latency is None
                                              or not 0 <= latency <= MAX_LATENCY_MS):
        raise error(f"latency_ms must be null or a number of milliseconds in [0, "
                    f"{MAX_LATENCY_MS:.0f}]", field="latency_ms")
