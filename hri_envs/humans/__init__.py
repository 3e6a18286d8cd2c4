"""The human partner as an agent: its protocol, the scripted families and populations.

=================  ==============================================================
module             contents
=================  ==============================================================
``protocol``       :class:`Human`, :class:`BatchHuman`: how a human plugs into a seat
``scripted``       :class:`ScriptedHuman` (a policy table), preference and Boltzmann humans
``populations``    Boltzmann preference humans, populations, drift, :class:`PopulationHumans`
``tables``         :class:`TableHumans`: scripted humans in a seat, by table look-up
``seat``           :func:`seat_human`: the envs' human arguments as one :class:`BatchHuman`
``spec``           :class:`HumanSpec`: one frozen description of the human, for every env
``runs``           :func:`study_humans`: a study's humans for a batch of its runs
=================  ==============================================================
"""

from hri_envs.humans.populations import POPULATIONS, PopulationHumans
from hri_envs.humans.protocol import BatchedHumans, BatchHuman, Human
from hri_envs.humans.rational import rational_human
from hri_envs.humans.scripted import ScriptedHuman, boltzmann_human, preference_human
from hri_envs.humans.seat import seat_human
from hri_envs.humans.tables import TableHumans

__all__ = [
    "POPULATIONS",
    "BatchHuman",
    "BatchedHumans",
    "Human",
    "PopulationHumans",
    "ScriptedHuman",
    "TableHumans",
    "boltzmann_human",
    "preference_human",
    "rational_human",
    "seat_human",
]
