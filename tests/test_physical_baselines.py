"""The physical baselines (``baselines.physical``): they run through the robot protocol
without the env, the admittance follows a sensed push, the goal filter reads the push's
direction, the blend's weight grows with its confidence, and the fixed admittance places
the object with less effort than the passive robot.
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import hri_envs  # noqa: F401
from agents.physical import PhysicalAgent, run_physical_episode
from baselines.physical import PHYSICAL_AGENTS, make_physical_agent
from baselines.physical.admittance import (
    AdmittanceGains,
    FixedAdmittance,
    VariableAdmittance,
    VariableGains,
)
from baselines.physical.blend import BlendParams, GoalBlend, arbitration
from baselines.physical.hindsight import GoalQMDP
from baselines.physical.routes import FilterParams, RouteFilter, Routes
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.robot_view import RobotTask, observation_layout
from hri_envs.physics.scene.design import design_for
from hri_envs.task.scenarios import graph_of, scenario_graph

HANGER_V1, WHEEL_V1 = "hri_envs/HangerPandaContinuous-v1", "hri_envs/WheelPandaContinuous-v1"
A, B, C = 0, 1, 2


def _make(env_id: str, **kwargs: object) -> gym.Env:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return gym.make(env_id, **kwargs)


def _task(start: int = B) -> RobotTask:
    """The hanger's public facts with ``start`` (no env needed)."""
    graph = scenario_graph("hanger")
    seats = np.array([s.position for s in graph.scenario.supports])
    return RobotTask("hanger", graph, graph.scenario, start, seats, None, 0.04, 30.0, 0.02,
                     0.06, design_for(graph), observation_layout(7, 3))


def _observation(task: RobotTask, pos: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """An observation with the object at rest at ``pos`` (the start's orientation), the
    robot's grip where the design puts it, and the wrist sensing ``wrench``.
    """
    obs = np.zeros(max(s.stop for s in task.layout_names.values()), dtype=np.float32)
    names = task.layout_names
    quat = task.geometry.orientations[task.geometry.supports[task.start].orientation]
    obs[names["object_pos"]] = pos
    obs[names["object_quat"]] = quat
    obs[names["grip_pos"]] = pos + task.design.grip_pos  # near enough: only r = grip - pos
    obs[names["grip_quat"]] = quat
    obs[names["wrench"]] = wrench
    return obs


def _free(task: RobotTask) -> np.ndarray:
    """A point 20 cm above the start's seat: no seat holds the object there."""
    return task.seats[task.start] + np.array([0.0, 0.0, 0.2])


def _reaches(obj: object, targets: list[object], depth: int = 3) -> bool:
    """Whether ``obj`` holds one of ``targets`` within ``depth`` attribute steps."""
    if any(obj is t for t in targets):
        return True
    if depth == 0 or isinstance(obj, str | bytes | int | float | np.ndarray):
        return False
    items = (list(obj.values()) if isinstance(obj, dict) else
             list(obj) if isinstance(obj, list | tuple) else list(vars(obj).values())
             if hasattr(obj, "__dict__") else [])
    return any(_reaches(v, targets, depth - 1) for v in items)


@pytest.fixture(scope="module")
def envs() -> dict[str, gym.Env]:
    return {"hanger": _make(HANGER_V1, max_time_s=1.2), "wheel": _make(WHEEL_V1, max_time_s=1.2)}


def test_the_registry_names_the_baselines_and_their_references() -> None:
    assert set(PHYSICAL_AGENTS) >= {"upper", "passive", "admittance", "variable-admittance",
                                    "goal-blend", "goal-qmdp", "learner"}
    assert [n for n, e in PHYSICAL_AGENTS.items() if e.privileged] == ["upper"]
    assert [n for n, e in PHYSICAL_AGENTS.items() if e.reference] == ["upper", "passive"]
    for name, entry in PHYSICAL_AGENTS.items():
        agent = entry("hanger", 0)
        assert isinstance(agent, PhysicalAgent) and entry.description
        assert agent.privileged == entry.privileged, name
    with pytest.raises(ConfigError, match="allowed: upper, passive"):
        make_physical_agent("oracle", "hanger")


@pytest.mark.parametrize("make", [FixedAdmittance, VariableAdmittance, GoalBlend, GoalQMDP])
def test_a_baseline_without_tuned_parameters_for_the_scenario_says_which_it_has(
        make: type) -> None:
    from tests import scenario_box

    with pytest.raises(ConfigError, match="no tuned parameters for scenario 'box'; "
                                          "allowed: hanger, wheel") as err:
        make(graph_of(scenario_box.SPEC))  # a scenario's graph, none tuned for it
    assert err.value.field == "scenario"
    with pytest.raises(ConfigError, match="unknown scenario 'kitchen'; allowed: hanger, "
                                          "wheel") as err:
        make("kitchen")  # a name is resolved at the constructor's top
    assert err.value.field == "scenario"


@pytest.mark.parametrize(("make", "key"), [
    (lambda: AdmittanceGains(damping=0.0), "damping"),
    (lambda: AdmittanceGains(rot_damping=-1.0), "rot_damping"),
    (lambda: VariableGains(force_ref_n=0.0), "force_ref_n"),
    (lambda: VariableGains(lever_m=float("nan")), "lever_m"),
])
def test_admittance_gains_that_must_be_positive_are_refused(make: Any, key: str) -> None:
    with pytest.raises(ConfigError, match=f"{key} must be > 0") as err:
        make()
    assert err.value.field == key


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_every_agent_runs_an_episode_without_the_env(scenario: str,
                                                     envs: dict[str, gym.Env]) -> None:
    """Through the robot protocol: a robot's attach refuses the env, and after a short
    episode no robot holds the env or its simulation.
    """
    env = envs[scenario]
    for name, entry in PHYSICAL_AGENTS.items():
        agent = entry(scenario, 0)
        if not entry.privileged:
            with pytest.raises(ConfigError, match="not privileged"):
                agent.attach(env.unwrapped)
        episode = run_physical_episode(env, agent, seed=3)
        assert episode.steps == 30 and episode.outcome.truncated, name
        if not entry.privileged:
            assert not _reaches(agent, [env, env.unwrapped, env.unwrapped.sim]), name
        belief = agent.belief()
        if name.startswith("goal-"):
            assert belief is not None and belief.sum() == pytest.approx(1.0)


def test_the_admittance_moves_the_grip_the_way_it_is_pushed() -> None:
    task = _task()
    agent = FixedAdmittance(gains=AdmittanceGains(damping=10.0, rot_damping=0.5))
    for axis in range(3):
        for sign in (1.0, -1.0):
            agent.begin_episode(task)
            wrench = np.zeros(6)
            wrench[axis] = 5.0 * sign
            a = agent.act(_observation(task, _free(task), wrench))
            assert np.sign(a[axis]) == sign and a[axis] * sign > 0.5 * np.abs(a[:3]).max()
            assert a[6] == 1.0  # tracked stiffly
    agent.begin_episode(task)
    quiet = agent.act(_observation(task, _free(task), np.array([0.5, 0, 0, 0, 0, 0])))
    assert np.all(quiet[:6] == 0.0)  # within the deadband


def test_the_goal_filter_follows_the_push_towards_a_goal() -> None:
    """From B the hanger goes up to B's mounting point; then down towards A, or over
    (-x) towards C. A push and motion towards C moves the posterior to C, and down to A.
    """
    task = _task(B)
    routes = Routes(task)
    mount = task.geometry.supports[B].mounting
    x = routes.embed(mount, task.geometry.orientations[1])
    for push, goal in (([-1.0, 0, 0], C), ([0, 0, -1.0], A)):
        flt = RouteFilter(routes, FilterParams())
        d = np.concatenate([push, np.zeros(3)])
        for _ in range(10):
            flt.update(x, 0.1 * d, 3.0 * d)
        goals = flt.goals()
        assert goals.sum() == pytest.approx(1.0) and goals[B] == 0.0
        assert goals[goal] > 0.9, (push, goals)


def test_the_blend_weight_grows_with_confidence() -> None:
    params = BlendParams(confidence_lo=0.6, confidence_hi=0.9, alpha_max=0.8)
    alphas = [arbitration(c, params) for c in (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)]
    assert alphas[0] == 0.0 and alphas[-1] == pytest.approx(0.8)
    assert all(b >= a for a, b in zip(alphas, alphas[1:], strict=False))
    assert alphas[2] < alphas[3] < alphas[4]
    task = _task(B)
    blend = GoalBlend("hanger", params)
    blend.begin_episode(task)
    obs = _observation(task, _free(task), np.zeros(6))
    blend.act(obs)
    assert blend.alpha == 0.0  # both goals equally likely
    assert blend.filter is not None
    blend.filter.posterior = np.where(blend.routes.goals == C, 1.0, 0.0)
    blend.filter.posterior /= blend.filter.posterior.sum()
    blend.act(obs)
    assert blend.alpha == pytest.approx(0.8, abs=0.02)


@pytest.mark.parametrize(("scenario", "options"), [("hanger", {"start": "B", "intention": "C"}),
                                                   ("wheel", {"start": "B", "intention": "C"})])
def test_the_admittance_places_with_less_effort_than_passive(scenario: str,
                                                             options: dict) -> None:
    env = _make(HANGER_V1 if scenario == "hanger" else WHEEL_V1, max_time_s=20.0)
    admittance = run_physical_episode(env, PHYSICAL_AGENTS["admittance"](scenario), seed=5,
                                      options=options)
    passive = run_physical_episode(env, PHYSICAL_AGENTS["passive"](scenario), seed=5,
                                   options=options)
    assert admittance.outcome.placed == options_index(options["intention"])
    assert admittance.outcome.metrics["effort"] < 0.8 * passive.outcome.metrics["effort"]


def options_index(name: str) -> int:
    return "ABC".index(name)
