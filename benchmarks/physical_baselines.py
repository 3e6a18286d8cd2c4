"""The physical robots on the same seeded episodes: per-episode rows and paired comparisons.

    .venv/bin/python benchmarks/physical_baselines.py --episodes 30 --jobs 2 \
        --agents upper,passive,admittance,variable-admittance,goal-blend,goal-qmdp,learner \
        --humans default,weak,hesitant,firm --out /tmp/physical-baselines

runs each agent of the registry (``baselines.physical.PHYSICAL_AGENTS``) on the v1
continuous envs (``*PandaContinuous-v1``) for every scenario and human: episode i is reset
with seed i, so it has the same start, goal, layout and human for every agent. An agent is
made once per run of ``--run-episodes`` consecutive episodes (a learning agent learns
across them). Every episode is a row of ``episodes.csv`` in the output folder (agent,
scenario, human, seed, outcome, return, effort, effort per progress, peak and RMS force,
RMS jerk, time to place, when a robot with a belief inferred the goal, ...; written as
runs finish), so paired comparisons need no re-run. ``summary.json`` and the printed
table have, per scenario, human (and all humans together) and agent: the goal rate
(Clopper-Pearson 95 % CI); the means of effort, return, peak force and time to place (95 %
bootstrap CIs); the paired differences of effort and return against ``--against``
(default: the fixed admittance), episode by episode (by human and seed); for a robot with
a belief over goals, how often and how soon it put 0.9 on the goal, and its paired effort
difference on the episodes where it did so within the first half of the episode and on the
others. Without ``--out`` the folder is a new temporary one, printed at the end.
``--from-csv`` summarises an existing ``episodes.csv`` without running anything. Wall
times depend on the machine's load; the figures do not.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from baselines.physical import PHYSICAL_AGENTS, make_physical_agent
from baselines.physical.runs import HUMANS, ROW_FIELDS, make_env, run_seeds
from hri_bench.core.stats import bootstrap_ci
from hri_envs.task.scenarios import scenario_spec

#: The summary's name for all humans together (with more than one human).
ALL = "all"

#: The figures summarised per agent (mean and 95 % bootstrap CI).
MEANS = ("effort", "return", "peak_force", "rms_force", "rms_jerk", "effort_per_progress",
         "time_to_place_s")


def run_job(job: dict[str, Any]) -> list[dict[str, Any]]:
    """One run in a worker process: the env and the agent are made here."""
    env = make_env(scenario_spec(job["scenario"]), job["human"], job["population"],
                   job["max_time_s"])
    try:
        agent = make_physical_agent(job["agent"], job["scenario"], seed=job["run"])
        return run_seeds(agent, env, job["seeds"], agent=job["agent"],
                         scenario=job["scenario"], human=job["human"],
                         population=job["population"], run=job["run"])
    finally:
        env.close()


def jobs_of(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The runs: per agent, scenario and human, the seeds in chunks of ``run_episodes``."""
    seeds = list(range(args.first_seed, args.first_seed + args.episodes))
    chunks = [seeds[i:i + args.run_episodes] for i in range(0, len(seeds), args.run_episodes)]
    return [{"agent": a, "scenario": s, "human": h, "population": args.population,
             "max_time_s": args.max_time_s, "seeds": chunk, "run": r}
            for s in args.scenarios for h in args.humans for a in args.agents
            for r, chunk in enumerate(chunks)]


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    """Exact 95 % CI of a rate of k in n (scipy's binomtest)."""
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(0.95, method="exact")
    return float(ci.low), float(ci.high)


def _finite(values: Sequence[Any]) -> np.ndarray:
    x = np.array([float(v) for v in values if v not in (None, "")], dtype=float)
    return x[np.isfinite(x)]


def _mean_ci(values: Sequence[Any], seed: int) -> dict[str, Any]:
    x = _finite(values)
    if len(x) == 0:
        return {"mean": None, "ci95": [None, None], "n": 0}
    return {"mean": float(x.mean()), "ci95": list(bootstrap_ci(x, "mean", seed)), "n": len(x)}


def _paired(rows: list[dict[str, Any]], base: list[dict[str, Any]], key: str, seed: int
            ) -> dict[str, Any] | None:
    """Mean of (agent - base) over the seeds both ran, with its bootstrap CI."""
    theirs = {(r["human"], r["seed"]): float(r[key]) for r in base}
    d = _finite([float(r[key]) - theirs[r["human"], r["seed"]] for r in rows
                 if (r["human"], r["seed"]) in theirs])
    if len(d) == 0:
        return None
    return {"mean": float(d.mean()), "ci95": list(bootstrap_ci(d, "mean", seed)),
            "n": len(d)}


def _early(row: dict[str, Any]) -> bool:
    """The robot put 0.9 on the revealed goal within the first half of the episode."""
    t = row.get("inferred_s")
    return t not in (None, "") and float(t) <= 0.5 * float(row["time_s"])


def _inference(rows: list[dict[str, Any]], base: list[dict[str, Any]] | None, against: str,
               seed: int) -> dict[str, Any]:
    """How often and how soon a robot with a belief inferred the goal, and its paired
    effort difference on the episodes where it did so early and on the others.
    """
    times = _finite([r.get("inferred_s") for r in rows])
    early = [r for r in rows if _early(r)]
    late = [r for r in rows if not _early(r)]
    out: dict[str, Any] = {"rate": len(times) / len(rows), "early": len(early),
                           "median_s": float(np.median(times)) if len(times) else None}
    if base is not None:
        out[f"effort_minus_{against}_early"] = _paired(early, base, "effort", seed)
        out[f"effort_minus_{against}_late"] = _paired(late, base, "effort", seed)
    return out


def summarise(rows: list[dict[str, Any]], against: str, seed: int = 0) -> dict[str, Any]:
    """Per scenario, human and agent: goal rate, means and paired differences."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["scenario"], r["human"], r["agent"]), []).append(r)
    if len({r["human"] for r in rows}) > 1:  # and over all humans, paired by (human, seed)
        for r in rows:
            groups.setdefault((r["scenario"], ALL, r["agent"]), []).append(r)
    out: dict[str, Any] = {}
    order = {name: i for i, name in enumerate(PHYSICAL_AGENTS)}
    humans = [*HUMANS, ALL]
    for (scenario, human, agent), rs in sorted(groups.items(), key=lambda kv: (
            kv[0][0], humans.index(kv[0][1]), order[kv[0][2]])):
        k = sum(str(r["reached_intention"]) in ("True", "true", "1") for r in rs)
        entry: dict[str, Any] = {
            "episodes": len(rs), "placed_at_goal": k,
            "goal_rate": k / len(rs), "goal_rate_ci95": list(clopper_pearson(k, len(rs))),
            "privileged": PHYSICAL_AGENTS[agent].privileged,
            "reference": PHYSICAL_AGENTS[agent].reference, "faults": {}}
        for r in rs:
            f = str(r["fault"] or r["outcome"])
            entry["faults"][f] = entry["faults"].get(f, 0) + 1
        for key in MEANS:
            entry[key] = _mean_ci([r[key] for r in rs], seed)
        base = groups.get((scenario, human, against))
        if base is not None and agent != against:
            entry[f"effort_minus_{against}"] = _paired(rs, base, "effort", seed)
            entry[f"return_minus_{against}"] = _paired(rs, base, "return", seed)
        inferred = _finite([r.get("inferred_s") for r in rs])
        if len(inferred):
            entry["inferred"] = _inference(rs, base if agent != against else None, against,
                                           seed)
        out.setdefault(scenario, {}).setdefault(human, {})[agent] = entry
    return out


def _fmt(stat: dict[str, Any] | None, digits: int = 1) -> str:
    if stat is None or stat.get("mean") is None:
        return "-"
    lo, hi = stat["ci95"]
    ci = "" if lo is None else f" [{lo:.{digits}f}, {hi:.{digits}f}]"
    return f"{stat['mean']:.{digits}f}{ci}"


def print_table(summary: dict[str, Any], against: str) -> None:
    """The summary as a table per scenario and human."""
    for scenario, humans in summary.items():
        for human, agents in humans.items():
            print(f"\n{scenario} / {human}")
            print(f"{'agent':20s} {'goal (CP 95 %)':22s} {'effort [N s]':22s} "
                  f"{'return':20s} {'peak [N]':8s} {'place [s]':9s} "
                  f"{'effort - ' + against:24s}")
            for agent, e in agents.items():
                lo, hi = e["goal_rate_ci95"]
                goal = f"{e['placed_at_goal']}/{e['episodes']} [{lo:.2f}, {hi:.2f}]"
                diff = _fmt(e.get(f"effort_minus_{against}"))
                peak, place = e["peak_force"]["mean"], e["time_to_place_s"]["mean"]
                print(f"{agent:20s} {goal:22s} {_fmt(e['effort']):22s} "
                      f"{_fmt(e['return'], 2):20s} {peak:8.1f} "
                      f"{'-' if place is None else f'{place:.1f}':9s} {diff:24s}")


def _finite_json(x: Any) -> Any:
    """``x`` with every non-finite float as None (JSON has no NaN or infinity)."""
    if isinstance(x, dict):
        return {k: _finite_json(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite_json(v) for v in x]
    return None if isinstance(x, float) and not math.isfinite(x) else x


def read_rows(path: Path) -> list[dict[str, Any]]:
    """The rows of an ``episodes.csv`` (seeds and runs as integers)."""
    with path.open() as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r["seed"], r["run"] = int(r["seed"]), int(r["run"])
    return rows


def _names(text: str, allowed: Sequence[str], what: str) -> list[str]:
    names = [n for n in text.split(",") if n]
    bad = [n for n in names if n not in allowed]
    if bad:
        raise SystemExit(f"unknown {what} {', '.join(bad)}; allowed: {', '.join(allowed)}")
    return names


def run_all(args: argparse.Namespace, out: Path) -> list[dict[str, Any]]:
    """Runs every job on ``args.jobs`` processes, appending rows to episodes.csv (with
    ``args.resume``, after the rows already there, skipping the runs they hold).
    """
    path = out / "episodes.csv"
    rows = read_rows(path) if args.resume and path.is_file() else []
    done_runs = {(r["agent"], r["scenario"], r["human"], r["run"]) for r in rows}
    jobs = [j for j in jobs_of(args)
            if (j["agent"], j["scenario"], j["human"], j["run"]) not in done_runs]
    t0 = time.perf_counter()
    with path.open("a" if rows else "w", newline="") as f, \
            ProcessPoolExecutor(args.jobs) as pool:
        writer = csv.DictWriter(f, fieldnames=ROW_FIELDS)
        if not rows:
            writer.writeheader()
        futures = {pool.submit(run_job, job): job for job in jobs}
        for i, done in enumerate(as_completed(futures), 1):
            job, new = futures[done], done.result()
            writer.writerows(new)
            f.flush()
            rows += new
            print(f"[{i}/{len(jobs)}] {job['scenario']} {job['human']} {job['agent']} run "
                  f"{job['run']}: {sum(bool(r['reached_intention']) for r in new)}/{len(new)}"
                  f" placed, effort {np.mean([r['effort'] for r in new]):.1f} N s "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return rows


def main() -> None:
    """Run (or read) the episodes, write the rows and the summary, print the table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--agents", default=",".join(PHYSICAL_AGENTS),
                   help=f"comma-separated registry names (default all: "
                        f"{', '.join(PHYSICAL_AGENTS)})")
    p.add_argument("--scenarios", default="hanger,wheel", help="comma-separated scenarios")
    p.add_argument("--humans", default="default",
                   help=f"comma-separated humans, from {', '.join(HUMANS)} (default default)")
    p.add_argument("--population", default=None,
                   help="a physical human population's name, passed to the env (v1's "
                        "population=; a member is drawn per episode from its seed)")
    p.add_argument("--episodes", type=int, default=30,
                   help="episodes per scenario, human and agent (default 30)")
    p.add_argument("--first-seed", type=int, default=0,
                   help="episode i has seed first-seed + i (default 0; tune on >= 1000)")
    p.add_argument("--run-episodes", type=int, default=10,
                   help="episodes per run: an agent is made once per run and learns "
                        "across it (default 10)")
    p.add_argument("--max-time-s", type=float, default=None,
                   help="the episodes' time limit [s] (default the env's: 30 hanger, "
                        "45 wheel)")
    p.add_argument("--against", default="admittance",
                   help="the agent paired differences are taken against (default "
                        "admittance)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--out", default=None,
                   help="output folder (default: a new temporary folder, printed)")
    p.add_argument("--from-csv", default=None,
                   help="summarise this episodes.csv instead of running")
    p.add_argument("--resume", action="store_true",
                   help="keep the runs already in --out's episodes.csv and run the others")
    args = p.parse_args()
    args.agents = _names(args.agents, list(PHYSICAL_AGENTS), "agent(s)")
    args.humans = _names(args.humans, HUMANS, "human(s)")
    args.scenarios = _names(args.scenarios, ["hanger", "wheel"], "scenario(s)")
    if args.from_csv:
        rows = read_rows(Path(args.from_csv))
        out = Path(args.out) if args.out else Path(args.from_csv).parent
        out.mkdir(parents=True, exist_ok=True)
    else:
        out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="physical-"))
        out.mkdir(parents=True, exist_ok=True)
        rows = run_all(args, out)
    summary = summarise(rows, args.against)
    (out / "summary.json").write_text(json.dumps(
        _finite_json({"args": vars(args), "summary": summary}), indent=1))
    print_table(summary, args.against)
    csv_path = Path(args.from_csv) if args.from_csv else out / "episodes.csv"
    print(f"\nrows: {csv_path}; summary: {out / 'summary.json'}")


if __name__ == "__main__":
    main()
