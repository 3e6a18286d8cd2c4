"""The pilots behind suite v2's and v3's run counts: how much the agents' scores spread.

    .venv/bin/python benchmarks/suite_power.py --version 4 [--blocks 4] [--seed 1000] [--jobs 2]
    .venv/bin/python benchmarks/suite_power.py --version 3 [--blocks 4] [--seed 1000] [--jobs 2]
    .venv/bin/python benchmarks/suite_power.py --version 2 [--runs 256] [--seed 1000] [--jobs 2]

**Version 4** runs v3's pilot on v4's tracks and the *validation-v3* split (the humans
distinct by behaviour) and prints ``PILOT_V4``, which ``hri_bench/suite/tracks.py`` holds
exactly as printed (``tests/test_suite_v4.py`` runs the pilot and compares; the full
comparison is a slow test).

**Version 3** (:func:`pilot_v3`) runs every v3 track on the *validation-v2* split's group of
the same humans' families (the test split is never looked at; the paper's anchor on its own
human), each member ``--blocks`` times, at a seed that is not the suite's, and normalises the
scores as the suite does. For each comparison the suite is for (``learner``, ``goalfilter``
and ``countqmdp`` pairwise and each against the reachable reference), it splits the spread
of the paired difference of normalised scores into the part between humans and the part
between runs of one human (a one-way random-effects estimate): the two spreads the suite's
two-stage bootstrap resamples. The track keeps the pair that needs the most runs per
human; it prints the ``PILOT_V3`` dict that ``hri_bench/suite/tracks.py`` freezes, and
each track's runs per human and the difference it detects
(:func:`hri_bench.suite.tracks.power_v3`).

**Version 2** (the rest of this docstring, frozen with suite v2):

For each track of suite v2 it runs the track's study with ``--runs`` runs at a seed that is
not the suite's (the suite's numbers never choose their own sample size) and takes the
comparisons the suite is for: the Learner against the goal filter (is learning the
preference worth anything?) and both against the upper bound ``informed`` (how much
headroom is left?). For each pair, the standard deviation over runs of the difference of
their run means (runs are paired: the same run meets the same human and schedule), within
the runs of each member of the population (the study meets the members in balanced blocks,
so their make-up adds no error; the CIs are stratified alike); the largest is the track's
``pilot_sd``, and ``runs_for_difference(pilot_sd, 0.05)`` at 80 %
power is what the track needs (``hri_bench.core.stats``). Pairs with agents whose episodes run
away (plain ME-IRL and the Imitator loop until the step limit with some humans: run means
of -20 and worse) would ask for tens of thousands of runs to resolve differences nobody
needs at 0.05; they are printed for reference, not used. It prints the table and the
``PILOT_SD`` dict that ``hri_bench/suite/tracks.py`` freezes.
"""


from __future__ import annotations

import argparse
import dataclasses
import itertools
import time

import numpy as np

from hri_bench.core import stats
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


#: v3's comparisons: the learners pairwise and each against the reachable reference.
LEARNERS_V3 = ("learner", "goalfilter", "countqmdp")


def components(diff: np.ndarray, humans: np.ndarray) -> tuple[float, float]:
    """(between, within): the standard deviation over humans of a human's true mean of
    ``diff`` and of ``diff`` between runs of one human (one-way random effects; one human:
    (0, the plain standard deviation)).
    """
    keys = np.unique(humans)
    if len(keys) < 2:
        return 0.0, float(np.std(diff, ddof=1))
    groups = [diff[humans == k] for k in keys]
    per = np.array([len(g) for g in groups])
    within = float(np.sqrt(sum(((g - g.mean()) ** 2).sum() for g in groups)
                           / max(int(per.sum()) - len(groups), 1)))
    means = np.array([g.mean() for g in groups])
    between2 = float(np.var(means, ddof=1)) - within ** 2 / float(per.mean())
    return float(np.sqrt(max(between2, 0.0))), within


def pilot_v3(blocks: int, seed: int, jobs: int, only: str | None, version: str = "3",
             quiet: bool = False) -> dict[str, tuple[float, float]]:
    """Run v3's pilot (module docstring) on ``version``'s tracks; the pilot's dict (the
    (between, within) spreads per track, rounded as frozen).
    """
    from hri_bench.report import ranking
    from hri_bench.run.study import regret_reference, run_study
    from hri_bench.suite import (
        DEFAULT_AGENTS_V3,
        DELTA_V3,
        FLOOR,
        MAX_BLOCKS,
        detectable_v3,
        power_v3,
    )
    from hri_bench.suite.results_v3 import run_humans

    found: dict[str, tuple[float, float]] = {}
    say = (lambda *a, **k: None) if quiet else print
    for track in select_tracks(only, version):
        t0 = time.perf_counter()
        cfg = track_config(track, DEFAULT_AGENTS_V3, seed=seed, jobs=jobs,
                           executor="process" if jobs > 1 else "serial", version=version)
        population = dict(track.settings).get("population")
        if population is not None:  # the same families, the validation split's humans
            cfg = dataclasses.replace(cfg, population=population.replace("test-", "validation-"))
            from hri_envs.humans.splits import population as spec_of

            cfg = dataclasses.replace(cfg, runs=blocks * spec_of(cfg.population, cfg.scenario).size)
        result = run_study(cfg)
        blind, _ = regret_reference(result)
        reference = float(blind.mean()) if blind is not None else float(
            result.metrics["qmdp"]["reward"].mean())
        floor = float(result.metrics[FLOOR]["reward"].mean())
        z = {a: ranking.normalise(m["reward"].mean(1), reference, floor)
             for a, m in result.metrics.items()}
        if blind is not None:
            z["blind"] = np.ones(cfg.runs)  # blind's exact value is the reference itself
        humans = np.asarray(run_humans(cfg))
        ref = "blind" if blind is not None else "qmdp"
        pairs = [*itertools.combinations(LEARNERS_V3, 2), *((a, ref) for a in LEARNERS_V3)]
        n_h = len(np.unique(humans))
        need = {}
        for a, b in pairs:
            between, within = components(z[a] - z[b], humans)
            n_blocks = power_v3(between, within, n_h if population else 1)
            shown = detectable_v3(between, within, 40, MAX_BLOCKS) if population else 0.0
            need[(a, b)] = ((n_blocks, shown, between, within))
            say(f"  {track.name:26s} {a:>10s} vs {b:10s} between {between:.4f} within "
                f"{within:.4f}", flush=True)
        (a, b), (_, shown, between, within) = max(need.items(), key=lambda kv: kv[1][:2])
        found[track.name] = (round(between, 4), round(within, 4))
        say(f"{track.name:28s} ({a} vs {b}) between {between:.4f}, within {within:.4f}; at "
            f"{MAX_BLOCKS} runs per human of 40 it detects {shown} (target {DELTA_V3}) "
            f"({time.perf_counter() - t0:.1f} s)", flush=True)
    return found


def main() -> None:
    """Run the pilot and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--version", choices=("2", "3", "4"), default="4",
                        help="the suite version whose pilot to run (default 4)")
    parser.add_argument("--runs", type=int, default=256, help="v2: runs per track")
    parser.add_argument("--blocks", type=int, default=4,
                        help="v3: runs per validation human (the paper's anchor: 60 runs)")
    parser.add_argument("--seed", type=int, default=1000, help="never a suite seed")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    parser.add_argument("--tracks", default=None, help="comma-separated tracks (default all)")
    args = parser.parse_args()
    if args.version in ("3", "4"):
        found = pilot_v3(args.blocks, args.seed, args.jobs, args.tracks, args.version)
        print(f"PILOT_V{args.version}: dict[str, tuple[float, float]] = {{")
        for name, (between, within) in found.items():
            print(f'    "{name}": ({between}, {within}),')
        print("}")
        return
    from hri_bench.run.study import run_study

    found: dict[str, float] = {}
    for track in select_tracks(args.tracks, "2"):  # v2's pilot
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
