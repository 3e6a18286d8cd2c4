"""The physics loop's thresholds and times are named fields of PhysicsDesign."""

import ast
import inspect
from dataclasses import replace

import numpy as np
import pytest

from hri_envs.envs.config import scenario_graph
from hri_envs.physics import PandaSim
from hri_envs.physics.panda import grasp, sim
from hri_envs.physics.panda.human import SimulatedHuman
from hri_envs.physics.scene.controller import Disagreement
from hri_envs.physics.scene.design import hanger_design, wheel_design
from hri_envs.physics.scene.seats import Seats

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

# The values the simulation used as bare numbers before they were named.
NAMED = {
    "pregrasp_distance_m": 0.08,
    "grip_finger_pos_m": 0.012,
    "motion_min_duration_s": 0.6,
    "grasp_approach_min_duration_s": 0.8,
    "grasp_approach_time_limit_s": 4.0,
    "grasp_close_time_s": 0.2,
    "release_retreat_time_limit_s": 3.0,
    "reset_grip_ik_error_max_m": 5e-3,
    "reset_pregrasp_ik_error_max_m": 0.03,  # 0.02 left the hanger unservable on C
    "ik_error_max_m": 0.03,
    "ik_error_time_max_s": 0.5,
    "settle_vel_sq_max_m2_s2": 1e-4,
    "settle_angvel_sq_max_rad2_s2": 2.5e-3,
    "settle_calm_time_s": 0.15,
    "settle_min_time_s": 0.05,
    "timeout_fault_factor": 2.5,
    "diverged_qvel_max": 50.0,
    "stability_check_every_steps": 50,
    "platform_update_every_steps": 25,
    "human_work_min_j": 0.05,
    "disagree_slack_factor": 0.5,
    "disagree_rise_time_s": 0.1,
    "disagree_fall_time_s": 0.3,
    "disagree_yield_alpha": 0.9,
    "disagree_yield_time_s": 0.3,
    "human_speed_factor": 1.2,
    "human_noise_time_s": 0.2,
    "human_noise_torque_lever_m": 0.1,
    "seat_capture_m": 0.03,
    "seat_capture_angle_rad": np.deg2rad(25.0),
    "seat_fade_m": 0.01,
}


@pytest.mark.parametrize("factory", [hanger_design, wheel_design])
def test_both_designs_keep_the_former_numbers(factory):
    design = factory()
    for name, value in NAMED.items():
        assert getattr(design, name) == value, name
        assert name in type(design).__doc__, f"{name} is not documented"


def test_no_bare_float_thresholds_in_the_physics_loop():
    tree = ast.parse("\n".join(inspect.getsource(c) for c in (sim.PandaSim, grasp.PandaGrasp)))
    for fn in ast.walk(tree):
        if isinstance(fn, ast.FunctionDef) and fn.name in (
                "step", "_run", "_robot_toggle", "_check_stable", "reset", "weld",
                "_grip_overload", "_seat_wrench", "_follow", "_update_ik", "_check_in_place"):
            for node in ast.walk(fn):
                if isinstance(node, ast.Constant) and isinstance(node.value, float):
                    assert node.value in (0.0, 1.0), (fn.name, node.value, node.lineno)


def test_the_numbers_are_read_from_the_design():
    design = replace(hanger_design(), disagree_slack_factor=0.25, seat_capture_m=0.05,
                     seat_capture_angle_rad=0.1, human_speed_factor=2.0,
                     disagree_yield_time_s=0.1)
    davi = Disagreement(design)
    assert davi.slack == 0.25 * design.disagree_force[0]
    seats = Seats(scenario_graph("hanger").scenario, design)
    assert (seats.capture, seats.max_angle) == (0.05, 0.1)
    human = SimulatedHuman(design, np.random.default_rng(0))
    assert human.speed == (2.0 * design.linear_speed, 2.0 * design.angular_speed)
    t = 0.0
    while not davi.yielded:  # full disagreement: α → 1 within ~0.5 s, then 0.1 s to yield
        davi.update(10 * design.disagree_force[1], 0.002)
        t += 0.002
    assert t < 1.0


def test_settle_time_comes_from_the_design():
    g = scenario_graph("hanger")
    panda = PandaSim(g)
    durations = []
    for calm in (0.15, 0.4):
        panda.design = replace(panda.design, settle_calm_time_s=calm)
        s = panda.reset(0)
        r = panda.step(s, 0, 0)  # nobody moves: settles after the calm time
        assert r.settled and r.fault is None
        durations.append(r.duration)
    assert durations[1] - durations[0] == pytest.approx(0.25, abs=1.5 * panda.dt)
