"""The continuous envs (*PandaContinuous-v0) on MuJoCo Warp against the C backend, on Warp's
CPU device.

``make test`` runs this module with tests/test_mjwarp.py in the process of its own for MuJoCo
Warp (one compile, shared kernel cache). A control period costs about the same for 1 or 5
worlds on the CPU device, so the seeded episodes run as the worlds of one batch.

Equality, as stated in docs/physics.md ("Many worlds on MuJoCo Warp"): a seeded episode on
``backend="mjwarp"`` ends in the same step as on ``backend="mujoco"``, terminated or
truncated alike, with the same fault and placement; after every step the object is within
:data:`POS_TOL_M` of the C backend's, and the episode's integral of the sensed wrench, its
human's effort and its return are within :data:`SENSED_TOL` (+ :data:`SENSED_RTOL`),
:data:`EFFORT_RTOL` and :data:`RETURN_TOL` (the slipping grip within
:data:`SLIP_EFFORT_RTOL`).
"""

import importlib.util

import gymnasium as gym
import numpy as np
import pytest

pytestmark = [
    pytest.mark.mjwarp,
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
    pytest.mark.skipif(importlib.util.find_spec("mujoco_warp") is None,
                       reason="the mjwarp extra is not installed"),
]

#: How far the object may be from the C backend's after any step [m] (float32 physics on
#: MuJoCo Warp, mink-warp's IK): largest seen 0.18 mm, in the slipping grip's episode.
POS_TOL_M = 1e-3
#: How far the episode's integral of the sensed wrench (force [N s] and torque [N m s]
#: components) may be from the C backend's: SENSED_TOL + SENSED_RTOL x its size (seen: 0.4 %,
#: the robot leading against a slow human).
SENSED_TOL, SENSED_RTOL = 0.01, 0.01
#: The human's effort over the episode (∫ |F| + |τ| / lever dt), relative.
EFFORT_RTOL = 0.01
#: ... while the handle slips out of the hand: friction at the edge of slipping amplifies
#: float32 differences in the hand's wrench (seen: 11 %; the object within 0.2 mm).
SLIP_EFFORT_RTOL = 0.25
#: The episode's return.
RETURN_TOL = 0.02

HANGER = "hri_envs/HangerPandaContinuous-v0"
B_TO_A = {"start": "B", "intention": "A"}
ALONE = {**B_TO_A, "robot_holds": False}
#: A human agent's action (parallel form): their hand 1 cm ahead and up and turning by
#: 0.018 rad per step, stiff.
HUMAN_ACTION = np.array([-0.5, 0.0, 0.5, 0.3, 0.0, -0.1, 1.0])
#: Bodies other than the default (1.741 m, 75 kg man): a 1st-percentile woman, a tall man.
SMALL_WOMAN = {"sex": "female", "stature_m": 1.48, "body_mass_kg": 45.0, "strength": 0.8}
TALL_MAN = {"stature_m": 1.95, "body_mass_kg": 110.0}
#: (human, reset options, robot policy, human agent's action or None, max_time_s) per world.
CASES = {
    "carried": ({}, B_TO_A, "upper", None, 1.1),  # truncated at the time limit
    # a slow human yields to a robot leading their way
    "leading": ({"reaction_s": 0.0, "speed": 0.3}, B_TO_A, "lead", None, 1.1),
    "human agent": ({}, B_TO_A, "passive", HUMAN_ACTION, 1.1),
    "slip": ({"grip_force_n": 0.3}, ALONE, "passive", None, 1.1),  # dropped
    "too weak": ({"strength": 0.002}, ALONE, "passive", None, 1.1),  # too_weak
    # bodies other than the default, in the same batch (per-world segments and torso)
    "small woman": (SMALL_WOMAN, B_TO_A, "upper", None, 1.1),
    "tall man alone": (TALL_MAN, ALONE, "passive", None, 1.1),
}


def _action(policy, env):
    from baselines.continuous import PASSIVE_ACTION, follow_action

    if policy == "passive":
        return PASSIVE_ACTION.astype(float)
    if policy == "lead":  # along the human's current line, stiff
        human = env.sim.human
        return np.array([*human.lines[human.index].direction, 0.0, 0.0, 0.0, 1.0])
    sim = env.sim  # the action's scale (max_step_m, max_step_rad) is the simulation's
    return follow_action(sim, sim.grip_pose(), sim.human_grip_reference()).astype(float)


def _record(env, out):
    """Per step: the object's position, the sensed wrench, reward, end, info."""
    obs, reward, term, trunc, info = out
    return {"pos": env.sim.object_pose().pos.copy(), "sensed": np.array(env.sim.sensed),
            "reward": reward, "term": term, "trunc": trunc, "info": info, "obs": obs}


def _c_episode(seed, human, options, policy, h_action, max_time_s):
    env = gym.make(HANGER, human=human, max_time_s=max_time_s).unwrapped
    env.reset(seed=seed, options=options)
    steps = []
    while True:
        a = _action(policy, env)
        if h_action is None:
            out = env.step(a)
        else:  # as CarryParallelEnv.step
            out = env._after(env.sim.step(env.sim.command(a), env.sim.human_command(h_action)))
        steps.append(_record(env, out))
        if out[2] or out[3]:
            return steps


def _warp_episodes(cases, seed):
    """Every case a world of one batch: its CarryEnv on a shared WarpCarryWorlds."""
    from hri_envs.physics.carry.env import CarryEnv
    from hri_envs.physics.carry.warp.sim import SHARED, WarpCarrySim
    from hri_envs.physics.carry.warp.worlds import WarpCarryWorlds
    from hri_envs.task.scenarios import scenario_graph

    n = len(cases)
    worlds = WarpCarryWorlds(scenario_graph("hanger"), n)
    with SHARED.sharing([WarpCarrySim(worlds, i) for i in range(n)]):
        envs = [CarryEnv("hanger", backend="mjwarp", human=h, max_time_s=t)
                for h, _, _, _, t in cases]
    for env, (_, options, _, _, _) in zip(envs, cases, strict=True):
        env.reset(seed=seed, options=options)
    steps = [[] for _ in range(n)]
    live = np.ones(n, bool)
    agent = np.array([c[3] is not None for c in cases])
    while live.any():
        rows = np.flatnonzero(live)
        actions = np.stack([_action(cases[i][2], envs[i]) for i in rows])
        h_rows = np.flatnonzero(live & agent)
        human = (worlds.commands(h_rows, np.stack([cases[i][3] for i in h_rows]), human=True)
                 if h_rows.size else None)
        results = worlds.step(worlds.commands(rows, actions), live, human, live & agent)
        for i in rows:
            out = envs[i]._after(results[i])
            steps[i].append(_record(envs[i], out))
            live[i] = not (out[2] or out[3])
    return steps, worlds


@pytest.fixture(scope="module")
def episodes():
    cases = list(CASES.values())
    warp, worlds = _warp_episodes(cases, seed=3)
    c = [_c_episode(3, *case) for case in cases]
    return {"names": list(CASES), "c": c, "warp": warp, "worlds": worlds}


def test_seeded_episodes_equal_the_c_backend(episodes):
    """Each case ends in the same step and the same way (terminated, truncated, fault,
    placement) on both backends; the object stays within POS_TOL_M after every step; the
    sensed wrench's integral, the human's effort and the return agree."""
    for name, c, w in zip(episodes["names"], episodes["c"], episodes["warp"], strict=True):
        assert len(w) == len(c), (name, len(c), len(w))
        cl, wl = c[-1], w[-1]
        assert (wl["term"], wl["trunc"]) == (cl["term"], cl["trunc"]), name
        for key in ("fault", "placed", "reached_intention"):
            assert wl["info"][key] == cl["info"][key], (name, key)
        for k, (cs, ws) in enumerate(zip(c, w, strict=True)):
            assert np.linalg.norm(ws["pos"] - cs["pos"]) < POS_TOL_M, (name, k)
        dt = 0.04
        sensed_c = sum(s["sensed"] for s in c) * dt
        sensed_w = sum(s["sensed"] for s in w) * dt
        np.testing.assert_allclose(sensed_w, sensed_c, rtol=SENSED_RTOL, atol=SENSED_TOL,
                                   err_msg=name)
        rtol = SLIP_EFFORT_RTOL if name == "slip" else EFFORT_RTOL
        assert wl["info"]["episode_effort"] == pytest.approx(cl["info"]["episode_effort"],
                                                             rel=rtol), name
        assert sum(s["reward"] for s in w) == pytest.approx(sum(s["reward"] for s in c),
                                                            abs=RETURN_TOL), name


def test_the_faults_are_per_world(episodes):
    """In the same batch the slipping grip drops the object, the weak human is too weak,
    and the three others run to the time limit without a fault; the slip's detail is the C
    backend's."""
    ends = {name: w[-1]["info"] for name, w in zip(episodes["names"], episodes["warp"],
                                                   strict=True)}
    assert ends["slip"]["fault"] == "dropped"
    assert "slipped out of the human's hand" in ends["slip"]["fault_detail"]
    c_slip = episodes["c"][episodes["names"].index("slip")][-1]["info"]["fault_detail"]
    assert ends["slip"]["fault_detail"] == c_slip
    assert ends["too weak"]["fault"] == "too_weak"
    assert "can lift at most" in ends["too weak"]["fault_detail"]
    for name in ("carried", "leading", "human agent"):
        assert ends[name]["fault"] is None and ends[name]["time_s"] == pytest.approx(1.12)
    worlds = episodes["worlds"]
    assert worlds.device == "cpu" and worlds.n == len(CASES)
    # The human's grip is a contact in every world: palm and pad on the handle.
    handle = worlds.template.arm.handle_geom
    assert worlds.touching(np.arange(worlds.n), handle)[[0, 1, 2]].all()


def test_bodies_are_per_world(episodes):
    """The worlds of other bodies run without a fault to the time limit (equal to the C
    backend: test_seeded_episodes_equal_the_c_backend), each with its own segments: the
    forearm's position on the upper arm (the upper arm's length) and mass per world."""
    names, worlds = episodes["names"], episodes["worlds"]
    for name in ("small woman", "tall man alone"):
        info = episodes["warp"][names.index(name)][-1]["info"]
        assert info["fault"] is None and info["time_s"] == pytest.approx(1.12), name
    import mujoco

    forearm = mujoco.mj_name2id(worlds.template.model, mujoco.mjtObj.mjOBJ_BODY,
                                "human_forearm")
    pos = worlds.m.body_pos.numpy()[:, forearm, 2]
    mass = worlds.m.body_mass.numpy()[:, forearm]
    i, j, k = names.index("carried"), names.index("small woman"), names.index("tall man alone")
    assert pos[i] == pytest.approx(-0.2817) and mass[i] == pytest.approx(0.0162 * 75)
    assert pos[j] == pytest.approx(-0.2751 * 1.48 / 1.735)  # her upper arm
    assert mass[k] == pytest.approx(0.0162 * 110)


def _assert_obs_close(warp, c):
    """Observations within 1e-3, the sensed wrench (entries 34-39 on the hanger) 0.01 N."""
    wrench = np.zeros(len(c), bool)
    wrench[34:40] = True
    np.testing.assert_allclose(warp[~wrench], c[~wrench], atol=1e-3)
    np.testing.assert_allclose(warp[wrench], c[wrench], atol=0.01)


def test_the_vector_env_matches_the_c_env_and_autoresets():
    """make_vec on the hanger's continuous id: 2 envs in one WarpCarryWorlds, 5-step
    episodes. Env 0 (seed 7) has the C env's observations (within 1e-3, the sensed wrench
    within 0.01 N: float32), rewards and ends; both truncate together and restart in the
    next step (reward 0)."""
    from hri_envs.physics.carry.warp.vector import CarryVectorEnv

    env = gym.make_vec(HANGER, num_envs=2, vectorization_mode="vector_entry_point",
                       max_time_s=0.2)
    venv = env.unwrapped
    assert isinstance(venv, CarryVectorEnv) and venv.worlds.n == 2
    obs, _ = env.reset(seed=7, options=B_TO_A)
    c_env = gym.make(HANGER, max_time_s=0.2)
    c_obs, _ = c_env.reset(seed=7, options=B_TO_A)
    _assert_obs_close(obs[0], c_obs)
    assert obs.shape == (2, c_obs.shape[0]) and env.action_space.shape == (2, 7)
    action = np.array([0.5, -0.5, 0.2, 0.0, 0.1, 0.0, 0.6])
    for _ in range(5):
        obs, rew, term, trunc, info = env.step(np.stack([action, -action]))
        c_obs, c_rew, c_term, c_trunc, _ = c_env.step(action)
        _assert_obs_close(obs[0], c_obs)
        assert rew[0] == pytest.approx(c_rew, abs=1e-3)
        assert (term[0], trunc[0]) == (c_term, c_trunc)
        assert info["_progress"].all()
    assert trunc.all() and not term.any()
    obs, rew, term, trunc, info = env.step(np.stack([action, action]))
    assert (rew == 0).all() and not (term | trunc).any()
    assert "_time_s" not in info  # nothing stepped: both envs restarted
    c_obs, _ = c_env.reset()  # its generator goes on from seed 7, as env 0's does
    _assert_obs_close(obs[0], c_obs)
    env.close()


def test_the_single_and_parallel_envs_run_on_mjwarp_and_the_muscles_are_refused():
    from hri_envs import hanger_continuous_v0
    from hri_envs.errors import ConfigError
    from hri_envs.physics.carry.warp.sim import WarpCarrySim

    env = hanger_continuous_v0.parallel_env(backend="mjwarp", max_time_s=0.08)
    assert isinstance(env.env.sim, WarpCarrySim) and env.env.sim.worlds.n == 1
    obs, _ = env.reset(seed=0, options=B_TO_A)
    assert env.observation_space("robot").contains(obs["robot"])
    obs, rew, term, trunc, info = env.step({"robot": np.zeros(7), "human": HUMAN_ACTION})
    assert info["robot"]["fault"] is None and not term["robot"]
    env.close()
    with pytest.raises(ConfigError, match="allowed"):
        gym.make(HANGER, backend="graph")
    with pytest.raises(ConfigError, match="allowed there: torque"):
        gym.make(HANGER, backend="mjwarp", drive="muscle")
    from hri_envs.envs.backends import carry_backend

    with pytest.raises(ConfigError, match="drive='muscle' does not run on backend='mjwarp'"):
        carry_backend("mjwarp", "muscle")  # refused by the registry, before any world
    with pytest.raises(ConfigError, match="no vector env on backend='mujoco'"):
        gym.make_vec(HANGER, num_envs=2, vectorization_mode="vector_entry_point",
                     backend="mujoco")


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_whole_episodes_of_the_upper_reference_equal_the_c_backend(scenario):
    """A whole episode of the upper reference from B to A (seed 3): placed at A in the same
    step on both backends, the object within POS_TOL_M after every step, the effort within
    EFFORT_RTOL, the return within RETURN_TOL (2-3 minutes each on this machine)."""
    from baselines.continuous import UpperReference

    env_id = {"hanger": HANGER, "wheel": "hri_envs/WheelPandaContinuous-v0"}[scenario]
    out = {}
    for backend in ("mujoco", "mjwarp"):
        env = gym.make(env_id, backend=backend).unwrapped
        obs, _ = env.reset(seed=3, options=B_TO_A)
        policy, steps = UpperReference(), []
        policy.attach(env)
        policy.begin_episode(env.robot_task())
        while True:
            step = _record(env, env.step(policy.act(obs)))
            obs = step["obs"]
            steps.append(step)
            if step["term"] or step["trunc"]:
                break
        out[backend] = steps
        env.close()
    c, w = out["mujoco"], out["mjwarp"]
    assert len(w) == len(c)
    assert w[-1]["term"] and w[-1]["info"]["reached_intention"]
    for key in ("fault", "placed"):
        assert w[-1]["info"][key] == c[-1]["info"][key]
    gap = max(np.linalg.norm(a["pos"] - b["pos"]) for a, b in zip(c, w, strict=True))
    print(f"{scenario}: {len(c)} steps, the object at most {gap:.2e} m apart, effort "
          f"{c[-1]['info']['episode_effort']:.3f} / {w[-1]['info']['episode_effort']:.3f}")
    assert gap < POS_TOL_M
    assert w[-1]["info"]["episode_effort"] == pytest.approx(
        c[-1]["info"]["episode_effort"], rel=EFFORT_RTOL)
    assert sum(s["reward"] for s in w) == pytest.approx(sum(s["reward"] for s in c),
                                                        abs=RETURN_TOL)


def test_the_picture_on_mjwarp_is_the_c_backends():
    """The same renderer draws the Warp world (copied into the C model): the same camera,
    fitted at reset, and the same picture."""
    shots = {}
    for backend in ("mujoco", "mjwarp"):
        env = gym.make(HANGER, backend=backend, render_mode="rgb_array",
                       render_size=(160, 120)).unwrapped
        env.reset(seed=0, options=B_TO_A)
        shots[backend] = (env.render().astype(float), env.pictures.renderer.pose)
        env.close()
    (c_frame, c_pose), (w_frame, w_pose) = shots["mujoco"], shots["mjwarp"]
    assert np.allclose(c_pose.lookat, w_pose.lookat, atol=1e-3)
    assert np.allclose((c_pose.azimuth, c_pose.elevation), (w_pose.azimuth, w_pose.elevation),
                       atol=1e-3)
    assert np.abs(c_frame - w_frame).mean() < 2.0 and c_frame.std() > 10
