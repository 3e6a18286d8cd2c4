"""Contacts of the mujoco backend: which geoms collide, grasps that can fail physically,
supports that stop an object moved through them, and actions the robot physically tries."""

from itertools import combinations

import mujoco
import numpy as np
import pytest

from hri_envs.envs.config import check_physics_options, scenario_graph
from hri_envs.errors import ConfigError
from hri_envs.physics import PandaSim
from hri_envs.physics.panda.steps import StepTotals
from hri_envs.physics.scene.contacts import finger_forces, touches
from hri_envs.physics.scene.kinematics import Pose, StraightLine, compose
from hri_envs.task.graph import HUMAN_BIT, PUT_ON, TAKE_OFF, TOGGLE, WAIT
from tests.helpers_physics import named as _named
from tests.helpers_physics import sim_fixture

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


hanger = sim_fixture("hanger")


def _kinds(sim):
    """Each colliding geom's kind: floor, object, grip, finger, support, thumb or handle."""
    m, sc = sim.model, sim.scene
    kind = {sc.floor_geom: "floor", sc.grip_geom: "grip",
            mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "handle_ball"): "handle"}
    kind.update({g: "thumb" for g in range(m.ngeom) if m.geom_bodyid[g] == mujoco.mj_name2id(
        m, mujoco.mjtObj.mjOBJ_BODY, "human_thumb")})
    kind.update({int(g): "finger" for g in sc.finger_geoms.ravel()})
    kind.update({int(g): "support" for g in sc.support_geoms})
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == sc.object_body and (m.geom_contype[g] or m.geom_conaffinity[g]):
            kind.setdefault(g, "object")
    return kind


@pytest.mark.parametrize("name", ["hanger", "wheel"])
def test_only_the_intended_pairs_collide(name, hanger):
    sim = hanger[1] if name == "hanger" else PandaSim(scenario_graph(name))
    m = sim.model
    sim.reset(0)  # the robot does not hold: its finger pads collide
    sim.arm.hold(sim.data, True)  # the thumb pad collides only while the human holds
    kind = _kinds(sim)
    colliding = {int(g) for g in np.flatnonzero((m.geom_contype | m.geom_conaffinity) != 0)}
    assert colliding == set(kind)  # no robot link, hand or picture geom collides
    assert len(sim.scene.finger_geoms) == 2 and sim.scene.finger_geoms.shape[1] > 0
    support_bodies = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"support_{x.name}")
                      for x in sim.scenario.supports}
    assert support_bodies <= set(m.geom_bodyid[sim.scene.support_geoms])  # each collides
    pairs = set()
    for a, b in combinations(sorted(colliding), 2):
        if (m.geom_contype[a] & m.geom_conaffinity[b]) or (m.geom_contype[b]
                                                            & m.geom_conaffinity[a]):
            pairs.add(tuple(sorted((kind[a], kind[b]))))
    assert pairs == {("floor", "object"), ("object", "support"), ("finger", "grip"),
                     ("handle", "thumb")}


@pytest.mark.parametrize("name", ["hanger", "wheel"])
def test_an_object_resting_on_a_support_touches_nothing(name, hanger):
    """The seat law holds a resting object; its geometry is clear of the support's. Only a
    holding human's thumb touches the object (on its handle)."""
    g, sim = hanger if name == "hanger" else (scenario_graph(name), None)
    sim = sim or PandaSim(g)
    kind = _kinds(sim)
    for k in range(len(g.scenario.supports)):
        for mu in range(4):
            sim.reset(k, state=g.support_state(k, mu))
            pairs = sorted({tuple(sorted((kind[int(c.geom1)], kind[int(c.geom2)])))
                            for c in sim.data.contact[:sim.data.ncon]})
            assert set(pairs) <= ({("handle", "thumb")} if mu & HUMAN_BIT else set()), (
                g.state_names[g.support_state(k, mu)])


def test_a_grasp_closes_both_fingers_on_the_grip(hanger):
    """The fingers close on the grip block and press on it before the weld; once it holds,
    they stay where the block stopped them with their contacts off (the weld carries the
    object), and a let-go turns the contacts on again."""
    g, sim = hanger
    s = sim.reset(1)
    pressed = []
    close = sim._close_on_grip

    def logged(totals):
        weld = sim.weld
        sim.weld = lambda on: (pressed.append(finger_forces(
            sim.model, sim.data, sim.scene.finger_geoms, sim.scene.grip_geom)), weld(on))
        try:
            close(totals)
        finally:
            del sim.weld

    sim._close_on_grip = logged
    try:
        r = sim.step(s, TOGGLE, WAIT)
    finally:
        del sim._close_on_grip
    assert r.fault is None and sim.holding and sim.data.eq_active[sim.scene.weld]
    assert len(pressed) == 1 and np.all(pressed[0] >= sim.design.grasp_contact_force_n)
    # The grip (4 cm wide) stopped the fingers before their commanded 1.2 cm, and they stay.
    q = sim.data.qpos[sim.scene.finger_qpos]
    assert np.all(np.abs(q - 0.0219) < 0.001), q
    fingers = sim.scene.finger_geoms.ravel()
    assert not sim.model.geom_contype[fingers].any() and sim.data.ncon <= 1  # thumb only
    r = sim.step(r.state, TOGGLE, WAIT)
    assert not sim.holding and sim.model.geom_contype[fingers].all()


@pytest.mark.parametrize("offset_m, holds", [(0.005, True), (0.025, False), (0.04, False)])
def test_a_grasp_beside_the_grip_fails(hanger, offset_m, holds):
    """The robot aims at a grip it believes is offset_m across the finger pads from the real
    one (a misplaced object): 5 mm still closes on it; 2.5 cm closes on the grip block but
    too far from the grip to hold it; 4 cm closes on nothing."""
    g, sim = hanger
    site = sim.scene.object_grip_site
    saved = sim.model.site_pos[site].copy()
    across = np.empty(9)
    mujoco.mju_quat2Mat(across, sim.design.grip_quat)
    try:
        sim.model.site_pos[site] = saved + offset_m * across.reshape(3, 3)[:, 0]
        s = sim.reset(1)
        r = sim.step(s, TOGGLE, WAIT)
    finally:
        sim.model.site_pos[site] = saved
    assert sim.holding == holds
    if not holds:
        assert r.fault_kind == "grasp_failed"
        assert ("N each" if offset_m > 0.03 else "from the grip") in r.fault, r.fault
        assert not sim.data.eq_active[sim.scene.weld]
        assert np.all(sim.data.ctrl[sim.scene.finger_actuators] == 0.04)  # opened again


def test_a_support_stops_an_object_moved_through_it(hanger):
    """The robot moves the hanger from B's outer column to 3 cm above B's seat and 4 cm on
    towards B's post, a line that crosses B's bar: the neck meets the bar's end and stops
    there; without the bar's collision geometry the hanger reaches the line's end."""
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m")
    seat_pos, seat_quat = sim.observer.pose(g.support_state(1, 3))
    bar = sim.scenario.supports[1]
    inward = (bar.position - bar.mounting) * [1.0, 1.0, 0.0]
    goal = Pose(seat_pos + [0.0, 0.0, 0.03] + 0.04 * inward / np.linalg.norm(inward), seat_quat)
    sup = sim.scene.support_geoms
    saved = sim.model.geom_contype[sup].copy()
    ends, hits = [], []
    for contacts_on in (True, False):
        sim.model.geom_contype[sup] = saved if contacts_on else 0
        try:
            sim.reset(0, state=s)
            seen: list[bool] = []

            def record(seen=seen):
                seen.append(any(touches(sim.data, int(x)) for x in sup))

            sim.on_frame, sim.frame_every = record, 10
            line = StraightLine(sim.grip_pose(), compose(goal, *sim.grip_in_object),
                                sim.design.linear_speed, sim.design.angular_speed, 0.6)
            sim._run(line, None, StepTotals(), 4.0)
        finally:
            sim.on_frame = None
            sim.model.geom_contype[sup] = saved
        ends.append(np.linalg.norm(sim.object_pose().pos - goal.pos))  # [m] short of the goal
        hits.append(any(seen))
    assert hits == [True, False]
    assert ends[0] > 0.04 and ends[1] < 0.01, ends


def test_attempt_invalid_is_checked():
    assert check_physics_options({"attempt_invalid": True}, "mujoco") == {
        "attempt_invalid": True}
    with pytest.raises(ConfigError, match="'attempt_invalid' must be True or False"):
        check_physics_options({"attempt_invalid": "yes"}, "mujoco")


@pytest.fixture(scope="module")
def attempting():
    g = scenario_graph("hanger")
    return g, PandaSim(g, options={"attempt_invalid": True})


@pytest.mark.parametrize("state, a_r, a_h, kind", [
    # Letting go in mid-air: the graph refuses it; tried, the hanger falls.
    ("held at B′ column, 0.87 m", TOGGLE, WAIT, "dropped"),
    # Taking off alone (the human lets go meanwhile): the detent gives, the robot alone holds
    # the hanger in free space, which no abstract state describes.
    ("on B, held by both", TAKE_OFF, TOGGLE, "off_support"),
])
def test_the_robot_physically_tries_invalid_actions(hanger, attempting, state, a_r, a_h, kind):
    g = hanger[0]
    s = _named(g, state)
    assert g.next_state[s, a_r, a_h] == g.next_state[s, WAIT, a_h]  # the graph: refused
    refused, tried = hanger[1], attempting[1]
    refused.reset(0, state=s)
    r = refused.step(s, a_r, a_h)
    assert r.fault is None and r.graph_agrees
    tried.reset(0, state=s)
    r = tried.step(s, a_r, a_h)
    assert r.fault_kind == kind and not r.graph_agrees


def test_a_tried_put_on_from_below_the_mounting_is_decided_by_the_physics(attempting):
    """The graph allows put on only from the mounting waypoint; tried from its column's
    lower waypoint, the robot carries the hanger up onto B's seat (nothing is in the way)."""
    g, sim = attempting
    s = _named(g, "held at B column, 0.585 m")
    assert not g.valid[s, PUT_ON]
    sim.reset(0, state=s)
    r = sim.step(s, PUT_ON, WAIT)
    assert r.fault is None and r.state == g.support_state(1, 3) and not r.graph_agrees
