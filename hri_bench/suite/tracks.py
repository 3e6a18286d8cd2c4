"""The benchmark suite's tracks: every version's fixed set of studies and their constants.

Three versions, selected with ``--suite-version`` (default :data:`LATEST`):

* **v3** (:data:`TRACKS_V3`): one headline track per group of the frozen test split v2's
  humans (scripted, misspecified, adaptive, inconsistent) per scenario, beside the paper's
  settings as the anchor; each track's humans are met :attr:`TrackV3.blocks` times each,
  from a power analysis with the two-stage spread a pilot measured (:func:`power_v3`,
  :data:`DELTA_V3` in normalised score; docs/results.md, "Ranking (suite v3)").
* **v2** (:data:`TRACKS_V2`): the frozen ``test`` split as the headline (both scenarios) and
  its parts (``test-misspecified``, ``test-adaptive``, ``test-inconsistent``), beside the
  paper's settings as the anchor. Every track has a reference: ``blind`` exactly where it
  fits (the paper tracks), else a labelled **bracket** on it (``qmdp`` below, ``informed``
  above, :mod:`baselines.product`), and every agent's gap to both ends with 95 % CIs. The
  ranked agents include ``goalfilter`` (a goal filter that learns no preference). Each
  track's runs come from a power analysis (:data:`DELTA` per episode at :data:`POWER`,
  :func:`hri_bench.core.stats.runs_for_difference`, with the standard deviation a pilot
  measured: ``benchmarks/suite_power.py``), not a fixed 500.
* **v1** (:data:`TRACKS`): the ten tracks of the first release, 500 runs each; its files
  are what v1 always wrote, byte for byte.

:func:`track_config` is a track's study (:class:`~hri_bench.run.study.StudyConfig`) with the
references that fit it (:func:`track_references`);
:func:`hri_bench.suite.running.run_suite` runs them. See docs/benchmark.md, "Suite".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from hri_bench.core import stats
from hri_bench.data.datasets import open_dataset
from hri_bench.data.fit import is_recorded
from hri_bench.run.agents import PLANNING_REFERENCES
from hri_bench.run.study import StudyConfig
from hri_envs.checks import select_named
from hri_envs.errors import ConfigError
from hri_envs.humans.splits import MIXTURES

__all__ = [
    "DEFAULT_AGENTS",
    "DEFAULT_AGENTS_V2",
    "DEFAULT_AGENTS_V3",
    "DELTA",
    "LATEST",
    "POWER",
    "SUITE_VERSION",
    "SUITE_VERSIONS",
    "TRACKS",
    "TRACKS_BY_VERSION",
    "TRACKS_V2",
    "TRACKS_V3",
    "TRACKS_V4",
    "Track",
    "TrackV3",
    "check_version",
    "default_agents",
    "population_track",
    "select_tracks",
    "track_config",
    "track_references",
]

#: Version of the first track set (v1; frozen).
SUITE_VERSION = "1"
#: The suite versions, and the default one.
SUITE_VERSIONS: tuple[str, ...] = ("1", "2", "3", "4")
LATEST = "4"
# Every published suite version lists its scenarios, agents and references by value: it never
# reads a registry, so registering a scenario, a family or an agent changes none of them.
#: The scenarios of every published version, in their order.
SUITE_SCENARIOS: tuple[str, ...] = ("hanger", "wheel")
#: The agents ranked by default in v1 (the references are added where they fit).
DEFAULT_AGENTS: tuple[str, ...] = ("learner", "imitator", "maxent", "passive", "oracle")
#: The agents ranked by default in v2: v1's and the goal filter.
DEFAULT_AGENTS_V2: tuple[str, ...] = (*DEFAULT_AGENTS, "goalfilter")
#: The agents ranked by default in v3: v2's and the count-based QMDP learner.
DEFAULT_AGENTS_V3: tuple[str, ...] = (*DEFAULT_AGENTS_V2, "countqmdp")
#: v1's references, added where one human is shared.
REFERENCES_V1: tuple[str, ...] = ("informed", "blind")
#: v3's floor of the normalised score (0): an agent that only follows; always run.
FLOOR = "passive"
#: v2's smallest difference worth detecting, reward per episode, at this power and level.
DELTA = 0.05
POWER = 0.8
ALPHA = 0.05
#: v2's bounds on a track's runs (the 2-minute budget of the whole suite on 2 cores).
MIN_RUNS, MAX_RUNS = 60, 400
#: Agents that must infer the intention (blind is their ceiling), as suite v2 lists them.
INTENTION_BLIND: tuple[str, ...] = ("learner", "imitator", "maxent", "passive", "goalfilter",
                                    "qmdp")
#: v3's: v2's and the count-based QMDP learner.
INTENTION_BLIND_V3: tuple[str, ...] = (*INTENTION_BLIND, "countqmdp")


@dataclass(frozen=True)
class Track:
    """One track: a study's settings besides the agents, seed and execution.

    Attributes:
        name: ``<scenario>-<kind>``.
        scenario: "hanger" or "wheel".
        description: One line for the leaderboard.
        runs: Runs per agent at ``--runs-scale 1``.
        settings: Keyword arguments of :class:`~hri_bench.run.study.StudyConfig`.
        pilot_sd: v2: the largest standard deviation over runs of a paired difference of
            two agents' run means that the pilot measured; ``runs`` detects :data:`DELTA`
            with it at :data:`POWER` (None in v1).
        headline: v2: a track of the whole test split.
        stable: v2: its humans keep one preference throughout.
    """

    name: str
    scenario: str
    description: str
    runs: int
    settings: tuple[tuple[str, Any], ...] = ()
    pilot_sd: float | None = None
    headline: bool = False
    stable: bool = False

    @property
    def per_run_humans(self) -> bool:
        """Whether runs draw their own humans (then blind/informed cannot run)."""
        keys = dict(self.settings)
        return keys.get("population") is not None or keys.get("human_drift") is not None


def _tracks() -> tuple[Track, ...]:
    out = []
    for sc, drift in zip(SUITE_SCENARIOS, (4, 10), strict=True):  # half their episodes
        out += [
            Track(f"{sc}-paper", sc, "the paper's settings: deterministic human, default "
                  "preference", 500),
            Track(f"{sc}-passive", sc, "a passive (noisy) human: waits in a step with "
                  "probability 0.2", 500, (("human_passive", 0.2),)),
            Track(f"{sc}-drift", sc, f"a drifting human: switches to another preference "
                  f"after {drift} episodes", 500, (("human_drift", drift),)),
            Track(f"{sc}-turnback", sc, "a human who turns back halfway with probability "
                  "0.5 per episode", 500, (("turn_back", 0.5),)),
            Track(f"{sc}-heldout", sc, "the held-out population: any preference, Boltzmann "
                  "β in [2, 30], passive and turning-back rates drawn per run", 500,
                  (("population", "heldout"),)),
        ]
    return tuple(out)


#: The suite's tracks, by name (version :data:`SUITE_VERSION`).
TRACKS: dict[str, Track] = {t.name: t for t in _tracks()}

#: v2's pilot: per track, the standard deviation over runs of the paired difference of two
#: agents' run means, within each member's runs (balanced blocks of members leave only that
#: spread; the CIs are stratified alike), the largest over the comparisons the suite is for
#: (learner vs goalfilter, both vs informed); measured by ``benchmarks/suite_power.py``
#: (seed 1000, never the suite's; 256 runs per track).
PILOT_SD: dict[str, float] = {
    "hanger-test": 0.2625, "wheel-test": 0.2216,
    "hanger-test-misspecified": 0.2235, "wheel-test-misspecified": 0.0788,
    "hanger-test-adaptive": 0.3797, "wheel-test-adaptive": 0.3572,
    "hanger-test-inconsistent": 0.1951, "wheel-test-inconsistent": 0.1407,
    "hanger-paper": 0.0614, "wheel-paper": 0.0429,
}


def _power_runs(sd: float, members: int | None = None) -> int:
    """A v2 track's runs: enough to detect :data:`DELTA` at :data:`POWER` with the pilot's
    ``sd``, at least :data:`MIN_RUNS`; for a population of ``members``, whole blocks of
    members (at least two, for the stratified CIs); at most :data:`MAX_RUNS` (whole blocks).
    """
    need = stats.runs_for_difference(sd, DELTA, power=POWER, alpha=ALPHA) if sd > 0 else 0
    n = max(MIN_RUNS, need)
    if not members:
        return int(min(n, MAX_RUNS))
    blocks = max(2, -(-n // members))
    while blocks > 2 and blocks * members > MAX_RUNS:
        blocks -= 1
    return int(blocks * members)


def _tracks_v2() -> tuple[Track, ...]:
    out = []
    parts = {
        "misspecified": ("the test split's misspecified humans: low, avoid, rotate-low, "
                         "impatient (preferences φ does not encode)", True),
        "adaptive": ("the test split's adaptive humans: follower, trust, wary (they learn "
                     "from the robot across episodes)", False),
        "inconsistent": ("the test split's inconsistent humans: fickle (changes its mind "
                         "mid-episode), moody (changes preference at random episodes)",
                         False),
    }
    for sc in SUITE_SCENARIOS:
        name = f"{sc}-test"
        out.append(Track(name, sc, "HEADLINE: the frozen test split (the evaluation set): "
                         "scripted, misspecified, adaptive and inconsistent humans",
                         _power_runs(PILOT_SD[name], MIXTURES[("test", sc)].size),
                         (("population", "test"),), PILOT_SD[name], headline=True))
    for part, (text, stable) in parts.items():
        for sc in ("hanger", "wheel"):
            name = f"{sc}-test-{part}"
            size = MIXTURES[(f"test-{part}", sc)].size
            out.append(Track(name, sc, text, _power_runs(PILOT_SD[name], size),
                             (("population", f"test-{part}"),), PILOT_SD[name],
                             stable=stable))
    for sc in ("hanger", "wheel"):
        name = f"{sc}-paper"
        out.append(Track(name, sc, "anchor: the paper's settings (deterministic human, "
                         "default preference); blind exact", _power_runs(PILOT_SD[name]),
                         (), PILOT_SD[name], stable=True))
    return tuple(out)


#: Suite v2's tracks, by name.
TRACKS_V2: dict[str, Track] = {t.name: t for t in _tracks_v2()}


@dataclass(frozen=True)
class TrackV3(Track):
    """A v3 track: a v2 track whose runs meet ``humans`` different humans ``blocks`` times
    each (a whole number of balanced blocks), from a power analysis with the two-stage
    spread (:func:`power_v3`).

    Attributes:
        humans: The track's different humans (1 on the paper's anchor).
        blocks: Runs per human.
        pilot_between: The pilot's standard deviation, over humans, of a pair's mean paired
            difference of normalised scores (the spread of the humans).
        pilot_within: The pilot's standard deviation of that difference between runs of one
            human.
    """

    humans: int = 1
    blocks: int = 1
    pilot_between: float = 0.0
    pilot_within: float = 0.0


#: v3's smallest difference worth detecting, in normalised score (5 % of the way from the
#: floor to the reachable reference), at :data:`POWER` and :data:`ALPHA`.
DELTA_V3 = 0.05
#: v3's fewest and most runs per human of a population track (at least two, for the second
#: stage of the bootstrap), and the runs of a track with one human.
MIN_BLOCKS, MAX_BLOCKS = 2, 8
MIN_RUNS_V3, MAX_RUNS_V3 = 60, 400
#: Where the target is out of reach, runs per human stop where the difference detected is
#: within this factor of what infinitely many would detect.
DIMINISHING = 1.05
#: v3's pilot (``benchmarks/suite_power.py --version 3``: the validation-v2 split's groups
#: and the paper's human, seed 1000, never the test split): per track, the (between-human,
#: within-human) standard deviations of the paired difference of normalised scores of the
#: comparison that needs the most runs among those the suite is for (learner, goalfilter,
#: countqmdp pairwise and against qmdp).
PILOT_V3: dict[str, tuple[float, float]] = {
    "hanger-test-scripted": (0.2935, 0.1114), "wheel-test-scripted": (0.2733, 0.1067),
    "hanger-test-misspecified": (1.2487, 0.0313), "wheel-test-misspecified": (1.2633, 0.0208),
    "hanger-test-adaptive": (1.4207, 0.5024), "wheel-test-adaptive": (1.5255, 0.4197),
    "hanger-test-inconsistent": (0.099, 0.1032), "wheel-test-inconsistent": (0.1232, 0.1208),
    "hanger-paper": (0.0, 0.0483), "wheel-paper": (0.0, 0.0394),
}


def detectable_v3(between: float, within: float, humans: int, blocks: int) -> float:
    """The smallest paired difference of normalised scores a track detects at
    :data:`POWER` (two-sided, :data:`ALPHA`) when it meets ``humans`` humans ``blocks``
    times each: the two-stage bootstrap's spread of the mean, ``√((σ_b² + σ_w²/R) / H)``,
    times ``z_(1-α/2) + z_power``.
    """
    spread = math.sqrt((between ** 2 + within ** 2 / blocks) / humans)
    return round(stats.detectable_difference(spread, 1, power=POWER, alpha=ALPHA), 4)


def power_v3(between: float, within: float, humans: int) -> int:
    """Runs per human: the fewest in [:data:`MIN_BLOCKS`, :data:`MAX_BLOCKS`] that detect
    :data:`DELTA_V3`. Where no number of runs can (the humans' own spread alone, with
    ``humans`` of them, detects more than the target), the fewest that come within
    :data:`DIMINISHING` of what infinitely many runs per human would detect (more runs would
    not narrow the interval noticeably; the track then misses its target, and says so),
    at most :data:`MAX_BLOCKS`. A track of one human: the runs that detect the target from
    the within spread alone, within [:data:`MIN_RUNS_V3`, :data:`MAX_RUNS_V3`].
    """
    if humans == 1:
        need = stats.runs_for_difference(within, DELTA_V3, power=POWER, alpha=ALPHA) \
            if within > 0 else 0
        return int(min(max(MIN_RUNS_V3, need), MAX_RUNS_V3))
    limit = detectable_v3(between, 0.0, humans, 1)  # infinitely many runs per human
    good_enough = DELTA_V3 if limit <= DELTA_V3 else DIMINISHING * limit
    for blocks in range(MIN_BLOCKS, MAX_BLOCKS + 1):
        if detectable_v3(between, within, humans, blocks) <= good_enough:
            return blocks
    return MAX_BLOCKS


def _tracks_v3(split: str = "test-v2", pilot: dict[str, tuple[float, float]] | None = None,
               scripted: str = "none of them a train human") -> tuple[TrackV3, ...]:
    """The headline tracks on ``split``'s groups and the paper's anchors, their runs from
    ``pilot`` (v3: :data:`PILOT_V3` on test-v2; v4: :data:`PILOT_V4` on test-v3).
    """
    pilot = PILOT_V3 if pilot is None else pilot
    texts = {
        "scripted": ("the test split's scripted humans (the Learner's own model family: any "
                     f"preference, passive or Boltzmann), {scripted}", True),
        "misspecified": ("the test split's misspecified humans: low, avoid, rotate-low, "
                         "impatient (preferences φ does not encode)", True),
        "adaptive": ("the test split's adaptive humans: follower, trust, wary (they learn "
                     "from the robot across episodes)", False),
        "inconsistent": ("the test split's inconsistent humans: fickle (changes its mind "
                         "mid-episode), moody (changes preference at random episodes)",
                         False),
    }
    out = []
    for group, (text, stable) in texts.items():
        for sc in ("hanger", "wheel"):
            name = f"{sc}-test-{group}"
            humans = MIXTURES[(f"{split}-{group}", sc)].size
            between, within = pilot[name]
            blocks = power_v3(between, within, humans)
            out.append(TrackV3(name, sc, f"HEADLINE: {text}", humans * blocks,
                               (("population", f"{split}-{group}"),), None, headline=True,
                               stable=stable, humans=humans, blocks=blocks,
                               pilot_between=between, pilot_within=within))
    for sc in ("hanger", "wheel"):
        name = f"{sc}-paper"
        between, within = pilot[name]
        runs = power_v3(between, within, 1)
        out.append(TrackV3(name, sc, "anchor, outside the headline: the paper's settings "
                           "(deterministic human, default preference); blind exact", runs, (),
                           None, stable=True, humans=1, blocks=runs, pilot_between=between,
                           pilot_within=within))
    return tuple(out)


#: Suite v3's tracks, by name.
TRACKS_V3: dict[str, TrackV3] = {t.name: t for t in _tracks_v3()}
#: v4's pilot (``benchmarks/suite_power.py --version 4``: the validation-v3 split's groups
#: and the paper's human, seed 1000, never the test split), as v3's: what the script prints,
#: compared by a test.
PILOT_V4: dict[str, tuple[float, float]] = {
    "hanger-test-scripted": (0.1666, 0.1938), "wheel-test-scripted": (0.5151, 0.1174),
    "hanger-test-misspecified": (1.2085, 0.0394), "wheel-test-misspecified": (1.3565, 0.0199),
    "hanger-test-adaptive": (0.1255, 0.1201), "wheel-test-adaptive": (0.1125, 0.0727),
    "hanger-test-inconsistent": (0.1421, 0.3099), "wheel-test-inconsistent": (0.266, 0.2476),
    "hanger-paper": (0.0, 0.0483), "wheel-paper": (0.0, 0.0394),
}
#: Suite v4's tracks, by name: v3's on the test split v3 (humans distinct by behaviour).
TRACKS_V4: dict[str, TrackV3] = {t.name: t for t in _tracks_v3(
    "test-v3", PILOT_V4, "each distinct by behaviour from every train and validation human")}
#: The tracks of each version.
TRACKS_BY_VERSION: dict[str, dict[str, Track]] = {"1": TRACKS, "2": TRACKS_V2,
                                                  "3": dict(TRACKS_V3), "4": dict(TRACKS_V4)}


def default_agents(version: str) -> tuple[str, ...]:
    """The agents a version ranks by default (:data:`DEFAULT_AGENTS_V3`, v2
    :data:`DEFAULT_AGENTS_V2`, v1 :data:`DEFAULT_AGENTS`).
    """
    return {"1": DEFAULT_AGENTS, "2": DEFAULT_AGENTS_V2}.get(version, DEFAULT_AGENTS_V3)


def check_version(version: Any) -> str:
    """``version`` if it is a suite version, else a :class:`ConfigError` (``suite_version``)."""
    if not isinstance(version, str) or version not in SUITE_VERSIONS:
        raise ConfigError(f"unknown suite version {version!r}; allowed: "
                          f"{', '.join(SUITE_VERSIONS)}", field="suite_version")
    return version


def select_tracks(names: str | Sequence[str] | None, version: str = LATEST
                  ) -> list[Track]:
    """The tracks named (comma-separated or a list; None: all), in the suite's order.

    Raises:
        ConfigError: An unknown track name (the message lists the version's tracks), or an
            unknown version.
    """
    return select_named(TRACKS_BY_VERSION[check_version(version)], names, "tracks", "track(s)",
                        f" of suite v{version}")


def population_track(population: str, version: str = LATEST) -> Track:
    """A track of one's own on a population (``recorded:DATASET``, a registered name of one
    scenario, ``module:Class`` is refused: its scenario is unknown); outside the versioned set.

    Raises:
        ConfigError: A name whose scenario cannot be told (``field="population"``).
    """
    scenario = None
    if is_recorded(population):
        scenario = open_dataset(population.split(":", 1)[1], field="population").scenario
    if scenario is None:
        raise ConfigError(f"a suite track of its own takes a recorded population "
                          f"(recorded:DATASET or recorded-irl:DATASET), got {population!r}",
                          field="population")
    name = f"{scenario}-{population.replace(':', '-')}"
    return Track(name, scenario, f"humans fitted to recorded sessions ({population}); a track "
                 f"of its own, not part of suite v{version}", 500,
                 (("population", population),))


def _runs(track: Track, scale: float) -> int:
    return max(2, int(round(track.runs * scale)))


def track_references(track: Track, version: str = LATEST) -> tuple[str, ...]:
    """The reference agents a track adds: v1, blind and informed where the human is shared;
    v2, informed everywhere, with blind where it is exact and qmdp (the bracket) elsewhere;
    none on a track of its own whose humans have no model (``recorded:``, ``module:Class``).
    """
    if version == "1":
        return () if track.per_run_humans else REFERENCES_V1
    if ":" in str(dict(track.settings).get("population")):
        return ()  # recorded or module:Class humans: no model to plan with
    exact = not track.per_run_humans and not dict(track.settings).get("human_rationality")
    refs = ("informed", "blind") if exact else ("informed", "qmdp")
    return refs if version == "2" else (*refs, FLOOR)


def track_config(track: Track, agents: Sequence[str], *, runs_scale: float = 1.0,
                 seed: int = 0, jobs: int = 1, executor: str = "serial",
                 version: str = LATEST) -> StudyConfig:
    """The study of a track: ``agents`` (references dropped) plus the references that fit
    (:func:`track_references`), ``track.runs × runs_scale`` runs (at least 2).
    """
    refs = track_references(track, version)
    ranked = tuple(a for a in agents if a not in PLANNING_REFERENCES)
    refs = tuple(r for r in refs if r not in ranked)  # v3's floor may be ranked too
    return StudyConfig(track.scenario, agents=ranked + tuple(refs),
                       runs=_runs(track, runs_scale), seed=seed, jobs=jobs,
                       executor=executor, **dict(track.settings))
