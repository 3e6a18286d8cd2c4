"""The continuous step's end-of-step rules (hri_envs.physics.carry.rules), written once over
a world axis for the C backend (one world) and MuJoCo Warp (N): fed a batch of mixed worlds
directly, each world ends as its rule says, with the exact fault text.
"""

import numpy as np
import pytest

from hri_envs.physics.carry import rules
from hri_envs.physics.carry.rules import (
    CALM_S,
    DROP_BELOW_M,
    FAULT_FELL,
    FAULT_FLOOR,
    FAULT_NONE,
    FAULT_SLIPPED,
    FAULT_TOO_WEAK,
    FAULT_UNSTABLE,
    SLIP_M,
    SLIP_RAD,
    STRAINED_S,
)
from hri_envs.physics.carry.stages import PERIODS

DT = 0.04
WEIGHT = 20.0
NAMES = ("shoulder", "elbow")
#: The batch: 0 dropped (on the floor), 1 slipped (the robot holds), 2 calm and placed on
#: seat 1, 3 strained (carrying alone) for a second: too weak.
DROPPED, SLIPPED, PLACED, STRAINED = range(4)


def _codes(floor, z, lowest_z, finite, off, angle):
    codes = np.full(len(z), -1)
    rules.fault_codes(np.asarray(floor), np.asarray(z, float), np.asarray(lowest_z, float),
                      np.asarray(finite), np.asarray(off, float), np.asarray(angle, float),
                      codes)
    return codes


def _calm(calm, seat, left_start, slow, dt):
    calm, placed = np.array(calm, float), np.full(len(seat), -7)
    rules.calm_update(calm, np.asarray(seat), np.asarray(left_start), np.asarray(slow), dt,
                      placed)
    return calm, placed


def _strain(strained, sat, start, end, dt, weight, lift):
    strained = np.array(strained, float)
    weak = rules.strain_update(strained, sat, start, end, dt, weight, lift)
    return strained, weak


def _end_of_step():
    """One step's end for the batch, as a backend runs it: the fault codes and texts, the
    strain timers of the worlds carrying alone without a fault, the calm timers and
    placements; the arm's greatest lift asked of which worlds."""
    r = 4
    floor = np.array([True, False, False, False])
    z = np.array([0.0, 0.8, 0.75, 0.9])
    lowest_z = np.full(r, 0.7)
    finite = np.ones(r, bool)
    off = np.array([0.0, 0.05, 0.001, 0.002])
    angle = np.array([0.0, 0.2, 0.01, 0.02])
    robot_holds = np.array([True, True, True, False])
    codes = _codes(floor, z, lowest_z, finite, off, angle)
    asked = []

    def why(j):
        asked.append(j)
        return f"why {j}"

    messages = rules.fault_messages(codes, off, angle, robot_holds, why)
    sat = np.zeros((r, len(NAMES)))
    sat[STRAINED, 1] = PERIODS  # the elbow at its limit all the step
    start = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.8], [0.5, 0.5, 0.75], [0.2, 0.3, 0.9]])
    end = start.copy()
    end[STRAINED, 0] += 0.0005  # moved less than MOVED_M
    alone = np.flatnonzero(~robot_holds & (codes == FAULT_NONE))

    def lift(due):
        asked.append(alone[due].tolist())
        return np.full(len(due), 5.0)  # [N], less than the weight

    strained, weak = _strain(np.full(len(alone), STRAINED_S - DT + 1e-9), sat[alone],
                             start[alone], end[alone], DT, WEIGHT, lift)
    seat = np.array([-1, 0, 1, -1])
    left_start = np.ones(r, bool)
    slow = np.array([True, False, True, False])
    calm, placed = _calm([0.0, 0.1, CALM_S - DT + 1e-9, 0.0], seat, left_start, slow, DT)
    return codes, messages, alone, strained, weak, asked, calm, placed


def test_a_batch_of_mixed_worlds_ends_each_by_its_rule():
    codes, messages, alone, strained, weak, asked, calm, placed = _end_of_step()
    assert codes.tolist() == [FAULT_FLOOR, FAULT_SLIPPED, FAULT_NONE, FAULT_NONE]
    assert messages == [
        "dropped: the object hit the floor",
        "slipped: the handle slipped out of the human's hand (5.0 cm, 11° off); why 1",
        None, None]
    assert alone.tolist() == [STRAINED]
    assert strained == pytest.approx([STRAINED_S + 1e-9])
    assert weak.tolist() == [True]
    assert asked == [SLIPPED, [STRAINED]]  # the reason of the slip, the lift of the strained
    too_weak = rules.fault_message(FAULT_TOO_WEAK, why="why 3")
    assert too_weak == "too_weak: the human cannot carry the object alone; why 3"
    assert placed.tolist() == [-1, -1, 1, -1]
    assert calm == pytest.approx([0.0, 0.0, CALM_S + 1e-9, 0.0])


def test_the_first_fault_wins_and_each_has_its_text():
    """Floor before falling before diverging before slipping; a slip while the human carries
    alone is a drop."""
    codes = _codes([True, False, False, False, False, False],
                   [-1.0, -1.0, 1.0, 1.0, 1.0, 1.0], np.zeros(6),
                   [False, False, False, True, True, True], [1.0, 1.0, 1.0, 1.0, 1.0, 0.0],
                   [1.0, 1.0, 1.0, 1.0, 0.0, 1.0])  # the last two: off, turned
    assert codes.tolist() == [FAULT_FLOOR, FAULT_FELL, FAULT_UNSTABLE, FAULT_SLIPPED,
                              FAULT_SLIPPED, FAULT_SLIPPED]
    at = np.array([0.0, 0.0])  # at the limits: no fault yet
    edge = _codes(np.zeros(2, bool), [-DROP_BELOW_M] * 2, at, np.ones(2, bool), [SLIP_M, 0.0],
                  [0.0, SLIP_RAD])
    assert edge.tolist() == [FAULT_NONE, FAULT_NONE]
    assert rules.fault_message(FAULT_FELL) == "dropped: the object fell below every support"
    assert rules.fault_message(FAULT_UNSTABLE) == "unstable: the simulation diverged"
    assert rules.fault_message(FAULT_SLIPPED, 0.0314, 0.6, False, "why") == (
        "dropped: the handle slipped out of the human's hand (3.1 cm, 34° off); why")
    with pytest.raises(ValueError, match="no fault text"):
        rules.fault_message(FAULT_NONE)


def test_the_slip_reason_names_the_lift_or_the_grip():
    counts = np.array([0.0, 2.0])
    assert rules.slip_reason(False, 5.04, 19.62, 40.0, NAMES, counts) == (
        "the arm can lift at most 5.0 N here, the object weighs 19.6 N (joints at their "
        "strength limit: elbow)")
    assert rules.slip_reason(True, 5.04, 19.62, 40.0, NAMES, np.zeros(2)) == (
        "grip force 40.0 N; joints at their strength limit: none")
    assert rules.slip_reason(False, 25.0, 19.62, 40.0, NAMES, counts).startswith("grip force")
    assert rules.saturated_joints(NAMES, np.array([PERIODS / 2, PERIODS / 2 + 1]),
                                  PERIODS / 2) == ["elbow"]


def test_the_strain_timer_runs_only_while_pushing_still():
    """It restarts when the object moved or no joint was at its limit in more than half the
    periods; the arm's lift is asked only of the worlds strained long enough, and one that
    can lift the weight is not too weak."""
    sat = np.zeros((5, 2))
    sat[[0, 1, 2, 4], 0] = PERIODS // 2 + 1
    sat[3, 0] = PERIODS // 2  # half the periods: not straining
    start = np.zeros((5, 3))
    end = np.zeros((5, 3))
    end[2, 2] = rules.MOVED_M  # moved
    before = np.array([STRAINED_S - DT, STRAINED_S, 0.5, 0.5, 0.0])
    assert STRAINED_S - DT + DT == STRAINED_S  # world 0 reaches STRAINED_S exactly
    asked = []

    def lift(due):
        asked.append(due.tolist())
        return np.array([WEIGHT - 1.0, WEIGHT])  # world 0 cannot lift it, world 1 can

    timers, weak = _strain(before, sat, start, end, DT, WEIGHT, lift)
    assert timers.tolist() == [STRAINED_S, STRAINED_S + DT, 0.0, 0.0, DT]
    assert weak.tolist() == [True, False, False, False, False]
    assert asked == [[0, 1]]
    _, weak = _strain(np.zeros(1), sat[:1], start[:1], end[:1], DT, WEIGHT,
                      lambda due: pytest.fail("no world is due"))
    assert not weak.any()


def test_the_calm_timer_restarts_unless_seated_off_the_start_and_slow():
    """Calm for CALM_S exactly is placed; a timer short of it runs on."""
    calm = np.array([CALM_S, 0.0, CALM_S, CALM_S, CALM_S - DT, 0.0])
    assert CALM_S - DT + DT == CALM_S  # world 4 reaches CALM_S exactly
    timers, placed = _calm(calm, [2, -1, 2, 2, 0, 0], [True, True, False, True, True, True],
                           [True, True, True, False, True, True], DT)
    assert timers.tolist() == [CALM_S + DT, 0.0, 0.0, 0.0, CALM_S, DT]
    assert placed.tolist() == [2, -1, -1, -1, 0, -1]
