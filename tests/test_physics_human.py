"""The embodied human of the mujoco backend: arm, actuators, grasp weld, reach, options."""

import mujoco
import numpy as np
import pytest

from hri_envs.envs.config import check_physics_options
from hri_envs.errors import ConfigError
from hri_envs.physics import PandaSim
from hri_envs.physics.panda.human_arm import HUMAN_JOINTS
from hri_envs.physics.scene.kinematics import quat_mul, rotation_error
from hri_envs.task.graph import HUMAN_BIT, TOGGLE, WAIT
from tests.helpers_physics import named as _named
from tests.helpers_physics import sim_fixture

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


hanger = sim_fixture("hanger")


def test_the_arm_is_six_position_actuators_with_the_humans_impedance(hanger):
    _, sim = hanger
    m, arm, design = sim.model, sim.arm, sim.design
    sim.reset(0)
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in arm.joints] == list(
        HUMAN_JOINTS)
    kp = [design.human_stiffness] * 3 + [design.human_rot_stiffness] * 3
    kv = [design.human_damping] * 3 + [design.human_rot_damping] * 3
    limit = [design.human_force] * 3 + [design.human_torque] * 3
    np.testing.assert_allclose(m.actuator_gainprm[arm.actuators, 0], kp)
    np.testing.assert_allclose(m.actuator_biasprm[arm.actuators, 1:3], -np.c_[kp, kv])
    np.testing.assert_allclose(m.actuator_forcerange[arm.actuators, 1], limit)
    assert all(m.actuator_forcelimited[arm.actuators]) and all(m.jnt_limited[arm.joints])
    assert m.body_gravcomp[arm.arm_body] == m.body_gravcomp[arm.hand_body] == 1.0
    assert m.body_mass[arm.arm_body] == design.human_mass


@pytest.mark.parametrize("state", ["on B, held by both", "on A, held by the robot",
                                   "held at B′ column, 0.87 m, rail-facing",
                                   "held at C column, 0.585 m, peg-facing"])
def test_the_hand_rests_on_the_handle_and_its_weld_is_the_grasp_bit(hanger, state):
    g, sim = hanger
    s = _named(g, state)
    sim.reset(0, state=s)
    d, arm = sim.data, sim.arm
    assert bool(d.eq_active[arm.weld]) == bool(g.grasp[s] & HUMAN_BIT) == sim.human.holding
    np.testing.assert_allclose(d.xpos[arm.hand_body], d.site_xpos[sim.scene.object_handle_site],
                               atol=1e-9)
    want = quat_mul(d.xquat[sim.scene.object_body], arm.hand_quat_in_object)
    assert np.linalg.norm(rotation_error(want, d.xquat[arm.hand_body])) < 1e-9


def test_letting_go_turns_the_weld_off(hanger):
    g, sim = hanger
    s = sim.reset(1)  # on B, held by nobody: the human grasps, then lets go
    assert not sim.data.eq_active[sim.arm.weld]
    r = sim.step(s, WAIT, TOGGLE)
    assert r.fault is None and sim.data.eq_active[sim.arm.weld] and sim.human.holding
    r = sim.step(r.state, WAIT, TOGGLE)
    assert r.fault is None and not sim.data.eq_active[sim.arm.weld]


def test_the_humans_force_is_limited_and_the_hand_stays_in_reach(hanger):
    """A weak human pulls down against the robot's move over: their actuators saturate at
    the human's strength, never beyond; a reference outside the workspace is clipped."""
    g, _ = hanger
    sim = PandaSim(g, options={"preset": "weak-human"})
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    arm, d = sim.arm, sim.data
    limit = sim.model.actuator_forcerange[arm.actuators, 1]
    assert limit[0] == 3.5  # the preset's human_force [N]
    peak = np.zeros(6)
    wrench = arm.wrench

    def logged(*args):
        np.maximum(peak, np.abs(d.actuator_force[arm.actuators]), out=peak)
        return wrench(*args)

    arm.wrench = logged
    r = sim.step(s, g.move_over(2), g.move_to_height(0))
    assert r.fault is None
    assert np.all(peak <= limit + 1e-9) and peak[2] == pytest.approx(limit[2])
    far = arm.targets(np.array([5.0, -5.0, 5.0]), np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(6))
    lo, hi = sim.design.human_reach_lo, sim.design.human_reach_hi
    np.testing.assert_allclose(far[:3], [hi[0], lo[1], hi[2]])


def test_physics_options_set_the_arm(hanger):
    g, _ = hanger
    sim = PandaSim(g, options={"human_stiffness": 100.0, "human_force": 5.0,
                               "randomize": {"human_mass": (2.0, 3.0)}})
    arm, m = sim.arm, sim.model
    masses = []
    for seed in range(3):
        sim.reset(0, rng=np.random.default_rng(seed))
        assert m.actuator_gainprm[arm.actuators[0], 0] == 100.0
        assert m.actuator_forcerange[arm.actuators[0], 1] == 5.0
        masses.append(m.body_mass[arm.arm_body])
    assert all(2.0 <= x <= 3.0 for x in masses) and len(set(masses)) == 3
    with pytest.raises(ConfigError, match=r"'human_mass' must be a number > 0 \[kg\], got 0"):
        check_physics_options({"human_mass": 0}, "mujoco")
