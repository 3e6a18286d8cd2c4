"""A study's humans for a batch of its runs, chosen once from its :class:`HumanSpec`.

A study asks for the humans of each batch of runs it simulates (a *unit*). Which kind of
humans they are does not change from one batch to the next, so :func:`study_humans` reads
the spec once and returns the maker of that kind:

* :class:`OwnHumans`: a human of the user's (``module:Class``) or a prefixed kind (a model
  fitted to recordings), :meth:`HumanSpec.custom`;
* :class:`ScriptedRuns`: the scripted human shared by the runs (with ``--preference all``,
  one per preference, each run meeting its own);
* :class:`DrawnRuns`: each run's own humans, drawn from ``(seed, run)`` alone (a
  population's member, a drift: :meth:`HumanSpec.run_draws`).

Each maker's :meth:`RunHumans.make` gives the batch's humans and each run's label (the
``human`` column of a study's results; per episode ``"a>b"`` for a drift).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass

from hri_envs.humans.finite_state import FiniteStateHumans
from hri_envs.humans.populations import humans_of
from hri_envs.humans.protocol import BatchHuman
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.spec import HumanSpec
from hri_envs.humans.tables import TableHumans
from hri_envs.task.graph import TaskGraph

__all__ = ["DrawnRuns", "OwnHumans", "RunHumans", "ScriptedRuns", "study_humans"]

#: What a maker gives: the batch's humans, and each run's label.
Made = tuple[ScriptedHuman | BatchHuman, list[str]]


@dataclass(frozen=True)
class RunHumans(ABC):
    """The maker of a study's humans for a batch of its runs.

    Attributes:
        spec: The study's human.
    """

    spec: HumanSpec

    @abstractmethod
    def make(self, graph: TaskGraph, runs: Sequence[int], preference: str) -> Made:
        """The humans of ``runs`` and each run's label.

        Args:
            graph: The study's task graph.
            runs: The batch's run indices.
            preference: The batch's preference: one of the scenario's, ``"all"`` (the runs'
                own preferences, :attr:`ScriptedRuns.run_preferences`) or ``""`` (a
                population's runs, whatever their preference).
        """


@dataclass(frozen=True)
class OwnHumans(RunHumans):
    """A human of the user's, or a prefixed kind: :meth:`HumanSpec.custom` for the batch,
    labelled by its name.
    """

    def make(self, graph: TaskGraph, runs: Sequence[int], preference: str) -> Made:
        """One batch of the class's humans (or the kind's model) for ``runs``."""
        assert self.spec.population is not None
        return self.spec.custom(graph, len(runs)), [self.spec.population] * len(runs)


@dataclass(frozen=True)
class ScriptedRuns(RunHumans):
    """The scripted human shared by the runs.

    Attributes:
        run_preferences: Each run's preference (of the study's runs, by index): the batch
            ``"all"`` meets one scripted human per preference, each run its own.
    """

    run_preferences: tuple[str, ...] = ()

    def make(self, graph: TaskGraph, runs: Sequence[int], preference: str) -> Made:
        """The scripted human of ``preference``, or of each run's for ``"all"``."""
        if preference == "all":  # a batch of the runs' preferences
            prefs = [self.run_preferences[r] for r in runs]
            shared = {p: self.spec.scripted(graph, p) for p in dict.fromkeys(prefs)}
            return TableHumans([[shared[p]] for p in prefs]), prefs
        return self.spec.scripted(graph, preference), [preference] * len(runs)


@dataclass(frozen=True)
class DrawnRuns(RunHumans):
    """Each run's own humans, one per episode, from ``(seed, run)`` alone.

    Attributes:
        seed: The study's seed.
        episodes: Episodes per run.
        drift: The episode after which the human's preference drifts (None: never).
    """

    seed: int = 0
    episodes: int = 1
    drift: int | None = None

    def make(self, graph: TaskGraph, runs: Sequence[int], preference: str) -> Made:
        """Each run's draws of ``preference`` (``""``: the population's own)."""
        n_e = self.episodes
        seqs = [self.spec.run_draws(graph, self.seed, r, n_e, preference, self.drift)
                for r in runs]
        labels = [">".join(dict.fromkeys(x.label() for x in seq)) for seq in seqs]
        flat = humans_of(graph, [d for seq in seqs for d in seq])
        per_run = [flat[i * n_e:(i + 1) * n_e] for i in range(len(runs))]
        if all(isinstance(h, ScriptedHuman) for h in flat):
            return TableHumans(per_run), labels
        # A member with a finite state (misspecified, adaptive, inconsistent): one model per
        # run throughout (such populations do not drift).
        return FiniteStateHumans([seq[0] for seq in per_run]), labels


def study_humans(spec: HumanSpec, *, seed: int, episodes: int, drift: int | None = None,
                 run_preferences: Sequence[str] = ()) -> RunHumans:
    """The maker of a study's humans (module docstring), read once from ``spec``.

    Args:
        spec: The study's human.
        seed: The study's seed.
        episodes: Episodes per run.
        drift: The episode after which a scripted human's preference drifts (None: never).
        run_preferences: Each run's preference (``--preference all`` cycles them).
    """
    if spec.kind in ("class", "prefixed"):
        return OwnHumans(spec)
    if spec.population is None and drift is None:
        return ScriptedRuns(spec, tuple(run_preferences))
    return DrawnRuns(spec, seed, episodes, drift)
