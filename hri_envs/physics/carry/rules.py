"""How a continuous step ends, written once over a leading axis of worlds: its faults, the
too-weak strain timer and the placement.

What :meth:`~hri_envs.physics.carry.sim.CarrySim.step` decides after its control periods,
as functions of ``(R, ...)`` arrays (R worlds: one on the C backend,
:mod:`~hri_envs.physics.carry.faults` and :class:`~hri_envs.physics.carry.sim.CarrySim`; the
worlds that step on MuJoCo Warp, :class:`~hri_envs.physics.carry.warp.worlds.WarpCarryWorlds`).
What they are fed (contacts, the handle's offset, the arm's greatest lift) is measured by
each backend; the rules and the fault messages are here only:

* :func:`fault_codes`: per world, ``dropped`` (the object touched the floor, or fell more
  than :data:`DROP_BELOW_M` below the lowest support), ``unstable`` (the state is not
  finite) or ``slipped`` (the handle :data:`SLIP_M` or :data:`SLIP_RAD` off the hand's
  grip), in that order; :func:`fault_message` words each code (:func:`fault_messages`
  each world's), :func:`slip_reason` says why the handle slipped;
* :func:`strain_update` (:func:`strain_timers`): a human who carries the object alone and
  has pushed at their strength limit for :data:`STRAINED_S` without moving it is
  ``too_weak`` if their arm cannot lift the object's weight;
* :func:`calm_update`: an object held by a seat, off its start and slow for :data:`CALM_S`
  is placed on that seat.

The per-world rules are compiled (:func:`~hri_envs.physics.scene.jit.kernel`, as the laws of
:mod:`~hri_envs.physics.scene.laws`: outputs into arrays given last): on the C backend they run
every step for one world, where numpy's cost per call would show (about 17 µs a step in
numpy, 5 µs compiled, of about 0.9 ms); the texts are Python.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from hri_envs.physics.carry.stages import PERIODS
from hri_envs.physics.scene.jit import kernel

__all__ = ["CALM_S", "DROP_BELOW_M", "FAULT_FELL", "FAULT_FLOOR", "FAULT_NONE",
           "FAULT_SLIPPED", "FAULT_TOO_WEAK", "FAULT_UNSTABLE", "MOVED_M", "SLIP_M", "SLIP_RAD",
           "STRAINED_S", "calm_update", "fault_codes", "fault_message", "fault_messages",
           "saturated_joints", "slip_reason", "strain_timers", "strain_update"]

#: [m], [rad]: the handle has left the hand when this far off, or turned, from its grip.
SLIP_M, SLIP_RAD = 0.03, 0.5
#: [m] the object this far below the lowest support point: dropped.
DROP_BELOW_M = 0.15
#: [s] at the strength limit without moving the object: too weak.
STRAINED_S = 1.0
#: [m] the object moved less than this in a step: not moved (the strain timer runs).
MOVED_M = 1e-3
#: [s] a placed object stays slow this long (squared speeds below
#: :data:`~hri_envs.physics.carry.stages.VEL_SQ_MAX`, ``ANGVEL_SQ_MAX``).
CALM_S = 0.15

#: A world's fault code (:func:`fault_codes`): none, the object hit the floor, it fell
#: below every support, the simulation diverged, the handle slipped out of the human's
#: hand, the human cannot carry the object alone (:func:`strain_update`).
FAULT_NONE, FAULT_FLOOR, FAULT_FELL, FAULT_UNSTABLE, FAULT_SLIPPED, FAULT_TOO_WEAK = range(6)


@kernel
def fault_codes(floor: np.ndarray, z: np.ndarray, lowest_z: np.ndarray, finite: np.ndarray,
                off: np.ndarray, angle: np.ndarray, codes: np.ndarray) -> None:
    """Each world's fault at the end of a step's control periods into ``codes``: the first
    that holds of ``FAULT_FLOOR``, ``FAULT_FELL``, ``FAULT_UNSTABLE``, ``FAULT_SLIPPED``
    (else ``FAULT_NONE``).

    Args:
        floor: (R,) bool, the object touches the floor.
        z: (R,) the object's height [m].
        lowest_z: (R,) the lowest support point of each world's layout [m].
        finite: (R,) bool, the state is finite.
        off: (R,) how far the handle is off the hand's grip [m]
            (:func:`~hri_envs.physics.scene.laws.handle_slip`).
        angle: (R,) how far it is turned from the grip [rad].
        codes: (R,) int, the codes.
    """
    for r in range(codes.shape[0]):
        if floor[r]:
            codes[r] = FAULT_FLOOR
        elif z[r] < lowest_z[r] - DROP_BELOW_M:
            codes[r] = FAULT_FELL
        elif not finite[r]:
            codes[r] = FAULT_UNSTABLE
        elif off[r] > SLIP_M or angle[r] > SLIP_RAD:
            codes[r] = FAULT_SLIPPED
        else:
            codes[r] = FAULT_NONE


def fault_message(code: int, off: float = 0.0, angle: float = 0.0, robot_holds: bool = True,
                  why: str = "") -> str:
    """The fault text of a world's code, ``"<kind>: <detail>"``.

    Args:
        code: The world's fault (:func:`fault_codes`, or ``FAULT_TOO_WEAK``), not
            ``FAULT_NONE``.
        off: A slip's offset [m].
        angle: A slip's turn [rad].
        robot_holds: The robot holds the object (a slip is ``slipped``; else ``dropped``).
        why: A slip's or a too-weak human's reason (:func:`slip_reason`).
    """
    if code == FAULT_FLOOR:
        return "dropped: the object hit the floor"
    if code == FAULT_FELL:
        return "dropped: the object fell below every support"
    if code == FAULT_UNSTABLE:
        return "unstable: the simulation diverged"
    if code == FAULT_SLIPPED:
        kind = "slipped" if robot_holds else "dropped"
        return (f"{kind}: the handle slipped out of the human's hand "
                f"({off * 100:.1f} cm, {math.degrees(angle):.0f}° off); {why}")
    if code == FAULT_TOO_WEAK:
        return "too_weak: the human cannot carry the object alone; " + why
    raise ValueError(f"no fault text for the code {code!r}; allowed: {FAULT_FLOOR} to "
                     f"{FAULT_TOO_WEAK}")


def fault_messages(codes: np.ndarray, off: np.ndarray, angle: np.ndarray,
                   robot_holds: np.ndarray, why: Callable[[int], str]) -> list[str | None]:
    """Each world's fault text (:func:`fault_message`) of its code (:func:`fault_codes`),
    None for ``FAULT_NONE``; ``why(j)`` the reason of the world at position ``j`` whose
    handle slipped (asked of those only).
    """
    return [None if c == FAULT_NONE else fault_message(
        c, float(off[j]), float(angle[j]), bool(robot_holds[j]),
        why(j) if c == FAULT_SLIPPED else "") for j, c in enumerate(codes.tolist())]


def saturated_joints(names: Sequence[str], counts: np.ndarray, above: float) -> list[str]:
    """The names of the arm joints at their strength limit in more than ``above`` of a
    step's control periods (``counts``: (n,) per joint).
    """
    return [n for n, c in zip(names, counts, strict=True) if c > above]


def slip_reason(robot_holds: bool, lift: float, weight: float, grip_force: float,
                names: Sequence[str], sat_counts: np.ndarray) -> str:
    """Why the handle slipped or the human cannot carry alone: the arm's greatest lift
    ``lift`` [N] against the object's ``weight`` [N] (a human carrying alone), else the grip
    force [N]; the joints at their strength limit in the last step (``sat_counts``).
    """
    sat = ", ".join(saturated_joints(names, sat_counts, 0)) or "none"
    if not robot_holds and lift < weight:
        return (f"the arm can lift at most {lift:.1f} N here, the object weighs "
                f"{weight:.1f} N (joints at their strength limit: {sat})")
    return f"grip force {grip_force:.1f} N; joints at their strength limit: {sat}"


@kernel
def strain_timers(strained: np.ndarray, sat: np.ndarray, start_pos: np.ndarray,
                  end_pos: np.ndarray, dt: float, due: np.ndarray) -> None:
    """The strain timers of worlds whose human carries the object alone, after a step (in
    place), and which have strained for :data:`STRAINED_S` (into ``due``).

    A world strains when some arm joint was at its strength limit in more than half the
    step's control periods and the object moved less than :data:`MOVED_M`; its timer runs
    while it strains and restarts otherwise.

    Args:
        strained: (R,) the timers [s], updated.
        sat: (R, n) per arm joint, in how many control periods it was at its limit.
        start_pos: (R, 3) the object at the step's start.
        end_pos: (R, 3) the object at the step's end.
        dt: The step [s].
        due: (R,) bool, the timer has reached :data:`STRAINED_S`.
    """
    for r in range(strained.shape[0]):
        dx = end_pos[r, 0] - start_pos[r, 0]
        dy = end_pos[r, 1] - start_pos[r, 1]
        dz = end_pos[r, 2] - start_pos[r, 2]
        pushing = False
        for j in range(sat.shape[1]):
            if sat[r, j] > PERIODS / 2:
                pushing = True
        if pushing and math.sqrt(dx * dx + dy * dy + dz * dz) < MOVED_M:
            strained[r] += dt
        else:
            strained[r] = 0.0
        due[r] = strained[r] >= STRAINED_S


def strain_update(strained: np.ndarray, sat: np.ndarray, start_pos: np.ndarray,
                  end_pos: np.ndarray, dt: float, weight: float,
                  max_lift: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """The too-weak rule: (R,) bool, the worlds strained for :data:`STRAINED_S` (their
    timers ``strained`` updated in place by :func:`strain_timers`, whose arguments these
    are) whose arm cannot lift the object's ``weight`` [N]. ``max_lift(positions)`` gives
    the arm's greatest lift [N] of the worlds at those positions in the batch; it is asked
    only of the worlds strained long enough, and not at all if none is.
    """
    weak = np.empty(len(strained), dtype=np.bool_)
    strain_timers(strained, sat, start_pos, end_pos, dt, weak)
    if weak.any():
        due = np.flatnonzero(weak)
        weak[due] = max_lift(due) < weight
    return weak


@kernel
def calm_update(calm: np.ndarray, seat: np.ndarray, left_start: np.ndarray,
                slow: np.ndarray, dt: float, placed: np.ndarray) -> None:
    """The calm timers (in place) and placements after a step.

    An object held by a seat, after it left its start, and slow, stays calm (its timer
    runs; otherwise it restarts); calm for :data:`CALM_S`, it is placed on that seat.

    Args:
        calm: (R,) the timers [s], updated.
        seat: (R,) int, the seat that holds each object (-1: none).
        left_start: (R,) bool, the object has left its start support this episode.
        slow: (R,) bool, the object is slow.
        dt: The step [s].
        placed: (R,) int, the seat each object is placed on (-1: none).
    """
    for r in range(calm.shape[0]):
        if seat[r] >= 0 and left_start[r] and slow[r]:
            calm[r] += dt
            placed[r] = seat[r] if calm[r] >= CALM_S else -1
        else:
            calm[r] = 0.0
            placed[r] = -1
