"""The control loop's per-period helpers: plain-float code paths against the array formulas."""

import numpy as np
import pytest

from hri_envs.envs.config import scenario_graph
from hri_envs.physics.scene.design import design_for
from hri_envs.physics.scene.kinematics import Pose, StraightLine, rotation_error, slerp
from hri_envs.physics.scene.seats import Seats


def _engaged_by_arrays(seats: Seats, pos: np.ndarray, quat: np.ndarray) -> int:
    """The seat test written with whole-array numpy operations."""
    e = seats.pos - pos
    along = -(e * seats.exit).sum(axis=1)
    across2 = (e * e).sum(axis=1) - along * along
    cap = seats.capture
    for k in np.flatnonzero((np.abs(along) < cap) & (across2 < cap * cap)):
        if np.linalg.norm(rotation_error(seats.quat[k], quat)) < seats.max_angle:
            return int(k)
    return -1


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_seat_test_matches_the_array_formula_around_every_seat(scenario):
    graph = scenario_graph(scenario)
    seats = Seats(graph.scenario, design_for(graph))
    rng = np.random.default_rng(0)
    found = set()
    for k in range(len(seats.pos)):
        for _ in range(400):
            # Around the seat, out to twice the capture region, turned up to 2x the capture
            # angle: inside, outside and on the edges of the region.
            pos = seats.pos[k] + rng.uniform(-2, 2, 3) * seats.capture
            axis = rng.standard_normal(3)
            angle = rng.uniform(0, 2 * seats.max_angle)
            turn = np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis / np.linalg.norm(axis)]
            w1, v1 = turn[0], turn[1:]
            w2, v2 = seats.quat[k][0], seats.quat[k][1:]
            quat = np.r_[w1 * w2 - v1 @ v2, w1 * v2 + w2 * v1 + np.cross(v1, v2)]
            got = seats.engaged(pos, quat)
            assert got == _engaged_by_arrays(seats, pos, quat)
            found.add(got)
        assert seats.engaged(seats.pos[k], seats.quat[k]) == k  # at rest in its seat
    assert -1 in found and len(found) > 1  # both outcomes were exercised


def test_straight_line_samples_its_ends_and_midpoint():
    start = Pose(np.array([0.1, 0.2, 0.3]), np.array([1.0, 0.0, 0.0, 0.0]))
    half = np.sqrt(0.5)
    goal = Pose(np.array([0.5, -0.2, 0.3]), np.array([half, 0.0, 0.0, half]))  # 90° about z
    line = StraightLine(start, goal, linear_speed=0.2, angular_speed=1.0, min_duration=0.5)
    # Peak speed 1.875 x mean: 0.566 m at 0.2 m/s, pi/2 rad at 1 rad/s.
    assert line.duration == pytest.approx(max(1.875 * np.hypot(0.4, 0.4) / 0.2,
                                              1.875 * np.pi / 2))
    mid = line.sample(line.duration / 2)  # minimum jerk: halfway in place, fastest
    np.testing.assert_allclose(mid.pos, [0.3, 0.0, 0.3], atol=1e-15)
    np.testing.assert_allclose(mid.quat, slerp(start.quat, goal.quat, 0.5), atol=1e-15)
    np.testing.assert_allclose(mid.vel, 1.875 / line.duration * (goal.pos - start.pos))
    for t in (line.duration, line.duration + 1.0):  # clamped, at rest
        end = line.sample(t)
        np.testing.assert_allclose(end.pos, goal.pos, atol=1e-15)
        np.testing.assert_allclose(end.quat, goal.quat, atol=1e-15)
        assert not end.vel.any() and not end.angvel.any()
    assert line.sample(line.duration + 2.0) is line.sample(line.duration)  # kept once ended
    before = line.sample(np.nextafter(line.duration, 0.0))  # not yet the end sample
    assert before is not line.sample(line.duration)
    start_sample = line.sample(-1.0)
    np.testing.assert_array_equal(start_sample.pos, start.pos)
    assert not start_sample.vel.any()


def test_rotation_error_of_a_quarter_turn():
    half = np.sqrt(0.5)
    about_z = np.array([half, 0.0, 0.0, half])
    np.testing.assert_allclose(rotation_error(about_z, np.array([1.0, 0, 0, 0])),
                               [0.0, 0.0, np.pi / 2], atol=1e-15)
    # The shortest way: q and -q are one rotation.
    np.testing.assert_allclose(rotation_error(-about_z, np.array([1.0, 0, 0, 0])),
                               [0.0, 0.0, np.pi / 2], atol=1e-15)
    np.testing.assert_array_equal(rotation_error(about_z, about_z), np.zeros(3))
