"""The continuous envs' v1: a reward that pays for placing, and nothing of the intention in
``info`` (or in the robot's reach) during an episode; v0 keeps its numbers.
"""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401
from agents.physical import PhysicalAgent, run_physical_episode
from baselines.continuous import PassiveFloor, UpperReference, follow_action, run_episode
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.env import HiddenIntentionError
from hri_envs.physics.carry.reward import EFFORT_LEVER_M, STALL_S, PlacingReward, StallClock
from hri_envs.physics.scene.kinematics import Pose

HANGER_V1, WHEEL_V1 = "hri_envs/HangerPandaContinuous-v1", "hri_envs/WheelPandaContinuous-v1"
HANGER_V0 = "hri_envs/HangerPandaContinuous-v0"
B_TO_A = {"start": "B", "intention": "A"}


def _make(env_id: str, **kwargs: object) -> gym.Env:
    with warnings.catch_warnings():  # gymnasium says v0 is out of date: it is, on purpose
        warnings.simplefilter("ignore", DeprecationWarning)
        return gym.make(env_id, **kwargs)


class Hover(PhysicalAgent):
    """Carries the object the human's way, then holds it 6 cm above where it was when the
    object came within 12 cm of the goal's seat: it never places (a test reference: it
    reads the goal).
    """

    name = "hover"
    privileged = True

    def attach(self, env: object) -> None:
        self.env = env

    def begin_episode(self, task: object) -> None:
        self.task, self.hold = task, None

    def act(self, observation: np.ndarray) -> np.ndarray:
        sim = self.env.sim  # type: ignore[attr-defined]
        grip = sim.grip_pose()
        goal = sim.seat_positions()[self.env._intention]  # type: ignore[attr-defined]
        if self.hold is None and np.linalg.norm(sim.object_pose().pos - goal) < 0.12:
            self.hold = Pose(grip.pos + np.array([0.0, 0.0, 0.06]), grip.quat)
        target = self.hold if self.hold is not None else sim.human_grip_reference()
        return follow_action(self.task, grip, target)  # type: ignore[arg-type]


class Plunge(PhysicalAgent):
    """Pushes the object down, stiff, until it slips out of the human's hand or drops."""

    name = "plunge"

    def act(self, observation: np.ndarray) -> np.ndarray:
        return np.array([0, 0, -1, 0, 0, 0, 1.0], dtype=np.float32)


def test_v0_keeps_its_numbers() -> None:
    """The frozen v0 id: a seeded episode of the upper reference as before v1 existed."""
    row = run_episode(_make(HANGER_V0), UpperReference(), seed=0)
    assert row["steps"] == 139 and row["placed"] == 1 and row["reached_intention"]
    assert row["effort"] == pytest.approx(13.016233037585884, rel=1e-6)
    assert row["return"] == pytest.approx(9.727, abs=1e-3)
    assert set(row["info"]) >= {"progress", "episode_effort", "reached_intention"}


@pytest.mark.parametrize("env_id", [HANGER_V1, WHEEL_V1])
def test_a_robot_that_never_places_scores_below_passive(env_id: str) -> None:
    """Hovering near the goal (v0 credited its progress) and pushing the object out of the
    human's hand (v0 charged little effort for failing early) both score below the passive
    robot, which lets the human place the object.
    """
    env = _make(env_id)
    passive = run_episode(env, PassiveFloor(), seed=0)
    assert passive["reached_intention"]
    for agent in (Hover(), Plunge()):
        row = run_episode(env, agent, seed=0)
        assert row["placed"] == -1
        assert row["return"] < passive["return"] - 5.0, (agent.name, row["return"])
        assert row["outcome"].metrics["outcome"] in ("timeout", "slipped", "dropped")


def test_during_an_episode_info_holds_only_what_the_robot_observes() -> None:
    """info before the end: time and stall, both functions of the observation; the
    intention is hidden (and the unwrapped env refuses it); the end reveals it."""
    env = _make(HANGER_V1)
    base = env.unwrapped
    obs, info = env.reset(seed=2, options=B_TO_A)
    assert info == {"time_s": 0.0, "stalled": False}
    task = base.robot_task()
    clock = StallClock(task.dt)
    clock.reset(task.part(obs, "object_pos").astype(float),
                task.part(obs, "object_quat").astype(float))
    with pytest.raises(HiddenIntentionError):
        _ = base.intention
    agent = PassiveFloor()
    steps = 0
    while True:
        obs, _, term, trunc, info = env.step(agent.act(obs))
        steps += 1
        stalled = clock.update(task.part(obs, "object_pos").astype(float),
                               task.part(obs, "object_quat").astype(float))
        if term or trunc:
            break
        assert set(info) == {"time_s", "stalled"}
        assert info["time_s"] == pytest.approx(steps * task.dt)
        assert info["stalled"] == stalled
        assert info["time_s"] == pytest.approx(float(task.part(obs, "time")[0])
                                               * task.time_limit_s, abs=1e-5)
    assert base.intention == 0  # revealed at the end
    ep = info["episode"]
    assert ep["intention"] == 0 and info["reached_intention"] and ep["outcome"] == "placed"
    assert "progress" not in info


def test_the_episode_reports_the_interaction_figures_at_its_end() -> None:
    env = _make(HANGER_V1)
    run = run_physical_episode(env, PassiveFloor(), seed=0)
    ep = run.outcome.metrics
    for key in ("effort", "effort_per_progress", "linear_impulse", "angular_impulse",
                "peak_force", "rms_force", "rms_jerk", "disagreement", "stall_s",
                "time_to_place_s", "return", "progress"):
        assert math.isfinite(ep[key]), key
    assert ep["effort"] == pytest.approx(ep["linear_impulse"]
                                         + ep["angular_impulse"] / EFFORT_LEVER_M)
    assert ep["effort_per_progress"] == pytest.approx(ep["effort"] / ep["progress"])
    assert 0 < ep["rms_force"] <= ep["peak_force"]
    assert ep["time_to_place_s"] == pytest.approx(run.steps * 0.04)
    assert ep["return"] == pytest.approx(run.reward)
    assert run.outcome.intention == run.outcome.placed == ep["intention"]


def test_a_timeout_and_a_stall_cost() -> None:
    """A human who waits 4 s before moving, a 3.2 s limit: the object rests on its start
    for 3.2 s, stalls after 2 s, the episode times out: the stall and the time-out cost."""
    w = PlacingReward()
    env = _make(HANGER_V1, max_time_s=3.2, human={"reaction_s": 4.0})
    run = run_physical_episode(env, PassiveFloor(), seed=0, options=B_TO_A)
    ep = run.outcome.metrics
    assert run.outcome.truncated and ep["outcome"] == "timeout" and run.outcome.intention == -1
    assert ep["stall_s"] == pytest.approx(3.2 - STALL_S, abs=0.05)
    assert run.reward == pytest.approx(-w.fail - w.stall * ep["stall_s"]
                                       - w.effort * ep["effort"]
                                       - w.disagreement * ep["disagreement"], abs=1e-9)
    assert math.isnan(ep["time_to_place_s"])


def test_weights_and_versions_are_checked() -> None:
    with pytest.raises(ConfigError, match="allowed: place, fail, effort"):
        _make(HANGER_V1, reward={"progress": 1.0})
    with pytest.raises(ConfigError, match="allowed: progress"):
        _make(HANGER_V0, reward={"place": 1.0})
    with pytest.raises(ConfigError, match="v1 ids"):
        _make(HANGER_V0, population="train")
    with pytest.raises(ConfigError, match="allowed: 0, 1"):
        _make(HANGER_V1, version=2)


def test_a_robot_gets_the_task_not_the_env() -> None:
    """run_physical_episode hands a robot the episode's public facts only; a reference
    (privileged) is handed the env too."""

    class Robot(PhysicalAgent):
        def begin_episode(self, task: object) -> None:
            self.task = task

        def act(self, observation: np.ndarray) -> np.ndarray:
            return np.array([0, 0, 0, 0, 0, 0, -1.0], dtype=np.float32)

    env = _make(HANGER_V1, max_time_s=0.2)
    robot = Robot()
    run_physical_episode(env, robot, seed=0)
    assert not hasattr(robot, "env")
    assert robot.task.start == env.unwrapped.start and robot.task.n_supports == 3
    with pytest.raises(KeyError, match="parts: object_pos"):
        robot.task.part(np.zeros(53), "intention")
    with pytest.raises(ConfigError, match="not privileged"):
        robot.attach(env.unwrapped)


def test_the_parallel_v1_form() -> None:
    from hri_envs import hanger_continuous_v1

    env = hanger_continuous_v1.parallel_env(max_time_s=0.2)
    obs, _ = env.reset(seed=0, options=B_TO_A)
    assert obs["human"][-3:].tolist() == [1.0, 0.0, 0.0]  # the human knows their goal
    assert env.metadata["name"] == "carry_continuous_v1"
    still = np.array([0, 0, 0, 0, 0, 0, 1.0], dtype=np.float32)
    _, _, _, _, infos = env.step({"robot": still, "human": still})
    assert set(infos["robot"]) == {"time_s", "stalled"}


def test_the_costs_stop_at_the_cap_so_placing_always_scores_above_failing() -> None:
    """A cap of 0.5 on the per-step costs: a placed episode returns place - 0.5 at least,
    and the episode's charged cost is the cap (the human's effort is reported in full)."""
    env = _make(HANGER_V1, reward={"cost_cap": 0.5})
    run = run_physical_episode(env, PassiveFloor(), seed=0)
    ep = run.outcome.metrics
    assert ep["outcome"] == "placed" and ep["effort"] * 0.02 > 0.5
    assert ep["cost"] == pytest.approx(0.5)
    assert run.reward == pytest.approx(10.0 - 0.5)
    hover = run_physical_episode(_make(HANGER_V1, reward={"cost_cap": 0.5}), Hover(),
                                 seed=0)
    assert hover.reward == pytest.approx(-5.0 - 0.5)
