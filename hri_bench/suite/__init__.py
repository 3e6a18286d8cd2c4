"""The benchmark suite: versioned tracks, their runs, the results files and leaderboards.

================  ====================================================================
module            contents
================  ====================================================================
``markdown``      names from users and files made safe in every leaderboard's text
``tracks``        every version's tracks and constants, a track's study
``resume``        the suite's folder: its lock, checks, finished tracks and units, resume
``results_v3``    suite v3's (and v4's) per-run humans, normalised scores and ranking sections
``results_v4``    suite v4's headline: learners apart from references, shared ranks
``evidence``      roles, ``blind``'s exact values, which agents' code is installed here
``submission``    the results file: read, build, compute, validate, merge; the recorder
``audit``         what a valid file cannot prove: replayed runs, conflicting files
``fresh``         ``validate --fresh``: the agents on a drawn seed and fresh humans
``merged``        ``hri-bench leaderboard``: validated files merged into one leaderboard
``leaderboards``  ``suite.json``'s track summaries, each version's ``leaderboard.md`` text
``running``       :func:`run_suite`: the tracks' studies, the suite's files and figures
================  ====================================================================

The modules import one way, in this table's order (``lint-imports``). Every public name of
the former module ``hri_bench.suite`` is importable from here, as before.
"""

from hri_bench.suite.leaderboards import (
    CONVERGED,
    episodes_to_converge,
    leaderboard,
    leaderboard_v2,
    leaderboard_v3,
    track_summary,
    track_summary_v2,
    track_summary_v3,
)
from hri_bench.suite.running import ERRORS_LOG, run_suite, track_figure
from hri_bench.suite.tracks import (
    ALPHA,
    DEFAULT_AGENTS,
    DEFAULT_AGENTS_V2,
    DEFAULT_AGENTS_V3,
    DELTA,
    DELTA_V3,
    DIMINISHING,
    FLOOR,
    INTENTION_BLIND,
    INTENTION_BLIND_V3,
    LATEST,
    MAX_BLOCKS,
    MAX_RUNS,
    MAX_RUNS_V3,
    MIN_BLOCKS,
    MIN_RUNS,
    MIN_RUNS_V3,
    PILOT_SD,
    PILOT_V3,
    POWER,
    SUITE_VERSION,
    SUITE_VERSIONS,
    TRACKS,
    TRACKS_BY_VERSION,
    TRACKS_V2,
    TRACKS_V3,
    Track,
    TrackV3,
    check_version,
    default_agents,
    detectable_v3,
    population_track,
    power_v3,
    select_tracks,
    track_config,
    track_references,
)

__all__ = [
    "ALPHA",
    "CONVERGED",
    "DEFAULT_AGENTS",
    "DEFAULT_AGENTS_V2",
    "DEFAULT_AGENTS_V3",
    "DELTA",
    "DELTA_V3",
    "DIMINISHING",
    "ERRORS_LOG",
    "FLOOR",
    "INTENTION_BLIND",
    "INTENTION_BLIND_V3",
    "LATEST",
    "MAX_BLOCKS",
    "MAX_RUNS",
    "MAX_RUNS_V3",
    "MIN_BLOCKS",
    "MIN_RUNS",
    "MIN_RUNS_V3",
    "PILOT_SD",
    "PILOT_V3",
    "POWER",
    "SUITE_VERSION",
    "SUITE_VERSIONS",
    "TRACKS",
    "TRACKS_BY_VERSION",
    "TRACKS_V2",
    "TRACKS_V3",
    "Track",
    "TrackV3",
    "check_version",
    "default_agents",
    "detectable_v3",
    "episodes_to_converge",
    "leaderboard",
    "leaderboard_v2",
    "leaderboard_v3",
    "population_track",
    "power_v3",
    "run_suite",
    "select_tracks",
    "track_config",
    "track_figure",
    "track_references",
    "track_summary",
    "track_summary_v2",
    "track_summary_v3",
]
