"""Issue 42, item 3, the JAX env (apart: JAX's threads, tests/conftest.py): it takes a
HumanSpec of the abstract graph and refuses a physical body or a population it cannot hold,
naming the field and the env."""

from __future__ import annotations

import pytest

pytest.importorskip("jax")

from hri_envs.errors import ConfigError  # noqa: E402
from hri_envs.humans.spec import HumanBody, HumanSpec  # noqa: E402
from hri_envs.jax.env import JaxRobotEnv  # noqa: E402


def test_the_jax_env_refuses_a_body():
    with pytest.raises(ConfigError, match=r"the JAX env cannot honour HumanSpec\.body=") as err:
        JaxRobotEnv("hanger", human=HumanSpec(body=HumanBody("weak", {"strength": 0.5})))
    assert err.value.field == "human"


@pytest.mark.parametrize("population, text", [
    ("test-heldout", "unknown population 'test-heldout'"),  # a physical track only
    ("hri_envs.humans.tables:TableHumans", "as tables, not"),
])
def test_the_jax_env_refuses_a_population_it_cannot_run(population, text):
    with pytest.raises(ConfigError, match=text) as err:
        JaxRobotEnv("hanger", human=HumanSpec(population=population))
    assert err.value.field == "population"
