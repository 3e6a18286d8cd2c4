"""Issue 42, item 3, the Panda ids' vector env on MuJoCo Warp (apart, as the other
tests/test_mjwarp*.py): a HumanSpec's body is the worlds' physical human, as the
``physics={"preset": ...}`` shorthand."""

from __future__ import annotations

import importlib.util

import gymnasium as gym
import pytest

import hri_envs  # noqa: F401  (registers the ids)
from hri_envs.humans.spec import HumanBody, HumanSpec

pytestmark = [
    pytest.mark.mjwarp,
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
    pytest.mark.skipif(importlib.util.find_spec("mujoco_warp") is None,
                       reason="needs the mjwarp extra"),
]


def _worlds(**kwargs):
    env = gym.make_vec("hri_envs/HangerPanda-v0", num_envs=2, backend="mjwarp",
                       vectorization_mode="vector_entry_point", **kwargs).unwrapped
    return env.worlds.template.settings.base


def test_the_warp_vector_envs_body_is_the_physics_options_of_the_human():
    body = HumanSpec(body=HumanBody("weak-human", {"human_force": 3.0}))
    by_body = _worlds(human=body)
    assert by_body == _worlds(physics={"preset": "weak-human", "human_force": 3.0})
    assert by_body != _worlds()
