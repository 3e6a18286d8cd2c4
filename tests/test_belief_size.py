"""A belief over another number of intentions than the graph's is refused naming the agent,
never scored (issue 34).
"""

import numpy as np
import pytest


def _belief_agent(extra):
    """A Passive agent whose belief has ``extra`` more (or fewer) entries than intentions."""
    from baselines import Passive

    class WrongBelief(Passive):
        name = "wrong-belief"

        def belief(self):
            k = self.graph.n_intentions + extra
            return np.full((self.n_runs, k), 1.0 / k)

    return WrongBelief


@pytest.mark.parametrize("extra", [1, -1])
def test_a_belief_of_the_wrong_size_is_refused_naming_the_agent(extra):
    from hri_bench.run.runner import make_schedule, simulate
    from hri_bench.run.study import graph_for
    from hri_envs.errors import ConfigError
    from hri_envs.humans.scripted import preference_human

    graph = graph_for("hanger")
    human = preference_human(graph)
    schedule = make_schedule(graph, "random", [0, 1], 1, 0, human)
    agent = _belief_agent(extra)(graph, 2)
    with pytest.raises(ConfigError, match=rf"belief\(\) of agent 'wrong-belief' returned "
                                          rf"{graph.n_intentions + extra} probabilities per "
                                          rf"run; the hanger has {graph.n_intentions}"):
        simulate(graph, agent, human, schedule, runs=[0, 1], seed=0, r0=-0.33)
