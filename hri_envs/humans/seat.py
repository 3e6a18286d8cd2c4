"""The envs' human seat: whatever a user gives for the human, as a :class:`BatchHuman`.

The robot envs, the vector env and :class:`~hri_envs.envs.partner.PartnerEnv` accept a
human in several forms (a preference and rates, a ready-made
:class:`~hri_envs.humans.scripted.ScriptedHuman`, a population's name, any
:class:`~hri_envs.humans.protocol.Human` or :class:`~hri_envs.humans.protocol.BatchHuman`);
:func:`seat_human` validates them and returns the one protocol object the env drives.
"""

from __future__ import annotations

import math

from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans
from hri_envs.humans.protocol import BatchedHumans, BatchHuman, Human
from hri_envs.humans.rational import rational_human, validate_rationality
from hri_envs.humans.scripted import ScriptedHuman, check_probability, preference_human
from hri_envs.humans.splits import population_seat
from hri_envs.humans.tables import TableHumans
from hri_envs.task.graph import TaskGraph

__all__ = ["HumanLike", "seat_human"]

#: What a seat accepts as its human.
HumanLike = ScriptedHuman | FiniteStateHuman | Human | BatchHuman


def seat_human(
    graph: TaskGraph,
    *,
    human: HumanLike | None = None,
    preference: str | None = None,
    passive: float = 0.0,
    turn_back: float = 0.0,
    rationality: float = math.inf,
    population: str | None = None,
    n_runs: int = 1,
) -> BatchHuman:
    """The human of an env's seat, for ``n_runs`` streams.

    Args:
        graph: The env's task graph.
        human: A ready-made human, which replaces the arguments below: a
            :class:`ScriptedHuman` or a
            :class:`~hri_envs.humans.finite_state.FiniteStateHuman` (a family's model:
            seated for every row), a :class:`Human` (one stream:
            ``n_runs`` must be 1) or a :class:`BatchHuman` with ``n_runs`` rows.
        preference: The scripted human's preference (default: the scenario's).
        passive: Its probability of waiting in a step (the env's ``human_passive``).
        turn_back: Its probability per episode of turning back halfway.
        rationality: β of a Boltzmann version (:func:`~hri_envs.humans.populations.
            rational_human`); ``inf``: the deterministic human.
        population: A population's name (a scripted population, a split such as "test",
            a mixture or a family; :func:`hri_envs.humans.splits.population`): a new member
            every episode, replacing the arguments above.
        n_runs: Rows of the seat (the vector env's envs).

    Raises:
        ConfigError: A value out of range, a human of another scenario or of another number
            of rows, or a population and a human both given.
    """
    validate_rationality(rationality)
    passive = check_probability(passive, "human_passive")  # the envs' names for them
    turn_back = check_probability(turn_back, "turn_back")
    if human is not None and population is not None:
        raise ConfigError("give either a human or a population, not both", field="population")
    if population is not None:
        return population_seat(graph, population, n_runs)
    if human is None:
        return TableHumans(rational_human(preference_human(graph, preference, passive=passive,
                                                           turn_back=turn_back), rationality),
                           n_runs)
    if isinstance(human, ScriptedHuman | FiniteStateHuman | BatchHuman):
        if human.graph.name != graph.name or human.graph.n_states != graph.n_states:
            raise ConfigError(f"the human was built for the {human.graph.name} scenario, not "
                              f"the {graph.name}", field="human")
    if isinstance(human, ScriptedHuman):
        return TableHumans(human, n_runs)
    if isinstance(human, FiniteStateHuman):
        return FiniteStateHumans(human, n_runs)
    if isinstance(human, Human):
        if n_runs != 1:
            raise ConfigError(f"a Human plays one stream; this seat has {n_runs}: give a "
                              "BatchHuman, or one Human per stream in BatchedHumans",
                              field="human")
        return BatchedHumans(graph, [human])
    if isinstance(human, BatchHuman):
        if human.n_runs != n_runs:
            raise ConfigError(f"the human has {human.n_runs} rows, the seat {n_runs}",
                              field="human")
        return human
    raise ConfigError(f"human must be a ScriptedHuman, a FiniteStateHuman, a Human or a "
                      f"BatchHuman, got {human!r}", field="human")
