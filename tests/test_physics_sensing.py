"""Sensed interaction, physics options and physical failures of the mujoco backend."""

from dataclasses import replace

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs.envs.backends import BACKENDS
from hri_envs.envs.config import check_physics_options, scenario_graph
from hri_envs.errors import ConfigError
from hri_envs.physics import PandaSim
from hri_envs.physics.panda.options import OPTION_KEYS, PARAMETER_KEYS, PHYSICS_PARAMETERS
from hri_envs.physics.scene.design import PRESET_NAMES, design_for
from hri_envs.physics.scene.sensing import SensorModel
from hri_envs.task.graph import TAKE_OFF, TOGGLE, WAIT
from tests.helpers_physics import named as _named
from tests.helpers_physics import sim_fixture

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


hanger = sim_fixture("hanger")


def test_the_model_has_a_wrist_force_torque_sensor_and_contacts(hanger):
    _, sim = hanger
    m, sc = sim.model, sim.scene
    assert m.sensor_type[sc.force_sensor] == mujoco.mjtSensor.mjSENS_FORCE
    assert m.sensor_type[sc.torque_sensor] == mujoco.mjtSensor.mjSENS_TORQUE
    assert m.site_bodyid[sc.wrist_site] == sc.hand_body
    assert not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    colliding = np.flatnonzero(m.geom_contype != 0)
    assert sc.floor_geom in colliding
    bodies = set(m.geom_bodyid[colliding])  # the floor, object, supports and finger pads
    assert {0, sc.object_body} <= bodies and sc.hand_body not in bodies
    assert set(m.geom_bodyid[sc.finger_geoms.ravel()]) <= bodies


def test_the_sensed_wrench_tracks_the_humans_true_wrench(hanger):
    """The human pulls the held hanger down; the compensated wrist reading follows."""
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    true, sensed = [], []
    wrench = sim.arm.wrench

    def logged(*args):
        w = wrench(*args)
        true.append(w[:3].copy())
        sensed.append(sim.sensor.true_wrench[:3].copy())
        return w

    sim.arm.wrench = logged
    try:
        r = sim.step(s, WAIT, g.move_to_height(0))
    finally:
        sim.arm.wrench = wrench
    # The reading at a control step is that of the physics step before: compare shifted.
    f_true, f_seen = np.array(true[:-1]), np.array(sensed[1:])
    assert r.fault is None and r.graph_agrees
    assert np.abs(f_true).max() > 5.0  # the human did pull
    assert np.abs(f_seen - f_true).mean() < 0.5  # [N]: uncompensated inertia
    assert r.linear_impulse == pytest.approx(r.linear_impulse_true, rel=0.15)


def test_a_following_human_is_felt_but_seen_to_follow(hanger):
    """The embodied hand's damping and inertia resist a robot-led motion a little: a
    non-zero impulse, yet negative work, so the robot infers that the human waited."""
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    r = sim.step(s, g.move_to_height(0), WAIT)
    assert r.graph_agrees and r.human_action == WAIT and not r.robot_yielded
    assert 0.0 < r.linear_impulse_true < 1.0 * r.duration  # [N s]: under 1 N on average
    assert 0.0 < r.linear_impulse < 1.0 * r.duration


def test_sensor_model_delay_bias_and_noise():
    dt = 0.002
    m = SensorModel(noise_n=0.0, bias_n=2.0, delay_s=3 * dt, torque_lever_m=0.1, dt=dt)
    m.reset(np.random.default_rng(0))
    assert np.linalg.norm(m.bias[:3]) == pytest.approx(2.0)
    assert np.linalg.norm(m.bias[3:]) == pytest.approx(0.2)
    inputs = [np.full(6, float(k)) for k in range(6)]
    out = [m.apply(w) for w in inputs]
    # Delayed by three steps (the first reading is repeated until the line fills).
    for k in range(3, 6):
        np.testing.assert_allclose(out[k], inputs[k - 3] + m.bias)
    noisy = SensorModel(noise_n=1.0, bias_n=0.0, delay_s=0.0, torque_lever_m=0.1, dt=dt)
    noisy.reset(np.random.default_rng(1))
    samples = np.array([noisy.apply(np.zeros(6)) for _ in range(4000)])
    assert samples[:, :3].std() == pytest.approx(1.0, rel=0.05)
    assert samples[:, 3:].std() == pytest.approx(0.1, rel=0.05)


def test_sensor_model_reading_is_the_v0_formula_and_the_compiled_law_bit_for_bit():
    """The reading is, bit for bit, the frozen v0 one: the wrench plus the bias, plus the
    noise times the generator's next six standard normals, torques times the lever (one at a
    time or the last of a batch); a noiseless sensor draws nothing. It is also what the
    compiled law the Warp worlds and the continuous envs run gives with one world
    (scene.laws.sensor_noise): the Panda backend keeps a numpy copy so that its processes
    need not load numba (docs/physics.md, "One law, or a copy on each side")."""
    from hri_envs.physics.scene import laws

    rng = np.random.default_rng(7)
    for noise in (0.0, 0.05, 3.7):
        m = SensorModel(noise_n=noise, bias_n=2.5, delay_s=0.0, torque_lever_m=0.13, dt=0.008)
        m.reset(np.random.default_rng(3))
        twin = np.random.default_rng(3)
        twin.standard_normal(6)  # the bias's draws
        for batch in (0, 0, 3, 0, 1):
            wrenches = rng.normal(size=(max(batch, 1), 6)) * 20.0
            got = m.apply_all(wrenches) if batch else m.apply(wrenches[0])
            z = twin.standard_normal((max(batch, 1), 6))[-1].tolist() if noise > 0 else [0.0] * 6
            w = (wrenches[-1] + m.bias).tolist()
            want = [w[c] + noise * z[c] if noise > 0 else w[c] for c in range(3)] + [
                w[c] + noise * z[c] * 0.13 if noise > 0 else w[c] for c in range(3, 6)]
            assert np.array(want).tobytes() == np.asarray(got, float).tobytes()
            law = np.empty((1, 6))
            laws.sensor_noise(wrenches[-1:].copy(), m.bias.reshape(1, 6), np.array([noise]),
                              np.array([z]), 0.13, law)
            assert law[0].tobytes() == np.asarray(got, float).tobytes()
        assert m.rng.standard_normal() == twin.standard_normal()  # the same draws, no more


def test_physics_option_keys_are_listed_once():
    spec = BACKENDS["mujoco"]
    assert set(PARAMETER_KEYS) == set(PHYSICS_PARAMETERS) <= set(OPTION_KEYS)
    assert set(spec.presets) == set(PRESET_NAMES)
    for scenario in ("hanger", "wheel"):  # every design sets every preset, with known keys
        presets = design_for(scenario_graph(scenario)).presets
        assert set(presets) == set(PRESET_NAMES)
        for values in presets.values():
            check_physics_options(values, "mujoco")


@pytest.mark.parametrize(("physics", "message"), [
    ({"human_strength": 1.0}, "unknown physics option(s) 'human_strength'; allowed: "),
    ({"preset": "strong"}, "unknown physics preset 'strong'; allowed: weak-human, noisy-sensor"),
    ({"object_mass": 0.0}, "'object_mass' must be a number > 0 [kg], got 0.0"),
    ({"sensor_delay_s": -0.1}, "'sensor_delay_s' must be a number >= 0 [s]"),
    ({"human_force": True}, "'human_force' must be a number > 0 [N], got True"),
    ({"randomize": {"video_fps": (1, 2)}}, "cannot randomize 'video_fps'; allowed: "),
    ({"randomize": {"object_mass": (0.5, 0.2)}}, "must have low <= high"),
    ({"randomize": {"object_mass": 0.5}}, "must be a (low, high) pair"),
    ({"attempt_invalid": 1}, "'attempt_invalid' must be True or False, got 1"),
    ({"human_grip_force": 0.0}, "'human_grip_force' must be a number > 0 and <= 12 [N], got 0.0"),
    ({"randomize": {"human_grip_force": (2.0, 13.0)}},
     "randomize['human_grip_force'] high must be a number > 0 and <= 12 [N], got 13.0"),
    ({"handle_noise_n": -1.0}, "'handle_noise_n' must be a number >= 0 [N]"),
])
def test_bad_physics_options_are_refused(physics, message):
    with pytest.raises(ConfigError, match=None) as err:
        check_physics_options(physics, "mujoco")
    assert message in str(err.value) and err.value.field == "physics"
    if "unknown physics option" in message:
        assert "human_stiffness" in str(err.value) and "randomize" in str(err.value)


def test_the_graph_backend_takes_no_physics_options():
    with pytest.raises(ConfigError, match="backend='graph' takes no physics options"):
        gym.make("hri_envs/Hanger-v0", physics={"object_mass": 1.0})


def test_the_robot_reads_the_humans_hold_off_the_handle(hanger):
    """The human grasps on A's seat, waits, lets go: the thumb's touch on the handle is the
    grip force while they hold and zero once they let go, and the observed state follows it
    (the wrist alone cannot tell: docs/physics.md)."""
    g, sim = hanger
    s = sim.reset(0)
    seen = []
    for a_h in (TOGGLE, WAIT, TOGGLE):
        r = sim.step(s, WAIT, a_h)
        seen.append((r.human_holds, r.human_holds_sensed, sim.handle.true_force(sim.data)))
        assert r.graph_agrees and r.fault is None
        s = r.state
    grip = sim.params.human_grip_force
    assert [x[:2] for x in seen] == [(True, True), (True, True), (False, False)]
    assert seen[0][2] == pytest.approx(grip, rel=0.1) and seen[2][2] == 0.0


def test_a_grip_the_handle_cannot_feel_misleads_the_robot(hanger):
    """A human whose thumb presses below the robot's 2 N threshold holds the hanger on A's
    seat, but the robot observes A with nobody holding: the graph's state and the physics'
    observation part, and the human's grasp is not inferred. Seeing that state, the human
    grasps again, and keeps holding (a grasp is not a let-go)."""
    g, _ = hanger
    sim = PandaSim(g, options={"human_grip_force": 1.0})
    s = sim.reset(0)
    r = sim.step(s, WAIT, TOGGLE)
    assert r.human_holds and not r.human_holds_sensed
    assert sim.handle.true_force(sim.data) == pytest.approx(1.0, rel=0.1)
    assert r.state == s != r.graph_next and not r.graph_agrees
    assert r.human_action == WAIT  # the robot did not see the grasp
    r = sim.step(r.state, WAIT, TOGGLE)
    assert r.human_holds and not r.human_holds_sensed and r.state == s


@pytest.mark.parametrize("name", ["hanger", "wheel"])
def test_the_handle_reads_the_strongest_allowed_grip(name, hanger):
    """At the option's 12 N maximum the thumb still stops at the handle: the sensor reads
    the grip, and nothing once the human lets go."""
    g = hanger[0] if name == "hanger" else scenario_graph(name)
    sim = PandaSim(g, options={"human_grip_force": 12.0, "handle_noise_n": 0.0})
    s = sim.reset(0)
    r = sim.step(s, WAIT, TOGGLE)
    assert r.human_holds_sensed and sim.handle.true_force(sim.data) == pytest.approx(12.0, 0.05)
    r = sim.step(r.state, WAIT, TOGGLE)
    assert not r.human_holds_sensed and sim.handle.true_force(sim.data) == 0.0


def test_only_the_thumb_counts_on_the_handle_sensor(hanger):
    """The touch sensor counts the contacts of its site's body: the handle body carries only
    the ball, which only the thumb pad touches, and the thumb pad collides only while the
    human holds (a wheel the robot carries alone must not run into the idle thumb)."""
    _, sim = hanger
    m = sim.model
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "handle_touch")
    handle = m.site_bodyid[site]
    assert m.body_parentid[handle] == sim.scene.object_body and m.body_jntnum[handle] == 0
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(i))
            for i in np.flatnonzero(m.geom_bodyid == handle)] == ["handle_ball"]
    pad = sim.arm.thumb_pad
    for holding in (True, False, True):
        sim.arm.hold(sim.data, holding)
        assert bool(m.geom_contype[pad]) == holding


def test_physics_options_set_the_episode(hanger):
    g, _ = hanger
    sim = PandaSim(g, options={"preset": "weak-human", "object_mass": 0.6,
                               "randomize": {"sensor_bias_n": (1.0, 3.0)}})
    b = sim.scene.object_body
    biases = []
    for seed in range(3):
        sim.reset(0, rng=np.random.default_rng(seed))
        assert sim.model.body_mass[b] == 0.6  # the true mass ...
        assert sim.controller.weight[2] == pytest.approx(0.3 * 9.81)  # ... the nominal payload
        weak = design_for(scenario_graph("hanger")).presets["weak-human"]
        assert sim.human.design.human_force == weak["human_force"]
        assert sim.human.design.human_delay_s == 0.4
        biases.append(sim.params.sensor_bias_n)
        assert np.linalg.norm(sim.sensor.model.bias[:3]) == pytest.approx(biases[-1])
    assert all(1.0 <= x <= 3.0 for x in biases) and len(set(biases)) == 3


def test_a_weak_human_cannot_stop_the_robot(hanger):
    """The robot leads over to C while a weak human pulls down: the physics, not the graph,
    decides (the graph says the human wins)."""
    g, _ = hanger
    sim = PandaSim(g, options={"preset": "weak-human"})
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    over, down = g.move_over(2), g.move_to_height(0)
    r = sim.step(s, over, down)
    assert not r.robot_yielded and not r.graph_agrees
    assert r.state == g.next_state[s, over, WAIT] != g.next_state[s, over, down]
    assert r.human_action != down  # the robot did not notice what the human wanted


def test_a_grasp_that_misses_fails(hanger):
    g, sim = hanger
    design = sim.design
    try:
        sim.design = replace(design, grasp_contact_force_n=100.0)  # more than fingers press
        s = sim.reset(1)
        r = sim.step(s, TOGGLE, WAIT)
    finally:
        sim.design = design
    assert r.fault_kind == "grasp_failed" and not sim.holding
    assert not sim.data.eq_active[sim.scene.weld]


def test_an_object_nobody_holds_drops(hanger):
    g, sim = hanger
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    sim.reset(0, state=s)
    sim.weld(False)
    sim.human.holding = False
    r = sim.step(s, WAIT, WAIT)
    assert r.fault_kind == "dropped" and not r.graph_agrees


def test_a_strong_pull_pulls_the_object_out_of_the_grip(hanger):
    g, sim = hanger
    design = sim.design
    s = _named(g, "held at B′ column, 0.87 m, rail-facing")
    try:
        sim.design = replace(design, grip_hold_force_n=3.0)
        sim.reset(0, state=s)
        r = sim.step(s, g.move_over(2), g.move_to_height(0))
    finally:
        sim.design = design
    assert r.fault_kind == "pulled_out" and not sim.holding


def test_a_physical_failure_ends_the_env_episode_with_r_minus():
    env = gym.make("hri_envs/HangerPanda-v0").unwrapped
    env.reset(seed=0, options={"start": "B", "intention": "A"})
    sim = env._episode.sim
    sim.design = replace(sim.design, grasp_contact_force_n=100.0)
    _, reward, terminated, truncated, info = env.step(TOGGLE)
    assert info["fault"] == "grasp_failed" and info["truncation_reason"].startswith(
        "grasp_failed")
    assert reward == -1.0 and truncated and not terminated
    for key in ("graph_agrees", "human_action_inferred", "human_action_true",
                "linear_impulse_true"):
        assert key in info
    env.close()


def test_per_step_info_reports_inferred_and_true_human_actions():
    env = gym.make("hri_envs/HangerPanda-v0", physics={"preset": "noisy-sensor"}).unwrapped
    env.reset(seed=0, options={"start": "B", "intention": "A"})
    seen = []
    for a in (TOGGLE, TAKE_OFF, WAIT):
        _, _, term, trunc, info = env.step(a)
        seen.append((info["human_action_inferred"], info["human_action_true"],
                     info["graph_agrees"], info["fault"]))
        assert info["episode_inference_accuracy"] <= 1.0
        if term or trunc:
            break
    assert all(isinstance(x[0], int) and isinstance(x[1], int) for x in seen)
    env.close()
