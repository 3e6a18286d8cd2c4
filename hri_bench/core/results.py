"""What a study produces: :class:`StudyResult`, per-agent arrays.

This module sits below both the study (:mod:`hri_bench.run.study`, which fills a result)
and the plots (:mod:`hri_bench.core.plots`, which draw one), so neither imports the other.
It imports nothing from the package. The result's configuration is typed structurally by
:class:`StudySettings`, which :class:`hri_bench.run.study.StudyConfig` satisfies;
``StudyResult[StudyConfig]`` is the result of :func:`hri_bench.run.study.run_study`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Generic, Protocol, TypeVar

import numpy as np

__all__ = ["StudyResult", "StudySettings"]


class StudySettings(Protocol):
    """The settings of a study that readers of a :class:`StudyResult` rely on."""

    @property
    def scenario(self) -> str:
        """"hanger" or "wheel"."""

    @property
    def schedule(self) -> str:
        """"random" or "table2"."""

    @property
    def runs(self) -> int:
        """Independent runs per agent."""

    @property
    def human_passive(self) -> float:
        """Probability that the human waits in a step."""

    @property
    def n_episodes(self) -> int:
        """Episodes per run."""

    @property
    def waiting_reward(self) -> float:
        """r0, the robot's reward for waiting while the human acts."""


ConfigT_co = TypeVar("ConfigT_co", bound=StudySettings, covariant=True)


@dataclass
class StudyResult(Generic[ConfigT_co]):
    """Per-agent arrays from a study.

    Attributes:
        config: The study's configuration (a :class:`hri_bench.run.study.StudyConfig`).
        metrics: ``metrics[agent][metric]`` is (runs, episodes).
        probes: ``probes[agent]`` is (runs, episodes + 1, len(config.probes)): the probed
            probabilities before the first episode and after each update.
        schedule: ``start``, ``goal`` and ``turn_back``, each (runs, episodes).
        wall_time_s: Seconds the simulation took (this process's part, if resumed).
        humans: Each run's human as a label (its preference, ``@β`` if Boltzmann, ``a>b``
            for a drifting human); empty if not recorded.
        failures: Agents that raised (with ``keep_going``), each with its traceback text;
            they have no entries in ``metrics`` and ``probes``.
    """

    config: ConfigT_co
    metrics: dict[str, dict[str, np.ndarray]]
    probes: dict[str, np.ndarray]
    schedule: dict[str, np.ndarray]
    wall_time_s: float
    humans: list[str] = field(default_factory=list)
    failures: dict[str, str] = field(default_factory=dict)
