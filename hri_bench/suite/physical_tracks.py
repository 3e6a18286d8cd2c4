"""The physical suite's tracks: robots that feel the human, ranked on held-out physical humans.

``hri-bench suite --physical`` runs robot agents (:mod:`agents.physical`) with the physical
humans of the frozen ``test`` split (:mod:`hri_envs.physics.carry.human.population`) on the
continuous envs' v1 (``*PandaContinuous-v1``: the reward pays for placing the object at the human's
goal; docs/physics.md). Version 1 (:data:`TRACKS_P1`): one track per scenario and test group
(``nominal`` adults, ``weak``, ``hesitant``, ``heldout`` body-size extremes absent from
train), 32 humans each, every track a headline track (each weighs the same; together they
partition the test humans). Each human is met :attr:`PhysicalTrack.blocks` times (runs; once
in version 1), each run :attr:`PhysicalTrack.episodes` episodes with random starts and
goals; an agent is made once per run and may learn across the run's episodes.

Per run the **score** is the mean over its episodes of the v1 return (placing at the goal
+10, any other end -5, the human's effort -0.02 per N s, the work against the object's
motion -0.1 per J, -0.5 per second of stall): effort counts only beside completion. The
**normalised score** of a run is ``(x - floor) / (reference - floor)``: 1 at the upper
reference (``upper``: knows the human's goal and follows their own reference; it reads the
simulation, so it is a reference, never ranked), 0 at the passive floor (``passive``:
gravity-compensated, no stiffness). A published version lists its tracks, populations and
agents by value: registering anything changes none of them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from hri_envs.checks import select_named
from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import NamedScenario

__all__ = ["DEFAULT_AGENTS", "FLOOR", "PHYSICAL_LATEST", "PHYSICAL_TRACKS",
           "PHYSICAL_VERSIONS", "REFERENCE", "TRACKS_P1", "PhysicalTrack",
           "check_physical_version", "select_physical_tracks", "track_runs"]

#: The physical suite's versions and the default.
PHYSICAL_VERSIONS: tuple[str, ...] = ("1",)
PHYSICAL_LATEST = "1"
#: The upper reference (1 of the normalised score; privileged: never ranked) and the floor.
REFERENCE, FLOOR = "upper", "passive"
#: The robots version 1 ranks by default (names of :mod:`baselines.physical`), the floor
#: among them.
DEFAULT_AGENTS: tuple[str, ...] = ("admittance", "variable-admittance", "goal-blend",
                                   "goal-qmdp", "learner", "rl", FLOOR)
_SCENARIOS = ("hanger", "wheel")
_GROUPS = {
    "nominal": "nominal adults (both sexes, 5th-95th percentile bodies, any preference) with "
               "firm and loose-gripping ones",
    "weak": "weak humans: a fraction of the adult's strength and stiffness",
    "hesitant": "hesitant humans: long reactions, pauses before each motion, slow",
    "heldout": "body-size extremes (below the 5th and above the 95th percentile), a family "
               "absent from train",
}


@dataclass(frozen=True)
class PhysicalTrack(NamedScenario):
    """One track of the physical suite (its scenario's name resolved once: :attr:`graph`).

    Attributes:
        name: ``<scenario>-<group>``.
        scenario: "hanger" or "wheel".
        population: The physical population its humans come from (``test-<group>``).
        description: One line for the leaderboard.
        humans: Its humans (the population's size).
        blocks: Runs per human (each human met this many times).
        episodes: Episodes per run.
        headline: Part of the headline.
    """

    name: str
    scenario: str
    population: str
    description: str
    humans: int
    blocks: int
    episodes: int
    headline: bool = True

    @property
    def runs(self) -> int:
        """Runs at ``--runs-scale 1``: every human ``blocks`` times."""
        return self.humans * self.blocks


def _tracks_p1() -> dict[str, PhysicalTrack]:
    out = {}
    for sc in _SCENARIOS:
        for group, text in _GROUPS.items():
            name = f"{sc}-{group}"
            out[name] = PhysicalTrack(name, sc, f"test-{group}", text, humans=32, blocks=1,
                                      episodes=2)
    return out


#: Version 1's tracks, by name.
TRACKS_P1: dict[str, PhysicalTrack] = _tracks_p1()
#: Every version's tracks.
PHYSICAL_TRACKS: dict[str, dict[str, PhysicalTrack]] = {"1": TRACKS_P1}


def check_physical_version(version: object) -> str:
    """``version`` if it is a physical suite version, else a :class:`ConfigError`."""
    if not isinstance(version, str) or version not in PHYSICAL_VERSIONS:
        raise ConfigError(f"unknown physical suite version {version!r}; allowed: "
                          f"{', '.join(PHYSICAL_VERSIONS)}", field="suite_version")
    return version


def select_physical_tracks(names: str | Sequence[str] | None,
                           version: str = PHYSICAL_LATEST) -> list[PhysicalTrack]:
    """The tracks named (comma-separated or a list; None: all), in the suite's order.

    Raises:
        ConfigError: An unknown track (the message lists the version's tracks).
    """
    return select_named(PHYSICAL_TRACKS[check_physical_version(version)], names, "tracks",
                        "track(s)", f" of the physical suite v{version}")


def track_runs(track: PhysicalTrack, runs_scale: float) -> int:
    """A track's runs at ``runs_scale``: whole blocks of its humans where the scale allows,
    at least 2 runs (a smoke run meets the first humans of the first block).
    """
    return max(2, int(round(track.runs * runs_scale)))
