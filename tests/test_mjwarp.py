"""The mjwarp backend (N worlds on MuJoCo Warp) against the C backend, on Warp's CPU device.

``make test`` runs this module in a process of its own: Warp compiles its kernels once
(about 1.5 minutes without a kernel cache), and the tests share the batches simulated by the
module-scoped fixtures. A step on the CPU device costs the same for 1 or 30 worlds (Warp's
launch overhead), so each fixture runs its cases as worlds of one batch. No timings.

Equality, as stated in docs/physics.md ("Many worlds on MuJoCo Warp"): every (state, motion)
pair reaches the C backend's (and the graph's) abstract state without a fault, settled, with
the same inferred human action; the object ends within :data:`POS_TOL_M` and
:data:`ANGLE_TOL_RAD` of where the C backend leaves it; a seeded env episode gives the same
observations and rewards with the object within :data:`POS_TOL_M`; a study gives the same
episode outcomes.
"""

import importlib.util

import numpy as np
import pytest

from hri_envs.envs.config import scenario_graph
from hri_envs.task.graph import TAKE_OFF, TOGGLE, WAIT
from tests.helpers_physics import named
from tests.test_physics import HANGER_STATES, WHEEL_STATES

pytestmark = [
    pytest.mark.mjwarp,
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
    pytest.mark.skipif(importlib.util.find_spec("mujoco_warp") is None,
                       reason="the mjwarp extra is not installed"),
]

#: How far the object may end from where the C backend leaves it (float32 physics on MuJoCo
#: Warp, mink-warp's IK): largest seen 3.8 mm, after the wheel's human-led motions.
POS_TOL_M = 0.01
ANGLE_TOL_RAD = 0.05


def _pairs(g, states, leader, nearest_move_over=False):
    """(state, robot action, human action) of every valid motion from ``states``; with
    ``nearest_move_over`` only the shortest of each state's move-overs (the longer ones
    take up to 9 simulated seconds, which would set the whole batch's length).
    """
    out = []
    for s in states:
        actions = [a for a in range(TAKE_OFF, g.n_actions) if g.valid[s, a]]
        if nearest_move_over:
            overs = [a for a in actions if a in [g.move_over(k) for k in range(g.n_intentions)]]
            if overs:
                pos = g.scenario.waypoint_position
                here = pos(int(g.column[s]), int(g.height[s]))
                near = min(overs, key=lambda a: np.linalg.norm(
                    pos(int(g.column[g.next_state[s, a, WAIT]]), int(g.height[s])) - here))
                actions = [a for a in actions if a not in overs or a == near]
        out += [(s, a, WAIT) if leader == "robot" else (s, WAIT, a) for a in actions]
    return out


def _run_c(g, cases):
    from hri_envs.physics import PandaSim

    sim = PandaSim(g)
    out = []
    for s, a_r, a_h in cases:
        sim.reset(0, state=s)
        res = sim.step(s, a_r, a_h)
        out.append((res, sim.object_pose()))
    return out


def _run_warp(worlds, cases, hook=None):
    """The ``cases`` as worlds 0.. of one batch; (result, object pose) per case."""
    n = worlds.n
    active = np.zeros(n, bool)
    states, a_r, a_h = (np.zeros(n, np.int64) for _ in range(3))
    for i, (s, ar, ah) in enumerate(cases):
        worlds.reset_world(i, 0, state=s)
        states[i], a_r[i], a_h[i], active[i] = s, ar, ah, True
    worlds.on_period = hook
    try:
        res = worlds.step(states, a_r, a_h, active)
    finally:
        worlds.on_period = None
    return [(res[i], worlds.object_pose(i)) for i in range(len(cases))]


def _angle(q1, q2):
    return 2.0 * np.arccos(min(1.0, abs(float(np.dot(q1, q2)))))


def _assert_equal(g, cases, c_out, w_out):
    """Both backends reach the graph's state, and the object ends within tolerance."""
    for (s, a_r, a_h), (c, c_pose), (w, w_pose) in zip(cases, c_out, w_out, strict=True):
        what = (f"{g.action_names[max(a_r, a_h)]} ({'robot' if a_r else 'human'}) from "
                f"{g.state_names[s]}")
        assert c.fault is None and w.fault is None, (what, c.fault, w.fault)
        assert w.state == c.state == g.next_state[s, a_r, a_h], (
            what, g.state_names[c.state], g.state_names[w.state])
        assert w.settled and w.graph_agrees and w.human_action == c.human_action, what
        assert np.linalg.norm(w_pose.pos - c_pose.pos) < POS_TOL_M, what
        assert _angle(w_pose.quat, c_pose.quat) < ANGLE_TOL_RAD, what


# ---------------------------------------------------------------------------- the hanger
#: Worlds after the 28 motions: grasp and let go with a faulty world among them.
GRASP_CASES = 4


@pytest.fixture(scope="module")
def hanger():
    """One batch of hanger worlds: every kind of motion (each valid motion, of the
    move-overs the shortest) from the representative states of tests/test_physics.py,
    robot-led (15) and human-led from the two free states (7), then on B: both grasp;
    nobody moves; the robot lets go; a world whose simulation is broken.
    """
    from hri_envs.physics.panda.warp.worlds import WarpWorlds

    g = scenario_graph("hanger")
    states = [named(g, n) for n in HANGER_STATES]
    pairs = (_pairs(g, states, "robot", nearest_move_over=True)
             + _pairs(g, states[2:4], "human", nearest_move_over=True))
    on_b, both_b = g.support_state(1, 0), g.support_state(1, 3)
    grasps = [(on_b, TOGGLE, TOGGLE), (on_b, WAIT, WAIT), (both_b, TOGGLE, WAIT),
              (both_b, TOGGLE, WAIT)]
    worlds = WarpWorlds(g, len(pairs) + GRASP_CASES)
    n_p = len(pairs)
    for i, (s, _, _) in enumerate(grasps):
        worlds.reset_world(n_p + i, 1, state=s)
    broken = n_p + 3
    qvel = worlds.d.qvel.numpy()
    qvel[broken] = np.nan
    worlds.d.qvel.assign(qvel)
    # The idle world (nobody moves) ends its step first: record its state in every later
    # period, while the others go on.
    idle, seen = n_p + 1, []

    def hook(ran):
        if not ran[idle]:
            seen.append((worlds.d.qpos.numpy()[idle].copy(), float(worlds.d.time.numpy()[idle])))

    n = worlds.n
    active = np.ones(n, bool)
    states_, a_r, a_h = (np.zeros(n, np.int64) for _ in range(3))
    for i, (s, ar, ah) in enumerate(pairs):
        worlds.reset_world(i, 0, state=s)
        states_[i], a_r[i], a_h[i] = s, ar, ah
    for i, (s, ar, ah) in enumerate(grasps):
        states_[n_p + i], a_r[n_p + i], a_h[n_p + i] = s, ar, ah
    worlds.on_period = hook
    res = worlds.step(states_, a_r, a_h, active)
    worlds.on_period = None
    margin = worlds.m.geom_margin.numpy().copy()
    eq = worlds.d.eq_active.numpy().copy()
    poses = [worlds.object_pose(i) for i in range(n)]
    final = (worlds.d.qpos.numpy()[idle].copy(), float(worlds.d.time.numpy()[idle]))
    return {"g": g, "worlds": worlds, "pairs": pairs, "res": res, "poses": poses,
            "margin": margin, "eq": eq, "seen": seen, "final": final, "n_pairs": n_p}


def test_the_worlds_run_on_the_cpu_device(hanger):
    assert hanger["worlds"].device == "cpu" and hanger["worlds"].n == 26


def test_hanger_motions_equal_the_c_backend(hanger):
    g, pairs = hanger["g"], hanger["pairs"]
    assert len(pairs) == 22
    names = [g.action_names[max(a_r, a_h)] for _, a_r, a_h in pairs]
    kinds = {n if not n.startswith("move") else n[:len("move over to")]
             if n.startswith("move over") else "move to" for n in names}
    assert kinds == {"take off", "put on", "rotate", "move over to", "move to"}
    w_out = list(zip(hanger["res"][:22], hanger["poses"][:22], strict=True))
    _assert_equal(g, pairs, _run_c(g, pairs), w_out)


def test_grasps_and_faults_are_per_world(hanger):
    """In the same batch: both grasp in one world, nobody moves in the next, the robot lets
    go in the third, and only the fourth, whose velocities are NaN, faults. The welds and
    the finger contacts' margins are each world's own."""
    g, res, n_p = hanger["g"], hanger["res"], hanger["n_pairs"]
    weld, fingers = hanger["worlds"].scene.weld, hanger["worlds"].scene.finger_geoms.ravel()
    both, eq, margin = n_p, hanger["eq"], hanger["margin"]
    assert res[both].state == g.support_state(1, 3) and res[both].fault is None
    assert res[both].human_action == TOGGLE and eq[both, weld]
    assert (margin[both, fingers] < 0).all()  # welded: the finger contacts are off
    idle = n_p + 1
    assert res[idle].state == g.support_state(1, 0) and res[idle].fault is None
    assert not eq[idle, weld] and (margin[idle, fingers] >= 0).all()
    let_go = n_p + 2
    assert res[let_go].state == g.support_state(1, 1) and res[let_go].fault is None
    assert not eq[let_go, weld] and (margin[let_go, fingers] >= 0).all()
    assert res[n_p + 3].fault is not None and res[n_p + 3].fault.startswith("unstable")
    for i in range(n_p + 3):
        assert res[i].fault is None


def test_a_world_that_has_ended_its_step_waits_frozen(hanger):
    """The idle world ended first; in every later period of the batch its state and clock
    stayed what they were when its step ended."""
    seen, (qpos, time) = hanger["seen"], hanger["final"]
    assert len(seen) > 100  # the other worlds ran on for many periods
    for q, t in seen:
        np.testing.assert_array_equal(q, qpos)
        assert t == time
    assert time == pytest.approx(hanger["res"][hanger["n_pairs"] + 1].duration, abs=1e-6)


# ---------------------------------------------------------------------------- the wheel
def test_wheel_motions_equal_the_c_backend():
    """The wheel: every kind of motion from a free state, human-led (6), and taking the
    wheel off its support, robot-led (1), 7 worlds together."""
    from hri_envs.physics.panda.warp.worlds import WarpWorlds

    g = scenario_graph("wheel")
    cases = (_pairs(g, [named(g, WHEEL_STATES[2])], "human", nearest_move_over=True)
             + _pairs(g, [named(g, WHEEL_STATES[0])], "robot"))
    assert len(cases) == 7
    _assert_equal(g, cases, _run_c(g, cases), _run_warp(WarpWorlds(g, len(cases)), cases))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["hanger", "wheel"])
def test_every_motion_from_every_state_equals_the_c_backend(name):
    """All (state, motion) pairs, robot-led and human-led (108 hanger, 300 wheel), in
    batches of 54 worlds (about 10 and 40 minutes on this project's 2-core machine)."""
    from hri_envs.physics.panda.warp.worlds import WarpWorlds

    g = scenario_graph(name)
    held = [s for s in range(g.n_states) if g.grasp[s] == 3]
    pairs = _pairs(g, held, "robot") + _pairs(g, held, "human")
    assert len(pairs) == {"hanger": 108, "wheel": 300}[name]
    worlds = WarpWorlds(g, 54)
    for k in range(0, len(pairs), worlds.n):
        batch = pairs[k:k + worlds.n]
        _assert_equal(g, batch, _run_c(g, batch), _run_warp(worlds, batch))


# ---------------------------------------------------------------------------- envs, studies
def _c_episode(seed, options, actions, max_cycles):
    import gymnasium as gym

    env = gym.make("hri_envs/HangerPanda-v0", max_cycles=max_cycles).unwrapped
    obs, _ = env.reset(seed=seed, options=options)
    out = [obs]
    for a in actions:
        out.append(env.step(a))
        out[-1][4]["object_pos"] = env._episode.sim.object_pose().pos
    env.close()
    return out


def test_the_vector_env_matches_the_c_env_and_autoresets():
    """make_vec on a Panda id: 2 envs in one WarpWorlds. Env 0 (seed 5: B to A) grasps and
    takes off: the same observations, rewards and ends as the C env with that seed, the
    object within POS_TOL_M; after max_cycles both envs restart in the next step (reward 0,
    their start states, the actions ignored)."""
    import gymnasium as gym

    import hri_envs  # noqa: F401
    from hri_envs.physics.panda.warp.vector import PandaVectorEnv

    options = {"start": "B", "intention": "A"}
    env = gym.make_vec("hri_envs/HangerPanda-v0", num_envs=2,
                       vectorization_mode="vector_entry_point", max_cycles=2)
    venv = env.unwrapped
    assert isinstance(venv, PandaVectorEnv) and venv.worlds.n == 2
    obs, _ = env.reset(seed=5, options=options)
    c = _c_episode(5, options, (TOGGLE, TAKE_OFF), max_cycles=2)
    assert obs["state"][0] == c[0]["state"] and obs["action_mask"].shape == (2, 10)
    start = obs["state"].copy()
    for k, a in enumerate((TOGGLE, TAKE_OFF)):
        obs, rew, term, trunc, info = env.step(np.array([a, a]))
        c_obs, c_rew, c_term, c_trunc, c_info = c[k + 1]
        assert obs["state"][0] == c_obs["state"]
        assert obs["last_human_action"][0] == c_obs["last_human_action"]
        assert (rew[0], term[0], trunc[0]) == (c_rew, c_term, c_trunc)
        assert info["graph_agrees"][0] and info["_graph_agrees"].all()
        pos = venv.worlds.object_pose(0).pos
        assert np.linalg.norm(pos - c_info["object_pos"]) < POS_TOL_M
    assert trunc.all() and not term.any()  # max_cycles=2
    obs, rew, term, trunc, info = env.step(np.array([TOGGLE, TOGGLE]))
    assert (rew == 0).all() and not (term | trunc).any()
    np.testing.assert_array_equal(obs["state"], start)  # both restarted on B, μ = 0
    env.close()


def test_a_study_gives_the_c_backends_episode_outcomes():
    """hri-bench's loop on both backends with the same seeds (Passive robot, the hanger's
    Table 2 schedule, its first two steps): the same steps, rewards, truncations, agreement,
    inference and faults per run; durations within 15 %."""
    from baselines import Passive
    from hri_bench.run.runner import make_schedule, simulate
    from hri_envs.humans.scripted import preference_human

    g = scenario_graph("hanger")
    human = preference_human(g)
    schedule = make_schedule(g, "table2", [0, 1], 1, seed=0)
    out = {}
    for backend in ("mujoco", "mjwarp"):
        out[backend] = simulate(g, Passive(g, 2), human, schedule, runs=[0, 1], seed=0,
                                r0=-0.33, max_steps=2, backend=backend)
    c, w = out["mujoco"], out["mjwarp"]
    np.testing.assert_array_equal(w.steps, c.steps)
    np.testing.assert_array_equal(w.reward, c.reward)
    np.testing.assert_array_equal(w.truncated, c.truncated)
    for key in ("graph_agrees", "inference_accuracy", "hold_accuracy", "physical_fault"):
        np.testing.assert_array_equal(w.extras[key], c.extras[key], err_msg=key)
    np.testing.assert_allclose(w.extras["duration_s"], c.extras["duration_s"], rtol=0.15)


def test_the_parallel_env_runs_on_mjwarp():
    from hri_envs import hanger_v0
    from hri_envs.physics.panda.warp.episode import WarpSim

    env = hanger_v0.parallel_env(backend="mjwarp", max_cycles=3)
    assert isinstance(env.unwrapped._episode.sim, WarpSim)
    assert env.unwrapped._episode.sim.worlds.n == 1
    obs, _ = env.reset(seed=0, options={"start": "B", "intention": "A"})
    obs, rew, term, trunc, info = env.step({"human": WAIT, "robot": WAIT})
    assert info["robot"]["graph_agrees"] and info["robot"]["fault"] is None
    assert 0.1 < info["robot"]["duration_s"] < 1.0  # nothing moves: it settles at once
    env.close()


def test_the_panda_vector_env_refuses_the_graph():
    from hri_envs.errors import ConfigError
    from hri_envs.physics.panda.warp.vector import PandaVectorEnv

    with pytest.raises(ConfigError, match="physics backends mujoco, mjwarp"):
        PandaVectorEnv(2, backend="graph")


def test_speed_reports_the_physics_beside_the_c_backend(capsys):
    """``hri-bench speed --physics --size tiny --physics-worlds 2`` for real (no timing
    thresholds): the C figures, the device, world-steps/s and real-time factor per number of
    worlds, consistent with each other."""
    import json

    from hri_bench.cli import main

    assert main(["speed", "--json", "--size", "tiny", "--no-jax", "--physics",
                 "--physics-worlds", "2"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    figures = json.loads(out[-1])
    assert figures["physics_warp_device"] == "cpu"
    # The figures are rounded (world-steps/s to 0.1, real-time factors to 0.01).
    assert figures["physics_c_world_steps_per_s"] * 0.002 == pytest.approx(
        figures["physics_c_realtime_factor"], abs=0.006)
    steps = figures["physics_warp_world_steps_per_s_by_worlds"]
    rtf = figures["physics_warp_realtime_factor_by_worlds"]
    assert set(steps) == set(rtf) == {"2"}
    for n in steps:
        assert steps[n] > 0 and rtf[n] == pytest.approx(steps[n] * 0.002, abs=0.006)
    assert figures["physics_warp_setup_s"] > 0
    assert any(line.startswith("physics_warp_device") for line in out)
    for scenario in ("hanger", "wheel"):  # the continuous envs beside raw mj_step
        env, raw = (figures[f"continuous_{scenario}_{k}_rtf_cpu"] for k in ("env", "raw"))
        assert 0 < env < raw
        assert figures[f"continuous_{scenario}_env_over_raw"] == pytest.approx(
            env / raw, rel=0.05)


def test_the_graph_vector_env_still_refuses_the_simulated_backends():
    import gymnasium as gym

    from hri_envs.errors import ConfigError

    for backend in ("mujoco", "mjwarp"):
        with pytest.raises(ConfigError, match="graph only"):
            gym.make_vec("hri_envs/Hanger-v0", num_envs=2,
                         vectorization_mode="vector_entry_point", backend=backend)


def test_a_missing_extra_names_the_install_command(monkeypatch):
    from hri_envs.errors import MissingExtraError
    from hri_envs.physics.scene.warp import device

    real = importlib.util.find_spec
    monkeypatch.setattr(device.importlib.util, "find_spec",
                        lambda name, *a: None if name == "mink_warp" else real(name, *a))
    with pytest.raises(MissingExtraError, match=r"mink_warp: .*pip install .*\[mjwarp\]"):
        device.require_warp()


def test_the_panda_vector_env_seats_a_human_spec_in_every_env():
    """As the other envs: ``human=HumanSpec(...)`` or its flat keywords; a batch of humans,
    which the N envs would share, is refused."""
    import gymnasium as gym

    import hri_envs  # noqa: F401
    from hri_envs.errors import ConfigError
    from hri_envs.humans.finite_state import FiniteStateHumans
    from hri_envs.humans.spec import HumanSpec
    from hri_envs.humans.splits import MixtureHumans

    def panda_vec(n, **kwargs):
        return gym.make_vec("hri_envs/HangerPanda-v0", num_envs=n,
                            vectorization_mode="vector_entry_point", **kwargs).unwrapped

    population = (MixtureHumans, FiniteStateHumans)
    venv = panda_vec(2, human=HumanSpec(population="test-v2-adaptive"))
    assert all(isinstance(env.human, population) and env.human.n_runs == 1
               for env in venv.envs)
    flat = panda_vec(1, population="test-v2-adaptive")  # the flat keyword reaches the envs
    assert isinstance(flat.envs[0].human, population)
    assert not isinstance(panda_vec(1).envs[0].human, population)
    batch = gym.make_vec("hri_envs/Hanger-v0", num_envs=2,
                         vectorization_mode="vector_entry_point").unwrapped.human
    with pytest.raises(ConfigError, match="seats one human per env") as err:
        panda_vec(2, human=batch)
    assert err.value.field == "human"
