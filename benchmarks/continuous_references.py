"""The continuous envs' references: the upper reference, the passive floor, the lifted Learner.

    .venv/bin/python benchmarks/continuous_references.py --episodes 100 \
        --out out/continuous_references.json

runs each policy for N episodes per scenario (episode i: seed i, so the start, goal and
the wheel's layout are the same for every policy) and prints, per scenario and policy, the
rate of episodes that place the object at the human's goal and the human's effort per
episode [N s], each with a 95 % bootstrap CI, and the mean return. ``--drive muscle``
uses the muscle-driven arm. Timings depend on the machine's load; the figures do not.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

import hri_envs  # noqa: F401
from baselines.continuous import LiftedLearner, PassiveFloor, UpperReference, run_episode
from hri_envs.task.scenarios import scenario_spec


def bootstrap_ci(values: np.ndarray, n: int = 10_000, seed: int = 0) -> tuple[float, float]:
    """95 % percentile bootstrap CI of the mean."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(len(values), size=(n, len(values)))
    means = values[idx].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def _exact_ci(k: int, n: int) -> tuple[float, float]:
    """Clopper-Pearson 95 % CI of a rate of k in n (scipy)."""
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(0.95, method="exact")
    return float(ci.low), float(ci.high)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--episodes", type=int, default=100,
                   help="episodes per scenario and policy (default 100)")
    p.add_argument("--scenarios", default="hanger,wheel",
                   help="comma-separated scenarios (default hanger,wheel)")
    p.add_argument("--policies", default="upper,passive,learner",
                   help="comma-separated, from upper, passive, learner (default all three)")
    p.add_argument("--drive", default="torque",
                   help="the human arm's drive: torque (default) or muscle")
    p.add_argument("--out", default="out/continuous_references.json",
                   help="where the figures are written as JSON")
    args = p.parse_args()
    results: dict[str, dict[str, dict[str, object]]] = {}
    for scenario in args.scenarios.split(","):
        env = gym.make(str(scenario_spec(scenario).continuous_id), drive=args.drive)
        results[scenario] = {}
        for name in args.policies.split(","):
            policy = (UpperReference() if name == "upper" else PassiveFloor()
                      if name == "passive" else LiftedLearner(scenario, seed=0))
            t0 = time.perf_counter()
            rows = [run_episode(env, policy, seed=i) for i in range(args.episodes)]
            wall = time.perf_counter() - t0
            reached = np.array([r["reached_intention"] for r in rows], dtype=float)
            effort = np.array([r["effort"] for r in rows])
            ret = np.array([r["return"] for r in rows])
            sim_s = float(sum(r["time_s"] for r in rows))
            faults: dict[str, int] = {}
            for r in rows:
                faults[str(r["fault"])] = faults.get(str(r["fault"]), 0) + 1
            results[scenario][name] = {
                "episodes": args.episodes, "reached_goal": float(reached.mean()),
                "reached_goal_ci95": bootstrap_ci(reached),
                "reached_goal_ci95_exact": _exact_ci(int(reached.sum()), len(reached)),
                "effort_mean_ns": float(effort.mean()), "effort_ci95": bootstrap_ci(effort),
                "return_mean": float(ret.mean()), "return_ci95": bootstrap_ci(ret),
                "faults": faults, "simulated_s": sim_s, "wall_s": wall}
            r = results[scenario][name]
            lo, hi = r["reached_goal_ci95_exact"]
            print(f"{scenario:6s} {name:8s} goal {r['reached_goal']:.2f} "
                  f"[{lo:.3f}, {hi:.3f}] (Clopper-Pearson)  "
                  f"effort {r['effort_mean_ns']:.1f} N s [{r['effort_ci95'][0]:.1f}, "
                  f"{r['effort_ci95'][1]:.1f}]  return {r['return_mean']:.2f}  "
                  f"faults {faults}  {sim_s:.0f} s simulated in {wall:.0f} s", flush=True)
        env.close()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
