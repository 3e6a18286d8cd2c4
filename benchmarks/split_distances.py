"""Split version 3's humans, distinct by behaviour: freeze them, and say how near the nearest
pairs are.

    .venv/bin/python benchmarks/split_distances.py            # the nearest pairs (v2 and v3)
    .venv/bin/python benchmarks/split_distances.py --write    # draw v3 again, freeze it

For each scenario and test split (v2, suite v3's; v3, suite v4's) it prints, per group, the
humans that are the same as another of the split or as a train or validation human
(:func:`hri_envs.humans.distance.same_behaviour`, tolerance
:data:`hri_envs.humans.distance.TOLERANCE`) and the nearest pair of each kind with its
behaviour distance (docs/humans.md, "Split version 3"). ``--write`` draws split version 3
afresh and writes :data:`hri_envs.humans.splits.FROZEN_PATH` (about a minute per split).
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

from hri_envs.humans.distance import TOLERANCE, behaviour_distance
from hri_envs.humans.families import GROUPS
from hri_envs.humans.finite_state import as_model
from hri_envs.humans.populations import build_human
from hri_envs.humans.splits import FROZEN_PATH, MIXTURES, frozen_document
from hri_envs.task.scenarios import scenario_graph

#: The splits no test human may equal, per test split.
EARLIER = {"test-v2": ("train", "validation"),
           "test-v3": ("train", "validation", "validation-v2", "validation-v3")}


def _models(name: str, scenario: str) -> list[tuple[str, Any]]:
    graph = scenario_graph(scenario)
    return [(d.label(), as_model(build_human(graph, d)))
            for d in MIXTURES[(name, scenario)].member_draws]


def nearest(models: list[tuple[str, Any]], others: list[tuple[str, Any]]
            ) -> tuple[float, str, str, int]:
    """(distance, label, label, humans the same as one of ``others``) of the nearest pair of a
    member of ``models`` and one of ``others`` (``others`` is ``models``: distinct members).
    """
    best, pair, same = 1.0, ("", ""), 0
    for i, (label, m) in enumerate(models):
        pool = models[:i] if others is models else others
        close = False
        for other, o in pool:
            d = behaviour_distance(m, o, stop_at=max(best, TOLERANCE))
            close |= d < TOLERANCE
            if d < best:
                best, pair = d, (label, other)
        same += close
    return best, pair[0], pair[1], same


def main() -> None:
    """Print the nearest pairs; with ``--write``, freeze split version 3 first."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="draw split v3, write its file")
    args = parser.parse_args()
    if args.write:
        t0 = time.perf_counter()
        specs = [MIXTURES[(n, sc)] for sc in ("hanger", "wheel")
                 for n in ("validation-v3", "test-v3")]
        FROZEN_PATH.write_text(json.dumps(frozen_document(specs), indent=0) + "\n")
        print(f"wrote {FROZEN_PATH} ({time.perf_counter() - t0:.0f} s)")
    for test, earlier in EARLIER.items():
        for sc in ("hanger", "wheel"):
            before = [m for n in earlier for m in _models(n, sc)]
            for group in GROUPS:
                models = _models(f"{test}-{group}", sc)
                d_in, a, b, same_in = nearest(models, models)
                d_out, c, e, same_out = nearest(models, before)
                print(f"{test} {sc:6s} {group:12s} {len(models):3d} humans; the same as "
                      f"another: {same_in:2d}, as an earlier split's: {same_out:2d}; nearest "
                      f"within {d_in:.3f} ({a} ~ {b}), to earlier {d_out:.3f} ({c} ~ {e})",
                      flush=True)


if __name__ == "__main__":
    main()
