"""Pairwise speed comparison of this checkout against another one, robust to a loaded machine.

    .venv/bin/python benchmarks/compare_speed.py --vs /path/to/old/checkout [--rounds 5]
    .venv/bin/python benchmarks/compare_speed.py --run /path/to/checkout --only jax_env

Each round times every measure once in the old checkout and once in this one, alternately,
each in a fresh interpreter with that checkout first on its path; the report gives, per
measure, the range and median of both and the range and median of the per-round ratio
old / new (> 1: this checkout is faster). Other jobs slow both sides of a round alike, so the
ratios vary much less than the raw figures. Only public APIs that both checkouts have are used
(``jax_env`` needs ``hri_envs.jax`` on both sides, from issue 28 on, and is left out of the
default set). ``--run`` times one checkout once, for a timer of whole processes such as
``farm-bench``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

#: The start of both Learner measures: a wheel trace of 8 steps, layout-independent imports.
_LEARNER = """
import time, numpy as np
from agents.learner import Learner
try:  # this layout, then the one before the benchmark became its own package
    from agents.protocol import Trace
    from hri_bench.run.study import graph_for
except ImportError:
    from hri_envs.bench.study import graph_for
    from hri_envs.task.protocol import Trace
try:  # arrays reused between updates: explicit since the house was rebuilt, before implicit
    from agents.learning.algorithm1 import Workspace
    KW = {"workspace": Workspace()}
except ImportError:
    KW = {}
g = graph_for("wheel"); w = g.waypoint_state
states = np.array([0, 1, 3, w(0, 3, 1), w(1, 3, 1), w(1, 1, 1), w(1, 1, 0), 7, 4])
tr = Trace(states, np.zeros(8, np.int64), np.zeros(8, np.int64))
"""

#: name -> (snippet printing one number, unit, True when larger is faster).
MEASURES: dict[str, tuple[str, str, bool]] = {
    "learner_update": (_LEARNER + """
best = np.inf
for n_b, reps in ((1, 100),) * 3:
    lrn = Learner(g, n_b, **KW); trs = [tr] * n_b; ints = np.ones(n_b, np.int64)
    lrn.end_episode(trs, ints)
    t0 = time.perf_counter()
    for _ in range(reps):
        lrn.end_episode(trs, ints)
    best = min(best, (time.perf_counter() - t0) / reps)
print(best * 1e3)
""", "ms", False),
    "learner_update_batched_per_run": (_LEARNER + """
lrn = Learner(g, 100, **KW); trs = [tr] * 100; ints = np.ones(100, np.int64)
lrn.end_episode(trs, ints)
best = np.inf
for _ in range(3):
    t0 = time.perf_counter()
    for _ in range(5):
        lrn.end_episode(trs, ints)
    best = min(best, (time.perf_counter() - t0) / 5 / 100)
print(best * 1e3)
""", "ms", False),
    "hanger_study_20_runs": ("""
import time
try:
    from hri_bench.report.speed import HANGER_STUDY_PREFERENCES
    from hri_bench.run.study import StudyConfig, run_study
except ImportError:
    from hri_envs.bench.speed import HANGER_STUDY_PREFERENCES
    from hri_envs.bench.study import StudyConfig, run_study
t0 = time.perf_counter()
for i, pref in enumerate(HANGER_STUDY_PREFERENCES):
    run_study(StudyConfig("hanger", agents=("learner",), runs=20, episodes=8, preference=pref,
                          seed=i))
print(time.perf_counter() - t0)
""", "s", False),
    "vector_env": ("""
from hri_envs.envs.speed import vector_env_steps_per_s
print(vector_env_steps_per_s(1024, steps=500).steps_per_s)
""", "steps/s", True),
    "parallel_env": ("""
from hri_envs.envs.speed import parallel_env_steps_per_s
print(parallel_env_steps_per_s(steps=20_000).steps_per_s)
""", "steps/s", True),
    "jax_env": ("""
from hri_envs.jax.speed import jax_env_steps_per_s
print(jax_env_steps_per_s(65_536, steps=2_000).steps_per_s)
""", "steps/s", True),
}
#: Left out unless named with --only.
OPTIONAL = ("jax_env",)


#: Run first in each interpreter: put the checkout before everything, including the finder
#: of an editable install (which would otherwise import the installed checkout's code).
_BOOT = """
import sys
sys.meta_path[:] = [f for f in sys.meta_path if "editable" not in repr(f).lower()]
sys.path[:] = [p for p in sys.path if "__editable__" not in p]
sys.path.insert(0, {checkout!r})
"""


def _run(checkout: Path, snippet: str) -> float:
    code = _BOOT.format(checkout=str(checkout)) + snippet
    out = subprocess.run([sys.executable, "-c", code], cwd=checkout, check=True,
                         capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    """Parse the arguments, time both checkouts alternately, print the ranges and ratios."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--vs", type=Path, help="the other checkout")
    which.add_argument("--run", type=Path, help="time this checkout once and print the figure")
    parser.add_argument("--rounds", type=int, default=5,
                        help="rounds, each timing both checkouts once (default 5)")
    parser.add_argument("--only", choices=sorted(MEASURES), action="append",
                        help="time only this measure (repeat for several; jax_env only when "
                             "named)")
    parser.add_argument("--json", action="store_true", help="end with one JSON line")
    args = parser.parse_args()
    if args.run is not None:
        for name in args.only or [m for m in MEASURES if m not in OPTIONAL]:
            print(name, _run(args.run.resolve(), MEASURES[name][0]), MEASURES[name][1],
                  flush=True)
        return
    here = Path(__file__).resolve().parents[1]
    report = {}
    for name in args.only or [m for m in MEASURES if m not in OPTIONAL]:
        snippet, unit, higher = MEASURES[name]
        old, new = [], []
        for _ in range(args.rounds):
            old.append(_run(args.vs.resolve(), snippet))
            new.append(_run(here, snippet))
        ratios = [(n / o) if higher else (o / n) for o, n in zip(old, new, strict=True)]
        mid = {key: statistics.median(v) for key, v in
               (("old", old), ("new", new), ("speedup", ratios))}
        report[name] = {"unit": unit, "old": [min(old), max(old)], "new": [min(new), max(new)],
                        "speedup": [min(ratios), max(ratios)], "median": mid}
        print(f"{name:32s} old {min(old):.4g}-{max(old):.4g} {unit} (median {mid['old']:.4g}), "
              f"new {min(new):.4g}-{max(new):.4g} {unit} (median {mid['new']:.4g}), speed-up "
              f"{min(ratios):.2f}-{max(ratios):.2f}x (median of the rounds' "
              f"{mid['speedup']:.2f}x)", flush=True)
    if args.json:
        print(json.dumps(report))


if __name__ == "__main__":
    main()
