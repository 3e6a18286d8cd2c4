"""The MuJoCo physics backend: abstract actions, compliance, grasping, faults, inference."""

from dataclasses import replace

import numpy as np
import pytest

from hri_envs.envs.config import scenario_graph
from hri_envs.physics import IKFailure, PandaSim
from hri_envs.task.graph import PUT_ON, ROTATE, TAKE_OFF, TOGGLE, WAIT
from tests.helpers_physics import named as _named
from tests.helpers_physics import sim_fixture

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


hanger = sim_fixture("hanger")


wheel = sim_fixture("wheel")


def _motions(g, s):
    return [a for a in range(TAKE_OFF, g.n_actions) if g.valid[s, a]]


def _check_all_motions(g, sim, states, leader):
    """Checks every valid motion from ``states``; returns how many (state, motion) pairs."""
    checked = 0
    for s in states:
        for a in _motions(g, s):
            sim.reset(0, state=s)
            a_r, a_h = (a, WAIT) if leader == "robot" else (WAIT, a)
            r = sim.step(s, a_r, a_h)
            assert r.fault is None, (g.state_names[s], g.action_names[a], r.fault)
            assert r.state == g.next_state[s, a_r, a_h], (
                f"{leader} {g.action_names[a]} from {g.state_names[s]} ended in "
                f"{g.state_names[r.state]}")
            assert r.graph_agrees and r.settled
            checked += 1
    return checked


def _n_motions(g, states):
    """Number of (state, motion) pairs, counted from the graph's action mask."""
    return int(g.valid[np.asarray(states, dtype=int), TAKE_OFF:].sum())


# Representative states: the two support kinds, both orientations, both heights, every
# column; each is tried with every valid motion (take off, put on, rotate, move over, height).
HANGER_STATES = ("on B, held by both", "on A, held by both",
                 "held at A′ column, 0.585 m, rail-facing",
                 "held at B′ column, 0.87 m, rail-facing",
                 "held at C column, 0.585 m, peg-facing",
                 "held at A column, 0.87 m, peg-facing")


def test_hanger_robot_actions_reach_the_graphs_states(hanger):
    g, sim = hanger
    states = [_named(g, n) for n in HANGER_STATES]
    assert _check_all_motions(g, sim, states, "robot") == _n_motions(g, states) == 19


def test_hanger_human_actions_reach_the_graphs_states(hanger):
    g, sim = hanger
    states = [_named(g, n) for n in HANGER_STATES[2:4]]
    assert _check_all_motions(g, sim, states, "human") == _n_motions(g, states) == 9


WHEEL_STATES = ("on A, held by both", "on C, held by both",
                "held at A′ column, 1.7 m, vertical", "held at B′ column, 1.1 m, horizontal",
                "held at C column, 0.95 m, horizontal")


def test_wheel_robot_actions_reach_the_graphs_states(wheel):
    g, sim = wheel
    states = [_named(g, n) for n in WHEEL_STATES]
    assert _check_all_motions(g, sim, states, "robot") == _n_motions(g, states) == 22


def test_wheel_human_actions_reach_the_graphs_states(wheel):
    g, sim = wheel
    states = [_named(g, "held at A′ column, 1.7 m, vertical")]
    assert _check_all_motions(g, sim, states, "human") == _n_motions(g, states) == 7


@pytest.mark.slow
@pytest.mark.parametrize("name", ["hanger", "wheel"])
def test_every_motion_from_every_state(name):
    """All (state, motion) pairs, robot-led and human-led (108 hanger, 300 wheel; minutes)."""
    g = scenario_graph(name)
    sim = PandaSim(g)
    held = [s for s in range(g.n_states) if g.grasp[s] == 3]
    per_leader = {"hanger": 54, "wheel": 150}[name]
    assert _n_motions(g, held) == per_leader
    assert _check_all_motions(g, sim, held, "robot") == per_leader
    assert _check_all_motions(g, sim, held, "human") == per_leader


def test_the_human_stays_in_control(hanger):
    """The robot moves towards X while the human pulls towards Y: the object ends at Y."""
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    x, y = g.move_over(2), g.move_to_height(0)  # robot: over to C; human: down
    r = sim.step(s, x, y)
    assert r.fault is None and r.robot_yielded
    assert r.state == g.next_state[s, WAIT, y] == g.next_state[s, x, y]
    assert r.human_action == y  # the robot infers what the human did
    assert r.linear_impulse > 0.0


def test_the_human_stays_in_control_of_the_wheel(wheel):
    g, sim = wheel
    s = _named(g, "held at A′ column, 1.7 m, vertical")
    for x, y in ((g.move_over(1), g.move_to_height(2)), (ROTATE, g.move_over(2)),
                 (g.move_to_height(0), ROTATE)):
        sim.reset(0, state=s)
        r = sim.step(s, x, y)
        assert r.fault is None and r.robot_yielded and r.human_action == y
        assert r.state == g.next_state[s, WAIT, y]


def test_grasp_and_release(hanger):
    g, sim = hanger
    s = sim.reset(1)
    assert s == g.support_state(1, 0) and not sim.data.eq_active[sim.scene.weld]
    r = sim.step(s, TOGGLE, TOGGLE)
    assert r.state == g.support_state(1, 3) and sim.data.eq_active[sim.scene.weld]
    assert r.human_action == TOGGLE
    grip, obj = sim.grip_pose(), sim.state_grip_pose(r.state)
    assert np.linalg.norm(grip.pos - obj.pos) < 0.01  # the hand is on the grip
    r = sim.step(r.state, TOGGLE, WAIT)
    assert r.state == g.support_state(1, 1) and not sim.data.eq_active[sim.scene.weld]
    assert r.position_error < 0.01  # the seat holds the object
    r = sim.step(r.state, WAIT, TOGGLE)
    assert r.state == g.support_state(1, 0) and r.human_action == TOGGLE


def test_invalid_action_aborts_without_motion(hanger):
    g, sim = hanger
    s = sim.reset(0, state=_named(g, "held at A′ column, 0.585 m, rail-facing"))
    r = sim.step(s, PUT_ON, ROTATE)  # put on needs the peg-facing orientation
    assert r.state == s == g.next_state[s, PUT_ON, ROTATE] and r.human_action == WAIT


def test_human_action_inference(hanger):
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    down = g.move_to_height(0)
    for a_r, a_h, expected in ((down, WAIT, WAIT), (WAIT, down, down), (down, down, down)):
        sim.reset(0, state=s)
        r = sim.step(s, a_r, a_h)
        assert r.human_action == expected, (a_r, a_h, r.human_action)


def test_faults_are_reported_not_raised(hanger, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to MUJOCO_LOG.TXT
    g, sim = hanger
    s = sim.reset(0, state=_named(g, "held at B′ column, 0.87 m, rail-facing"))
    design = sim.design
    try:
        sim.design = replace(design, step_time_limit=0.2)  # stopped near the start: no fault
        r = sim.step(s, WAIT, g.move_over(0))
        assert r.fault is None and not r.settled and r.state == s
        s = sim.reset(0, state=s)
        sim.design = replace(design, step_time_limit=1.6)  # stopped half-way: off_support
        r = sim.step(s, WAIT, g.move_over(0))
        assert r.fault is not None and r.fault.startswith("off_support")
    finally:
        sim.design = design
    s = sim.reset(0, state=s)

    def no_solution(*args):
        raise IKFailure("no solution (injected)")

    step = sim.ik.step
    try:
        sim.ik.step = no_solution
        r = sim.step(s, g.move_over(0), WAIT)
        assert r.fault is not None and r.fault.startswith("ik_failure")
    finally:
        sim.ik.step = step
    s = sim.reset(0, state=s)
    sim.data.qvel[:] = np.nan
    r = sim.step(s, g.move_over(0), WAIT)
    assert r.fault is not None and r.fault.startswith("unstable")


def test_physics_speed_measurements_on_a_tiny_size():
    """hri_envs.physics.panda.speed for real (no timing thresholds): structure and counts."""
    from hri_envs.humans.scripted import preference_human
    from hri_envs.physics.panda.speed import physics_realtime_factor, seconds_per_abstract_step

    g = scenario_graph("hanger")
    line = physics_realtime_factor(g, repeats=1)
    assert line.abstract_steps == 2  # over to B and back over to A, once
    episode = seconds_per_abstract_step(g, episodes=1)
    # The same episode (B to A, the human leading, the robot only grasping and letting go)
    # on the graph: the physics must take exactly as many abstract steps.
    human, s, n = preference_human(g), g.support_state(1, 0), 0
    while not (g.support[s] == 0 and g.grasp[s] == 0):
        a_h = int(human.preferred_action(np.array(s), np.array(1), np.array(0)))
        a_r = TOGGLE if g.support[s] >= 0 and a_h == TOGGLE else WAIT
        s, n = int(g.next_state[s, a_r, a_h]), n + 1
        assert n < 40
    assert episode.abstract_steps == n > 3
    for res in (line, episode):
        values = (res.sim_seconds, res.wall_seconds, res.realtime_factor, res.seconds_per_step)
        assert all(np.isfinite(v) and v > 0 for v in values), res
        assert res.seconds_per_step == pytest.approx(res.wall_seconds / res.abstract_steps)
        assert res.sim_seconds > 0.1 * res.abstract_steps  # a motion takes simulated time
