"""The continuous-control envs with the whole human arm (hri_envs/*PandaContinuous-v0)."""

from __future__ import annotations

import importlib.util

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("mink")

import hri_envs  # noqa: E402,F401
from hri_envs.errors import ActionError, ConfigError  # noqa: E402
from hri_envs.physics.carry.env import CarryEnv  # noqa: E402
from hri_envs.physics.carry.human.intention import HumanParams  # noqa: E402
from hri_envs.physics.carry.parallel import parallel_env  # noqa: E402
from hri_envs.physics.carry.sim import CarrySim  # noqa: E402
from hri_envs.physics.scene.kinematics import rotation_error  # noqa: E402
from hri_envs.task.scenarios import scenario_graph  # noqa: E402

IDS = ["hri_envs/HangerPandaContinuous-v0", "hri_envs/WheelPandaContinuous-v0",
       "hri_envs/HangerPandaContinuous-v1", "hri_envs/WheelPandaContinuous-v1"]
PASSIVE = np.array([0, 0, 0, 0, 0, 0, -1.0])


def _follow(sim: CarrySim) -> np.ndarray:
    """The upper reference's action: towards the grip pose of the human's reference."""
    ref, grip = sim.human_grip_reference(), sim.grip_pose()
    return np.concatenate([np.clip((ref.pos - grip.pos) / sim.max_step_m, -1, 1),
                           np.clip(rotation_error(ref.quat, grip.quat) / sim.max_step_rad,
                                   -1, 1), [1.0]])


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_and_sb3_check_env(env_id: str) -> None:
    from gymnasium.utils.env_checker import check_env

    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    if importlib.util.find_spec("stable_baselines3") is not None:
        from stable_baselines3.common.env_checker import check_env as sb3_check_env

        sb3_check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("module", ["hanger_continuous_v0", "wheel_continuous_v0",
                                    "hanger_continuous_v1", "wheel_continuous_v1"])
def test_parallel_api(module: str) -> None:
    import importlib

    from pettingzoo.test import parallel_api_test

    env = importlib.import_module(f"hri_envs.{module}").parallel_env(max_time_s=1.0)
    parallel_api_test(env, num_cycles=30)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        assert all(env.observation_space(a).contains(o) for a, o in obs.items())
        obs, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})


def test_intention_is_not_observed_by_the_robot() -> None:
    """The robot's observation is the same whichever goal the human has; the human's not."""
    env = parallel_env("hanger")
    a, _ = env.reset(seed=3, options={"start": "B", "intention": "A"})
    b, _ = env.reset(seed=3, options={"start": "B", "intention": "C"})
    assert np.array_equal(a["robot"], b["robot"])
    assert not np.array_equal(a["human"], b["human"])


def test_bad_input_is_refused_with_what_is_allowed() -> None:
    env = CarryEnv("hanger")
    env.reset(seed=0)
    for bad in ([0.0] * 6, [2.0] + [0.0] * 6, "left", [np.nan] * 7):
        with pytest.raises(ActionError, match=r"robot's action .* \[-1, 1\]"):
            env.step(bad)
    with pytest.raises(ConfigError, match="allowed: torque, muscle"):
        CarryEnv("hanger", drive="hydraulic")
    with pytest.raises(ConfigError, match="allowed: preset"):
        CarryEnv("hanger", human={"strenght": 2.0})
    with pytest.raises(ConfigError, match="allowed: progress, effort"):
        CarryEnv("hanger", reward={"speed": 1.0})
    with pytest.raises(ConfigError, match="support index"):
        env.reset(options={"start": "Z"})


def test_same_seed_same_episode() -> None:
    def run() -> list[np.ndarray]:
        env = gym.make(IDS[0])
        env.reset(seed=11)
        rng = np.random.default_rng(0)
        out = []
        for _ in range(10):
            obs, reward, *_ = env.step(rng.uniform(-1, 1, 7))
            out.append(np.append(obs, reward))  # the sensed wrench's noise included
        return out

    assert all(np.array_equal(a, b) for a, b in zip(run(), run(), strict=True))


def test_the_human_pushes_against_a_robot_going_the_wrong_way() -> None:
    """Against the human's route the human's hand pushes back (effort, disagreement)
    far more than when the robot goes their way.
    """
    sim = CarrySim(scenario_graph("hanger"))

    def effort(wrong: bool) -> tuple[float, float]:
        sim.reset(1, 0, np.random.default_rng(0), human=HumanParams(reaction_s=0.0))
        total = disagree = 0.0
        for _ in range(40):
            a = _follow(sim)
            if wrong:  # the opposite way along the route's first line (take-off: -y)
                a = np.array([0, 1.0, 0, 0, 0, 0, 1.0])
            res = sim.step(sim.command(a))
            total, disagree = total + res.effort, disagree + res.disagreement
        return total, disagree

    (good, good_dis), (bad, bad_dis) = effort(False), effort(True)
    assert bad > 3 * good
    assert bad_dis > 3 * good_dis + 0.1


def test_the_human_yields_to_a_robot_leading_their_way() -> None:
    """A robot that leads along the route moves the human's reference ahead of its clock."""
    sim = CarrySim(scenario_graph("hanger"))
    sim.reset(1, 0, np.random.default_rng(0), human=HumanParams(reaction_s=0.0, speed=0.3))
    clock = 0.0
    for _ in range(25):
        line = sim.human.lines[sim.human.index]
        ahead = (line.direction * 1.0)
        sim.step(sim.command(np.array([*ahead, 0, 0, 0, 1.0])))
        clock += sim.dt_step
    assert sim.human.index > 0 or sim.human.t > 1.5 * clock


def test_a_weak_human_cannot_carry_the_object_alone_and_the_env_says_why() -> None:
    env = CarryEnv("hanger", human={"strength": 0.002})
    env.reset(seed=0, options={"start": "B", "intention": "A", "robot_holds": False})
    assert env.sim.max_lift_n() < env.sim.design.object_mass * 9.81
    info: dict = {}
    for _ in range(100):
        _, _, term, trunc, info = env.step(PASSIVE)
        if term or trunc:
            break
    assert term and info["fault"] in ("dropped", "too_weak")
    assert "can lift at most" in info["fault_detail"]
    assert "weighs" in info["fault_detail"]


def test_an_adult_carries_the_object_alone() -> None:
    """The same start with the adult's strength: the human alone places it at the goal."""
    env = CarryEnv("hanger")
    env.reset(seed=0, options={"start": "B", "intention": "A", "robot_holds": False})
    info: dict = {}
    for _ in range(env.max_steps):
        _, _, term, trunc, info = env.step(PASSIVE)
        if term or trunc:
            break
    assert info["fault"] is None and info["reached_intention"]


def test_the_effort_is_the_hands_wrench_on_the_object() -> None:
    """A human carrying the hanger alone holds up its weight: the linear impulse of their
    hand's wrench per second is the weight (within the motion's accelerations).
    """
    env = CarryEnv("hanger", human={"speed": 0.5})
    env.reset(seed=0, options={"start": "B", "intention": "A", "robot_holds": False})
    forces = []
    for _ in range(200):
        _, _, term, trunc, info = env.step(PASSIVE)
        if info["progress"] > 0.3:  # off the seat, carried
            forces.append(info["linear_impulse"] / env.sim.dt_step)
        if term or trunc:
            break
    weight = env.sim.design.object_mass * 9.81
    assert len(forces) > 20
    assert abs(np.median(forces) - weight) < 0.2 * weight


def test_a_weak_grip_slips() -> None:
    """With a grip far weaker than the load, the handle slips out of the hand."""
    env = CarryEnv("hanger", human={"grip_force_n": 0.3})
    env.reset(seed=0, options={"start": "B", "intention": "A", "robot_holds": False})
    info: dict = {}
    for _ in range(200):
        _, _, term, trunc, info = env.step(PASSIVE)
        if term or trunc:
            break
    assert info["fault"] == "dropped"
    assert "slipped out of the human's hand" in info["fault_detail"]


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_the_upper_reference_places_the_object_with_less_effort(scenario: str) -> None:
    from baselines.continuous import PassiveFloor, UpperReference, run_episode

    env = CarryEnv(scenario)
    options = {"start": "B", "intention": "A"}
    upper = run_episode(env, UpperReference(), seed=1, options=options)
    passive = run_episode(env, PassiveFloor(), seed=1, options=options)
    assert upper["reached_intention"] and upper["fault"] is None
    assert upper["effort"] < passive["effort"]


def test_the_lifted_learner_acts_through_primitives_and_learns() -> None:
    """The Learner sees the abstract states the object passes, and learns at the end."""
    from baselines.continuous import LiftedLearner, run_episode

    env = CarryEnv("hanger", max_time_s=6.0)
    learner = LiftedLearner("hanger", seed=0)
    theta = learner.agent.batch.theta.copy()  # type: ignore[attr-defined]
    run_episode(env, learner, seed=0, options={"start": "B", "intention": "A"})
    assert len(set(learner.states)) >= 2  # the object left its support state
    assert learner.agent.batch.episodes == 1  # type: ignore[attr-defined]
    run_episode(env, learner, seed=1, options={"start": "A", "intention": "B"})
    assert learner.agent.batch.episodes == 2  # type: ignore[attr-defined]
    assert theta.shape == learner.agent.batch.theta.shape  # type: ignore[attr-defined]


def test_muscle_driven_arm_makes_the_torques_it_is_asked_for() -> None:
    """MyoSuite's arm in the scene: the coupling's derivative is the polynomials' (finite
    differences), the activations (in [0, 1]) make a modest torque request, and the arm
    carries the wheel with the upper reference without a fault.
    """
    pytest.importorskip("myo_sim")
    pytest.importorskip("scipy")
    import mujoco

    sim = CarrySim(scenario_graph("wheel"), drive="muscle")
    sim.reset(1, 0, np.random.default_rng(0))
    coupling, data = sim.coupling, sim.data
    c = coupling.update(data).copy()
    q_ind = data.qpos[sim.arm.arm_qpos].copy()
    dep = coupling.dofs[len(q_ind):]
    h = 1e-6
    for j in range(len(q_ind)):
        data.qpos[sim.arm.arm_qpos] = q_ind
        data.qpos[sim.arm.arm_qpos[j]] += h
        coupling.apply(data)
        plus = data.qpos[sim.model.jnt_qposadr[[int(np.flatnonzero(sim.model.jnt_dofadr == d)[0])
                                                for d in dep]]].copy()
        data.qpos[sim.arm.arm_qpos[j]] -= 2 * h
        coupling.apply(data)
        minus = data.qpos[sim.model.jnt_qposadr[[int(np.flatnonzero(sim.model.jnt_dofadr == d)[0])
                                                 for d in dep]]].copy()
        assert np.allclose((plus - minus) / (2 * h), c[len(q_ind):, j], atol=1e-4)
    data.qpos[sim.arm.arm_qpos] = q_ind
    coupling.apply(data)
    mujoco.mj_forward(sim.model, data)
    want = np.array([2.0, -1.0, 0.5, 3.0, 0.2, 0.1, -0.1])
    made = sim.arm_drive.apply(data, want)
    act = sim.arm_drive.activation  # type: ignore[attr-defined]
    assert act.min() >= 0.0 and act.max() <= 1.0 and act.max() > 0.0
    assert np.allclose(made, want, atol=0.3)
    for _ in range(25):
        res = sim.step(sim.command(_follow(sim)))
        assert res.fault is None


def test_the_muscle_arm_on_the_hanger_resets_everywhere_and_slips_off_a() -> None:
    """What the muscle drive does on the hanger (docs/physics.md, "Two drives"): every
    (start, goal) pair resets without a fault; from B the upper reference places the object
    on C; from A the handle slips out of the hand in the first steps, whatever the robot
    does (the arm's posture on A's peg)."""
    pytest.importorskip("myo_sim")
    from baselines.continuous import PassiveFloor, UpperReference, run_episode

    env = gym.make("hri_envs/HangerPandaContinuous-v1", drive="muscle")
    for start, goal in [("A", "B"), ("A", "C"), ("B", "A"), ("B", "C"), ("C", "A"), ("C", "B")]:
        env.reset(seed=0, options={"start": start, "intention": goal})
        assert env.unwrapped._fault is None, (start, goal)  # no IKFailure at the reset
    placed = run_episode(env, UpperReference(), seed=0, options={"start": "B", "intention": "C"})
    assert placed["fault"] is None and placed["placed"] == 2 and placed["reached_intention"]
    for policy in (UpperReference(), PassiveFloor()):
        slipped = run_episode(env, policy, seed=0, options={"start": "A", "intention": "B"})
        assert slipped["fault"] == "slipped" and slipped["steps"] <= 5, slipped["info"]
    env.close()


def test_building_the_muscle_arm_prints_and_writes_nothing(tmp_path) -> None:
    """myo-sim's composition of the arm makes MuJoCo warn "Attaching a spec with an empty
    prefix" on every build; MuJoCo's default handler prints it and appends it to
    MUJOCO_LOG.TXT in the current folder. Neither happens."""
    pytest.importorskip("myo_sim")
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = ("import gymnasium as gym, hri_envs\n"
            "env = gym.make('hri_envs/WheelPandaContinuous-v1', drive='muscle')\n"
            "env.reset(seed=0)\n"
            "gym.make('hri_envs/HangerPandaContinuous-v1', drive='muscle').reset(seed=0)\n")
    done = subprocess.run([sys.executable, "-W", "error::UserWarning", "-c", code],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(root)})
    assert done.returncode == 0, done.stderr
    assert "empty prefix" not in done.stdout + done.stderr
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
