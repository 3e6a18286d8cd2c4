"""Where a study's configuration travels: the modules whose functions receive it.

    .venv/bin/python benchmarks/config_reach.py

Runs a small study (four agents, references included, on a population) and its outputs under
``sys.setprofile`` and counts, per module, the calls whose arguments hold the
:class:`~hri_bench.run.study.StudyConfig` object itself. The study resolves the configuration
at its edge into the objects the layers below take (the task graph, which knows its
scenario; the :class:`~hri_envs.humans.spec.HumanSpec`; the agents' context), so the
configuration should stay in ``hri_bench.run.study`` and the result it is recorded in.
"""

from __future__ import annotations

import argparse
import collections
import sys
import tempfile
from types import FrameType
from typing import Any

from hri_bench.run.study import StudyConfig, run_study, write_outputs


def main() -> None:
    """Run the study under a profiler and print the modules the configuration reached."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=4, help="runs of the study (default 4)")
    args = parser.parse_args()
    cfg = StudyConfig("wheel", agents=("learner", "countqmdp", "qmdp", "informed"), runs=args.runs,
                      episodes=2, population="test-v2-adaptive")
    reached: collections.Counter[str] = collections.Counter()

    def profile(frame: FrameType, event: str, arg: Any) -> None:
        if event == "call" and any(v is cfg for v in frame.f_locals.values()):
            reached[str(frame.f_globals.get("__name__", "?"))] += 1

    sys.setprofile(profile)
    try:
        result = run_study(cfg)
        write_outputs(result, tempfile.mkdtemp(), plots=False)
    finally:
        sys.setprofile(None)
    for module, calls in reached.most_common():
        print(f"{calls:6d}  {module}")
    print(f"{len(reached)} module(s) received the study's configuration")


if __name__ == "__main__":
    main()
