"""What the physics tests share: a simulator per scenario, kept for a module, and state look-up."""

import pytest

from hri_envs.envs.config import scenario_graph


def sim_fixture(scenario: str):
    """A module-scoped fixture giving ``(graph, PandaSim)`` of ``scenario`` (built once)."""

    @pytest.fixture(scope="module")
    def sim():
        from hri_envs.physics import PandaSim

        g = scenario_graph(scenario)
        return g, PandaSim(g)

    return sim


def named(g, prefix):
    """The first state of ``g`` whose name starts with ``prefix``."""
    return next(s for s in range(g.n_states) if g.state_names[s].startswith(prefix))
