"""The Panda ids simulate the Panda: ``gymnasium.make(panda_id, backend="graph")`` is refused,
naming the physics backends, instead of silently giving the graph env (issue 34).
"""

import pytest


@pytest.mark.parametrize("backend", ["graph", "nope", None])
def test_a_panda_id_refuses_a_backend_other_than_a_physics_one(backend):
    import gymnasium as gym

    from hri_envs.errors import ConfigError

    for env_id, graph_id in (("hri_envs/HangerPanda-v0", "hri_envs/Hanger-v0"),
                             ("hri_envs/WheelPanda-v0", "hri_envs/Wheel-v0")):
        with pytest.raises(ConfigError, match=r"backend must be one of the physics backends "
                                              r"mujoco, mjwarp, got .*the graph env has an id "
                                              rf"of its own \({graph_id}\)") as info:
            gym.make(env_id, backend=backend)
        assert info.value.field == "backend"
