"""The continuous envs end their episodes as they did before their control periods were
compiled (numba, :mod:`hri_envs.physics.carry.periods`).

``tests/data/continuous_reference.json`` holds the ends of seeded episodes recorded from the
numpy implementation (``tests/data/make_continuous_reference.py``, which also replays every
recorded episode with ``--check``). A few well-conditioned episodes are replayed here: the
same last step and outcome, the human's effort, impulses, disagreement and interaction
measures within 1e-6 relative, the object's final position within 1e-6 m.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from tests.data.make_continuous_reference import compare, run_case  # noqa: E402

REFERENCE = json.loads((Path(__file__).parent / "data" / "continuous_reference.json")
                       .read_text())
#: (case, seed): both scenarios with the upper reference and the passive floor, the human
#: agent's commands (the parallel env), a human carrying alone, a smaller human's body.
EPISODES = (("hanger-upper", 0), ("wheel-upper", 0), ("hanger-passive", 0),
            ("wheel-passive", 0), ("hanger-human-agent", 0), ("wheel-alone", 0),
            ("hanger-body", 0), ("wheel-body", 0))


@pytest.mark.parametrize(("case", "seed"), EPISODES)
def test_episode_ends_as_recorded(case: str, seed: int) -> None:
    ref = next(e for e in REFERENCE[case] if e["seed"] == seed)
    got = run_case(case, [seed])[0]
    assert compare(ref, got) == []


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_the_compiled_observation_is_the_simulations_state(scenario: str) -> None:
    """CarrySim.observation_state (one compiled call) is what the numpy accessors read."""
    import gymnasium as gym  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    from baselines.continuous import UpperReference  # noqa: PLC0415
    from hri_envs.task.scenarios import scenario_spec  # noqa: PLC0415

    env = gym.make(str(scenario_spec(scenario).continuous_id))
    base, policy = env.unwrapped, UpperReference()
    obs, _ = env.reset(seed=2)
    policy.attach(base)
    policy.begin_episode(base.robot_task())
    for _ in range(30):
        obs, *_ = env.step(policy.act(obs))
        sim = base.sim
        obj, grip = sim.object_pose(), sim.grip_pose()
        v, w = sim.object_velocity()
        joints, joint_vel = sim.robot_joints()
        expected = np.concatenate([obj.pos, obj.quat * np.sign(obj.quat[0] or 1.0), v, w,
                                   grip.pos, grip.quat * np.sign(grip.quat[0] or 1.0), joints,
                                   joint_vel])
        np.testing.assert_array_equal(sim.observation_state(), expected)
