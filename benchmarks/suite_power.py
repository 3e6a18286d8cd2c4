"""The pilot behind suite v2's run counts: how much the agents' run means spread per track.

    python benchmarks/suite_power.py [--runs 256] [--seed 1000] [--jobs 2] [--tracks T1,T2]

For each track of suite v2 it runs the track's study with ``--runs`` runs at a seed that is
not the suite's (the suite's numbers never choose their own sample size) and takes the
comparisons the suite is for: the Learner against the goal filter (is learning the
preference worth anything?) and both against the upper bound ``informed`` (how much
headroom is left?). For each pair, the standard deviation over runs of the difference of
their run means (runs are paired: the same run meets the same human and schedule), within
the runs of each member of the population (the study meets the members in balanced blocks,
so their make-up adds no error; the CIs are stratified alike); the largest is the track's
``pilot_sd``, and ``runs_for_difference(pilot_sd, 0.05)`` at 80 %
power is what the track needs (``hri_bench.stats``). Pairs with agents whose episodes run
away (plain ME-IRL and the Imitator loop until the step limit with some humans: run means
of -20 and worse) would ask for tens of thousands of runs to resolve differences nobody
needs at 0.05; they are printed for reference, not used. It prints the table and the
``PILOT_SD`` dict that ``hri_bench/suite.py`` freezes.
"""


from __future__ import annotations

import argparse
import dataclasses
import itertools
import time

import numpy as np

from hri_bench import stats
from hri_bench.suite import ALPHA, DEFAULT_AGENTS_V2, DELTA, POWER, select_tracks, track_config

#: The comparisons that set a track's runs.
KEY_PAIRS = (("learner", "goalfilter"), ("learner", "informed"), ("goalfilter", "informed"))


def _within_sd(diff: np.ndarray, labels: np.ndarray) -> float:
    """The standard deviation of ``diff`` within the runs of each human, pooled (a track of
    one shared human: the plain one). Balanced blocks of members leave only this spread in
    the mean over a population's runs.
    """
    keys = np.unique(labels)
    if len(keys) < 2:
        return float(np.std(diff, ddof=1))
    resid = np.concatenate([diff[labels == k] - diff[labels == k].mean() for k in keys])
    return float(np.sqrt((resid ** 2).sum() / max(len(diff) - len(keys), 1)))


def main() -> None:
    """Run the pilot and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=256)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--tracks", default=None)
    args = parser.parse_args()
    from hri_bench.study import run_study

    found: dict[str, float] = {}
    for track in select_tracks(args.tracks, "2"):
        t0 = time.perf_counter()
        cfg = track_config(track, DEFAULT_AGENTS_V2, seed=args.seed, jobs=args.jobs,
                           executor="process" if args.jobs > 1 else "serial", version="2")
        cfg = dataclasses.replace(cfg, runs=args.runs)
        result = run_study(cfg)
        means = {a: m["reward"].mean(1) for a, m in result.metrics.items()
                 if a in (*DEFAULT_AGENTS_V2, "informed")}
        labels = np.array(result.humans)
        sds = {(a, b): _within_sd(means[a] - means[b], labels)
               for a, b in itertools.combinations(means, 2)}
        key = {p: sds.get(p, sds.get((p[1], p[0]), 0.0)) for p in KEY_PAIRS}
        (a, b), sd = max(key.items(), key=lambda kv: kv[1])
        (wa, wb), worst = max(sds.items(), key=lambda kv: kv[1])
        found[track.name] = round(sd, 4)
        need = stats.runs_for_difference(sd, DELTA, power=POWER, alpha=ALPHA)
        print(f"{track.name:28s} pilot sd {sd:.4f} ({a} vs {b}); runs for {DELTA}: {need:5d}"
              f"; widest pair {wa} vs {wb}: {worst:.3f}  ({time.perf_counter() - t0:.1f} s)",
              flush=True)
    print("PILOT_SD = {")
    for name, sd in found.items():
        print(f'    "{name}": {sd},')
    print("}")


if __name__ == "__main__":
    main()
