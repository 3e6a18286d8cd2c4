"""The envs' human seat: whatever a user gives for the human, as a :class:`BatchHuman`.

The robot envs, the parallel and vector envs and :class:`~hri_envs.envs.partner.PartnerEnv`
accept the human as a :class:`~hri_envs.humans.spec.HumanSpec` (the one description every
env, the study and ``serve`` take; the flat keywords ``preference=``, ``human_passive=``,
... are its shorthand), or a ready-made human: a
:class:`~hri_envs.humans.scripted.ScriptedHuman`, a family's
:class:`~hri_envs.humans.finite_state.FiniteStateHuman`, any
:class:`~hri_envs.humans.protocol.Human` or :class:`~hri_envs.humans.protocol.BatchHuman`.
:func:`seat_human` validates it and returns the one protocol object the env drives.
"""

from __future__ import annotations

from typing import Any

from hri_envs.errors import ConfigError
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans
from hri_envs.humans.protocol import BatchedHumans, BatchHuman, Human
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.spec import HumanSpec
from hri_envs.humans.tables import TableHumans
from hri_envs.task.graph import TaskGraph

__all__ = ["HumanLike", "human_spec", "seat_human"]

#: What a seat accepts as its human.
HumanLike = HumanSpec | ScriptedHuman | FiniteStateHuman | Human | BatchHuman


def human_spec(human: HumanLike | None, keywords: dict[str, Any]) -> HumanLike:
    """The env's human: ``human`` if given (a spec or a ready-made human), else the spec the
    flat keywords describe (:meth:`HumanSpec.from_kwargs`).

    Raises:
        ConfigError: ``human`` and flat keywords both given (``field="human"``), or a
            population with a ready-made human.
        TypeError: A keyword that is not the human's.
    """
    spec = HumanSpec.from_kwargs(**keywords)
    if human is None:
        return spec
    if spec != HumanSpec():
        given = ", ".join(sorted(keywords))
        raise ConfigError(f"give the human either as human=... or by keywords ({given}), not "
                          "both", field="population" if "population" in keywords else "human")
    return human


def seat_human(graph: TaskGraph, *, human: HumanLike | None = None, n_runs: int = 1,
               body: bool = False, env: str = "this env", **keywords: Any) -> BatchHuman:
    """The human of an env's seat, for ``n_runs`` streams.

    Args:
        graph: The env's task graph.
        human: A :class:`HumanSpec` (:meth:`HumanSpec.seat`), or a ready-made human: a
            :class:`ScriptedHuman` or a :class:`FiniteStateHuman` (seated for every row), a
            :class:`Human` (one stream: ``n_runs`` must be 1) or a :class:`BatchHuman`
            with ``n_runs`` rows.
        n_runs: Rows of the seat (the vector env's envs).
        body: The env honours a spec's :attr:`HumanSpec.body` itself (its physics); else a
            spec with a body is refused, naming ``env``.
        env: The env, for that error.
        keywords: The flat keywords of a spec (``preference``, ``human_passive``,
            ``turn_back``, ``human_rationality``, ``population``, ``human_params``), when
            ``human`` is None.

    Raises:
        ConfigError: A value out of range, a human of another scenario or of another number
            of rows, a human given both ways, or a body the seat cannot honour.
    """
    human = human_spec(human, keywords)
    if isinstance(human, HumanSpec):
        if not body:
            human.bodiless(env)
        return human.seat(graph, n_runs)
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
    raise ConfigError(f"human must be a HumanSpec, a ScriptedHuman, a FiniteStateHuman, a "
                      f"Human or a BatchHuman, got {human!r}", field="human")
