"""A physical human fitted to recorded sessions, scored on held-out ones, run in a study.

Records synthetic participants (members of the frozen ``train`` population, scripted, led
through the page's protocol: :func:`hri_bench.people.synthetic.record_synthetic`; marked
synthetic) unless the dataset already holds sessions, fits a reference human to each
training participant (:func:`hri_bench.people.physical_fit.fit_physical`), prints the fit's
hand-target error on the training and the held-out participants beside the default
human's, writes the population file, and runs the physical robots against the fitted
population as the physical suite runs a track (:func:`hri_bench.run.physical.simulate_unit`:
every fitted human met ``--blocks`` times, ``--episodes`` episodes a run, population
``fitted:<file>``):

    MUJOCO_GL=egl .venv/bin/python benchmarks/people_physical_fit.py --data out/datasets \\
        --sessions 8 --out out/physical-fit
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="hanger", choices=("hanger", "wheel"),
                   help="the task the synthetic people lead (default hanger)")
    p.add_argument("--dataset", default=None,
                   help="the dataset id (default <scenario>-physical-synthetic)")
    p.add_argument("--data", type=Path, required=True, help="the datasets' root")
    p.add_argument("--sessions", type=int, default=8,
                   help="synthetic participants to record when the dataset is empty (8)")
    p.add_argument("--session-episodes", type=int, default=1,
                   help="episodes per recorded session (1)")
    p.add_argument("--agents", default="passive,admittance,variable-admittance,upper",
                   help="the robots of the study (comma-separated)")
    p.add_argument("--blocks", type=int, default=1, help="runs per fitted human (1)")
    p.add_argument("--episodes", type=int, default=1, help="episodes per run (1)")
    p.add_argument("--seed", type=int, default=0, help="the random seed (default 0)")
    p.add_argument("--out", type=Path, required=True, help="a folder for the results")
    args = p.parse_args()

    from hri_bench.data.datasets import create_dataset, open_dataset
    from hri_bench.people.physical_fit import fit_physical
    from hri_bench.people.synthetic import record_synthetic
    from hri_bench.run.physical import PhysicalUnit, simulate_unit
    from hri_bench.suite.physical_running import make_robot
    from hri_envs.physics.carry.human.population import physical_population

    dataset_id = args.dataset or f"{args.scenario}-physical-synthetic"
    dataset = create_dataset(dataset_id, args.scenario, synthetic=True, root=args.data,
                             physical=True)
    if not dataset.participants():
        t0 = time.perf_counter()
        dataset = record_synthetic(args.scenario, dataset_id, sessions=args.sessions,
                                   episodes=args.session_episodes, data=args.data)
        print(f"recorded {args.sessions} synthetic sessions through the page's protocol in "
              f"{time.perf_counter() - t0:.0f} s")
    dataset = open_dataset(dataset.dataset_id, args.data)
    fit = fit_physical(dataset)
    s = fit.scores
    kind = "synthetic" if dataset.synthetic else "people"
    print(f"{dataset.dataset_id} ({kind}): fitted to {len(fit.train)} participants, "
          f"{len(fit.held_out)} held out ({', '.join(fit.held_out)})")
    print(f"  hand-target RMS error [m]: train {s['train']:.4f} (default human "
          f"{s['default_train']:.4f}), held out {s['held_out']:.4f} (default human "
          f"{s['default_held_out']:.4f})")
    args.out.mkdir(parents=True, exist_ok=True)
    path = fit.save(args.out / "population.json").resolve()
    name = f"fitted:{path}"
    pop = physical_population(name, args.scenario)
    runs = len(pop) * args.blocks
    members = tuple(pop.member_index(args.seed, r) for r in range(runs))
    results: dict[str, dict[str, float]] = {}
    for agent in [a for a in args.agents.split(",") if a]:
        t0 = time.perf_counter()
        unit = PhysicalUnit(f"{args.scenario}-fitted", args.scenario, agent, name, members,
                            tuple(range(runs)), args.episodes, args.seed)
        figures = simulate_unit(unit, make_robot, pop.members)
        ret, placed = figures["return"], figures["placed_goal"]
        results[agent] = {"return_mean": float(np.mean(ret)),
                          "return_min": float(np.min(ret)), "return_max": float(np.max(ret)),
                          "placed_goal": float(np.mean(placed)),
                          "episodes": int(ret.size), "wall_s": time.perf_counter() - t0}
        r = results[agent]
        print(f"  {agent:20s} return {r['return_mean']:7.2f} (range {r['return_min']:.2f} "
              f"to {r['return_max']:.2f}), placed at the goal {r['placed_goal']:.2f}, "
              f"{r['episodes']} episodes in {r['wall_s']:.0f} s")
    doc = {"dataset": dataset.dataset_id, "synthetic": dataset.synthetic,
           "population": name, "population_hash": pop.content_hash(), "fit": s,
           "train": list(fit.train), "held_out": list(fit.held_out), "study": results,
           "load_average": os.getloadavg()}
    (args.out / "study.json").write_text(json.dumps(doc, indent=1) + "\n")
    print(f"  wrote {args.out / 'study.json'}, {path}")


if __name__ == "__main__":
    main()
