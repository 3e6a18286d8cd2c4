"""Make, check and describe the frozen physical populations
(hri_envs.physics.carry.human.population).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/physical_populations.py --write
    .venv/bin/python benchmarks/physical_populations.py --check 4
    .venv/bin/python benchmarks/physical_populations.py --report

``--write`` draws every split of both scenarios (one process per scenario; about 0.8 s of
probing per candidate on one idle core) and writes ``hri_envs/physics/carry/human/data/
physical_populations.json`` and ``physical_signatures.npz``. ``--check N`` probes N members
per split and scenario again on this machine and prints the largest distance from the
committed signatures (0 on the machine that wrote them), with the time a probe took.
``--report`` prints the splits' sizes, content hashes and nearest behavioural distances
(docs/physical-humans.md). ``--feasibility N`` runs the upper reference and the passive
floor (baselines/continuous.py) with the first N members of each test track, one episode
each (episode i: seed i), and prints per track how often each placed the object at the
human's goal, their mean effort and the faults.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.physics.carry.human.population import SCENARIOS, SPLITS, physical_population
from hri_envs.physics.carry.human.population_build import build_scenario, nearest, write
from hri_envs.physics.carry.human.probe import distance, signature
from hri_envs.physics.carry.sim import CarrySim
from hri_envs.task.scenarios import scenario_graph

DATA = Path(__file__).resolve().parents[1] / "hri_envs" / "physics" / "carry" / "human" / "data"


def _build(scenario: str) -> tuple[str, tuple[dict[str, Any], np.ndarray], float]:
    t = time.perf_counter()
    count = [0]

    def progress(what: str) -> None:
        count[0] += 1
        if count[0] % 32 == 0:
            print(f"{time.perf_counter() - t:6.0f} s {what}", flush=True)

    out = build_scenario(scenario_graph(scenario), progress)
    return scenario, out, time.perf_counter() - t


def _write() -> None:
    with ProcessPoolExecutor(len(SCENARIOS)) as pool:
        results = list(pool.map(_build, SCENARIOS))
    for scenario, (doc, sigs), seconds in results:
        print(f"{scenario}: {len(sigs)} members in {seconds:.0f} s, rejected {doc['rejected']}")
    DATA.mkdir(parents=True, exist_ok=True)
    write(DATA, {s: out for s, out, _ in results})


def _check(n: int) -> None:
    for scenario in SCENARIOS:
        sim = CarrySim(scenario_graph(scenario))
        worst, times = 0.0, []
        for split in SPLITS:
            pop = physical_population(split, scenario)
            sigs = pop.signatures()
            for i in np.linspace(0, len(pop) - 1, n).astype(int):
                t = time.perf_counter()
                sig = signature(sim, pop.members[i])
                times.append(time.perf_counter() - t)
                worst = max(worst, distance(sig, sigs[i]))
        print(f"{scenario}: largest distance from the committed signatures {worst:.2e} "
              f"(tolerance 1); a probe took {min(times):.2f}-{max(times):.2f} s")


def _report() -> None:
    for scenario in SCENARIOS:
        print(f"## {scenario}")
        sizes = {}
        for split in SPLITS:
            pop = physical_population(split, scenario)
            sizes[split] = len(pop)
            groups = {g: len(v) for g, v in pop.groups().items()}
            print(f"{split}: {len(pop)} members {groups}, content hash {pop.content_hash()}")
        rows = np.concatenate([physical_population(s, scenario).signatures() for s in SPLITS])
        for what, d in nearest(rows, sizes).items():
            print(f"  nearest {what}: {d:.2f}")


def _feasible(args: tuple[str, int]) -> list[str]:
    import gymnasium as gym

    import hri_envs  # noqa: F401  (registers the ids)
    from baselines.continuous import PassiveFloor, UpperReference, run_episode

    scenario, n = args
    env = gym.make(f"hri_envs/{scenario.capitalize()}PandaContinuous-v0")
    lines = []
    test = physical_population("test", scenario)
    for group, rows in test.groups().items():
        for policy in (UpperReference(), PassiveFloor()):
            placed, effort, faults = 0, [], []
            for k, i in enumerate(rows[:n]):
                env.unwrapped.human_params = test.members[i]
                out = run_episode(env, policy, seed=k)
                placed += out["reached_intention"]
                effort.append(out["effort"])
                if out["fault"]:
                    faults.append(out["fault"])
            lines.append(f"{scenario} test-{group} {type(policy).__name__}: at the goal "
                         f"{placed}/{len(effort)}, effort {np.mean(effort):.1f} N s, faults "
                         f"{faults or 'none'}")
    return lines


def main() -> None:
    """Command line."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true", help="draw the splits again")
    parser.add_argument("--check", type=int, default=0, metavar="N",
                        help="probe N members per split again")
    parser.add_argument("--report", action="store_true", help="sizes, hashes, distances")
    parser.add_argument("--feasibility", type=int, default=0, metavar="N",
                        help="the references with N members of each test track")
    args = parser.parse_args()
    if args.write:
        _write()
    if args.check:
        _check(args.check)
    if args.report:
        _report()
    if args.feasibility:
        with ProcessPoolExecutor(len(SCENARIOS)) as pool:
            for lines in pool.map(_feasible, [(s, args.feasibility) for s in SCENARIOS]):
                print("\n".join(lines))


if __name__ == "__main__":
    main()
