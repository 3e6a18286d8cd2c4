"""Tune the physical baselines' parameters on training episodes (coordinate search).

    .venv/bin/python benchmarks/tune_physical_baselines.py --jobs 2 \
        --agents admittance,variable-admittance,goal-blend,goal-qmdp,learner \
        --scenarios hanger,wheel --seeds 4 --out /tmp/physical-tuning

For each agent and scenario it starts from the parameters in the code (``TUNED_*`` of
``baselines/physical/*.py`` and ``baselines/continuous.py``) and searches one parameter
at a time over a few candidate values (:data:`SEARCH`: multiples of the current value, or
fixed values), keeping a change only if it raises the objective, for ``--passes`` passes.
The objective is the mean v1 return over the training episodes: seeds ``--first-seed``
(1000) onwards, ``--seeds`` of them per human, for the default human and every preset
(or, with ``--population train``, as many episodes of the physical populations' training
split, passed to the env: a member drawn per seed); every candidate meets the same
episodes. An agent that learns (the lifted Learner) runs each human's episodes in order,
as one run. When ``admittance`` is tuned in the same call, the agents
after it are tuned with (and keep) its chosen gains. Every evaluation is a line of
``tuning.jsonl`` in the output folder; the chosen parameters are printed as the Python to
put into the code. Never evaluate on seeds 0-29: they are the evaluation's.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent
from baselines.continuous import TUNED_LEARNER, LiftedLearner
from baselines.physical.admittance import (
    TUNED_FIXED,
    TUNED_VARIABLE,
    FixedAdmittance,
    VariableAdmittance,
)
from baselines.physical.blend import TUNED_BLEND, GoalBlend
from baselines.physical.hindsight import TUNED_QMDP, GoalQMDP
from baselines.physical.runs import HUMANS, make_env, run_seeds
from hri_envs.task.scenarios import scenario_spec

#: Per agent: (the dotted field, ("x", factors) for multiples of the current value or
#: ("=", values) for fixed values) searched one after another.
SEARCH: dict[str, list[tuple[str, tuple[str, tuple[float, ...]]]]] = {
    "admittance": [("damping", ("x", (0.6, 0.8, 1.25, 1.6))),
                   ("rot_damping", ("x", (0.6, 0.8, 1.25, 1.6))),
                   ("deadband_n", ("x", (0.5, 2.0))),
                   ("filter_s", ("x", (0.5, 1.5))),
                   ("settle_stiffness", ("=", (0.0, 1.0)))],
    "variable-admittance": [("min_ratio", ("=", (0.4, 0.8))),
                            ("force_ref_n", ("x", (0.5, 2.0))),
                            ("mass_s", ("=", (0.0, 0.15)))],
    "goal-blend": [("lead.speed_mps", ("x", (0.7, 1.4))),
                   ("alpha_max", ("=", (0.6, 0.95))),
                   ("confidence_lo", ("=", (0.4, 0.7))),
                   ("lead.filter.kappa_f", ("x", (0.0, 2.0)))],
    "goal-qmdp": [("lead.speed_mps", ("x", (0.7, 1.4))),
                  ("effort_weight", ("x", (0.5, 2.0))),
                  ("lead.yield_n", ("x", (0.5, 2.0))),
                  ("lead.filter.kappa_f", ("x", (0.0, 2.0)))],
    "learner": [("lead.speed_mps", ("x", (0.7, 1.4))),
                ("confidence", ("=", (0.0, 0.6))),
                ("engage_cos", ("=", (0.5, 0.85)))],
}

#: The starting parameters of each agent, per scenario (the code's).
TABLES: dict[str, dict[str, Any]] = {
    "admittance": TUNED_FIXED, "variable-admittance": TUNED_VARIABLE,
    "goal-blend": TUNED_BLEND, "goal-qmdp": TUNED_QMDP, "learner": TUNED_LEARNER}


def make_agent(kind: str, scenario: str, params: Any, run: int = 0) -> PhysicalAgent:
    """The agent ``kind`` with ``params`` (its parameter object)."""
    if kind == "admittance":
        return FixedAdmittance(gains=params)
    if kind == "variable-admittance":
        return VariableAdmittance(gains=params)
    if kind == "goal-blend":
        return GoalBlend(scenario, params)
    if kind == "goal-qmdp":
        return GoalQMDP(scenario, params)
    return LiftedLearner(scenario, seed=run, lead=params)


def get(params: Any, path: str) -> Any:
    """The field at the dotted ``path`` of nested dataclasses."""
    for name in path.split("."):
        params = getattr(params, name)
    return params


def put(params: Any, path: str, value: Any) -> Any:
    """``params`` with the field at the dotted ``path`` replaced (nested dataclasses)."""
    head, _, rest = path.partition(".")
    if not rest:
        return dataclasses.replace(params, **{head: value})
    return dataclasses.replace(params, **{head: put(getattr(params, head), rest, value)})


def run_human(job: dict[str, Any]) -> list[dict[str, Any]]:
    """One human's training episodes in a worker process (one run: in order)."""
    env = make_env(scenario_spec(job["scenario"]), job["human"], job["population"])
    try:
        agent = make_agent(job["kind"], job["scenario"], job["params"])
        return run_seeds(agent, env, job["seeds"], agent=job["kind"],
                         scenario=job["scenario"], human=job["human"], run=0)
    finally:
        env.close()


def evaluate(pool: ProcessPoolExecutor, kind: str, scenario: str, params: Any,
             args: argparse.Namespace) -> dict[str, float]:
    """The objective (mean return) and the goal rate and effort of ``params``."""
    n, first = args.seeds, args.first_seed
    if args.population:  # as many episodes as with the named humans, members drawn per seed
        parts = [("default", list(range(first + i * n, first + (i + 1) * n)))
                 for i in range(len(args.humans))]
    else:
        parts = [(h, list(range(first, first + n))) for h in args.humans]
    jobs = [{"kind": kind, "scenario": scenario, "params": params, "human": h,
             "population": args.population, "seeds": seeds} for h, seeds in parts]
    rows = [r for rs in pool.map(run_human, jobs) for r in rs]
    return {"return": float(np.mean([r["return"] for r in rows])),
            "goal_rate": float(np.mean([bool(r["reached_intention"]) for r in rows])),
            "effort": float(np.mean([r["effort"] for r in rows])), "episodes": len(rows)}


def candidates(current: Any, rule: tuple[str, tuple[float, ...]]) -> list[Any]:
    """The values to try for a field whose current value is ``current``."""
    kind, values = rule
    out = [_round(current * f) for f in values] if kind == "x" else list(values)
    return [v for v in out if v != current]


def _round(x: float) -> float:
    """``x`` to 3 significant digits (the parameters as they are written in the code)."""
    return float(f"{x:.3g}")


def beyond(value: float, rule: tuple[str, tuple[float, ...]], ref: float) -> list[float]:
    """One step further when the best value so far is at or beyond the most extreme
    multiple of ``ref`` tried (the optimum may lie further): that value times the extreme
    factor again.
    """
    kind, factors = rule
    if kind != "x" or not ref:
        return []
    ratio, lo, hi = value / ref, min(factors), max(factors)
    if ratio <= lo * 1.01 and lo > 0:
        return [_round(value * lo)]
    if ratio >= hi * 0.99:
        return [_round(value * hi)]
    return []


def tune(pool: ProcessPoolExecutor, kind: str, scenario: str, start: Any,
         args: argparse.Namespace, log: Any) -> Any:
    """Coordinate search from ``start``; the best parameters found."""
    best = start
    score = evaluate(pool, kind, scenario, best, args)
    _log(log, kind, scenario, "start", None, best, score)
    for _ in range(args.passes):
        for path, rule in SEARCH[kind]:
            ref = get(best, path)
            values = candidates(ref, rule)
            while values:
                value = values.pop(0)
                try:
                    trial = put(best, path, value)
                except Exception as exc:  # noqa: BLE001 (a value the dataclass refuses)
                    print(f"  skip {path}={value}: {exc}")
                    continue
                s = evaluate(pool, kind, scenario, trial, args)
                _log(log, kind, scenario, path, value, trial, s)
                if s["return"] > score["return"]:
                    best, score = trial, s
                    values += beyond(value, rule, ref)
    print(f"{kind} {scenario}: return {score['return']:.3f}, goal {score['goal_rate']:.2f}, "
          f"effort {score['effort']:.1f} N s\n  {best!r}", flush=True)
    return best


def _log(log: Any, kind: str, scenario: str, path: str, value: Any, params: Any,
         score: dict[str, float]) -> None:
    line = {"agent": kind, "scenario": scenario, "field": path, "value": value,
            "params": repr(params), **score, "time": time.strftime("%H:%M:%S")}
    log.write(json.dumps(line) + "\n")
    log.flush()
    print(f"  {kind} {scenario} {path}={value}: return {score['return']:.3f} goal "
          f"{score['goal_rate']:.2f} effort {score['effort']:.1f}", flush=True)


def _on_admittance(kind: str, start: Any, fixed: Any) -> Any:
    """``start`` on the fixed admittance just tuned (``fixed``, if any) instead of its own."""
    if fixed is None:
        return start
    if kind == "variable-admittance":
        return dataclasses.replace(start, base=fixed)
    if kind in ("goal-blend", "goal-qmdp"):
        return put(start, "lead.admittance", fixed)
    if kind == "learner":
        return dataclasses.replace(start, admittance=fixed)
    return start


def main() -> None:
    """Tune the agents on the training episodes and print the chosen parameters."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--agents", default=",".join(SEARCH),
                   help=f"comma-separated, in this order (default: {', '.join(SEARCH)})")
    p.add_argument("--scenarios", default="hanger,wheel", help="comma-separated scenarios")
    p.add_argument("--humans", default=",".join(HUMANS),
                   help=f"comma-separated humans (default all: {', '.join(HUMANS)})")
    p.add_argument("--population", default=None,
                   help="train on this physical population (e.g. train) instead of the "
                        "named humans: passed to the env")
    p.add_argument("--seeds", type=int, default=4,
                   help="training episodes per human (default 4; with --population, as "
                        "many episodes in all as with the humans, a member drawn per seed)")
    p.add_argument("--first-seed", type=int, default=1000,
                   help="the first training seed (default 1000; 0-29 are the evaluation's)")
    p.add_argument("--passes", type=int, default=1,
                   help="passes over the fields (default 1)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--out", default=None,
                   help="output folder for tuning.jsonl (default: a new temporary folder)")
    args = p.parse_args()
    kinds = [k for k in args.agents.split(",") if k]
    bad = [k for k in kinds if k not in SEARCH]
    if bad:
        raise SystemExit(f"unknown agent(s) {', '.join(bad)}; allowed: {', '.join(SEARCH)}")
    if args.first_seed < 30:
        raise SystemExit("--first-seed must be >= 30: seeds 0-29 are the evaluation's")
    args.humans = [h for h in args.humans.split(",") if h]
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="physical-tuning-"))
    out.mkdir(parents=True, exist_ok=True)
    chosen: dict[str, dict[str, Any]] = {}
    with (out / "tuning.jsonl").open("a") as log, ProcessPoolExecutor(args.jobs) as pool:
        for scenario in [s for s in args.scenarios.split(",") if s]:
            fixed = None
            for kind in kinds:
                start = _on_admittance(kind, TABLES[kind][scenario], fixed)
                best = tune(pool, kind, scenario, start, args, log)
                fixed = best if kind == "admittance" else fixed
                chosen.setdefault(kind, {})[scenario] = best
    print("\nchosen (put into the code's TUNED_* tables):")
    for kind, per in chosen.items():
        for scenario, params in per.items():
            print(f"{kind} {scenario}: {params!r}")
    print(f"\nwrote {out / 'tuning.jsonl'}")


if __name__ == "__main__":
    main()
