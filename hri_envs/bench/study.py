"""A study: several agents, many runs, one scenario and human; results as arrays and files.

:func:`run_study` splits the work into units of (agent, human preference, chunk of runs),
runs them serially, in a process pool or on Ray, and stitches the results together in run
order. Since every run draws only from ``(seed, run)``, the numbers are identical whatever
the executor and the number of jobs.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.bench.agents import BUILTIN_AGENTS, make_agent, validate_agent_name
from hri_envs.bench.results import StudyResult  # re-exported; shared with the plots
from hri_envs.bench.runner import TABLE2, make_schedule, simulate
from hri_envs.envs.backends import BACKENDS, batch_backend
from hri_envs.envs.config import check_physics_options
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.humans import preference_human, preferences_for
from hri_envs.task.scenarios import SCENARIOS, scenario_graph, scenario_spec

__all__ = [
    "METRICS",
    "Probe",
    "StudyConfig",
    "StudyResult",
    "graph_for",
    "run_study",
    "summarize",
    "write_outputs",
]

#: Metrics of every backend; a backend adds its own ``extras`` (the physics: impulses, ...).
METRICS = ("reward", "correct", "passive", "wrong", "steps", "truncated")
EXECUTORS = ("serial", "process", "ray")


def graph_for(scenario: str) -> TaskGraph:
    """The task graph of a scenario by name (built once per process)."""
    return scenario_graph(scenario)


@dataclass(frozen=True)
class Probe:
    """A policy entry to record after every episode: π(action | state, intention).

    ``kind`` is "human" (the agent's estimate π̂_H) or "robot" (its π_R); agents without the
    matching ``human_policy``/``robot_policy`` method record NaN.
    """

    label: str
    kind: str
    state: int
    intention: int
    action: int
    relative_to_wait: bool = False


@dataclass(frozen=True)
class StudyConfig:
    """What to simulate. ``None`` fields take the scenario's defaults.

    Attributes:
        scenario: "hanger" or "wheel".
        agents: Agent names (see :mod:`hri_envs.bench.agents`).
        runs: Independent runs per agent (each learns from scratch).
        episodes: Episodes per run (default 8 hanger, 20 wheel; 9 for "table2").
        schedule: "random" start and goal per episode, or the user study's "table2".
        preference: The scripted human's preference, or "all" to cycle runs over all of them.
        r0: Robot reward for waiting while the human acts, in (-1, 0).
        human_passive: Probability that the human waits in a step.
        turn_back: Probability per episode that the human turns back halfway.
        seed: Base seed; run r depends on (seed, r) only.
        jobs: Worker processes (or Ray tasks in flight).
        executor: "serial", "process" or "ray".
        backend: "graph" (the abstract task graph, batched) or "mujoco" (the simulated
            Panda, one run at a time; adds interaction impulse, duration and graph agreement
            to the metrics).
        max_steps: Step limit per episode.
        ray_address: Address of a Ray cluster (default: start Ray locally).
        probes: Policy entries to record per episode (for Figs. 8, 11, 12).
        physics_preset: A named set of physics options of the backend (mujoco:
            "weak-human", "noisy-sensor"; docs/physics.md); None for its defaults.
    """

    scenario: str
    agents: tuple[str, ...] = BUILTIN_AGENTS
    runs: int = 100
    episodes: int | None = None
    schedule: str = "random"
    preference: str | None = None
    r0: float | None = None
    human_passive: float = 0.0
    turn_back: float = 0.0
    seed: int = 0
    jobs: int = 1
    executor: str = "serial"
    backend: str = "graph"
    max_steps: int = 100
    ray_address: str | None = None
    probes: tuple[Probe, ...] = field(default_factory=tuple)
    physics_preset: str | None = None

    def __post_init__(self) -> None:
        def bad(name: str, allowed: str) -> ConfigError:
            return ConfigError(f"{name} must be {allowed}, got {getattr(self, name)!r}",
                               field=name)

        if self.scenario not in SCENARIOS:
            raise bad("scenario", f"one of {', '.join(SCENARIOS)}")
        if not self.agents:
            raise bad("agents", "a non-empty list")
        for name in self.agents:
            validate_agent_name(name)
        if self.runs < 1:
            raise bad("runs", ">= 1")
        if self.episodes is not None and self.episodes < 1:
            raise bad("episodes", ">= 1")
        if self.schedule not in ("random", "table2"):
            raise bad("schedule", "'random' or 'table2'")
        if self.schedule == "table2" and self.scenario != "hanger":
            raise ConfigError("schedule 'table2' is the hanger user study's; use 'random' for "
                              "the wheel", field="schedule")
        prefs = preferences_for(self.scenario)
        if self.preference is not None and self.preference not in (*prefs, "all"):
            raise bad("preference", f"'all' or one of {', '.join(prefs)}")
        if self.r0 is not None and not -1.0 < self.r0 < 0.0:
            raise bad("r0", "in (-1, 0)")
        for name in ("human_passive", "turn_back"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise bad(name, "a probability in [0, 1]")
        if self.jobs < 1:
            raise bad("jobs", ">= 1")
        if self.executor not in EXECUTORS:
            raise bad("executor", f"one of {', '.join(EXECUTORS)}")
        if self.backend not in BACKENDS:
            raise bad("backend", f"one of {', '.join(BACKENDS)}")
        if self.max_steps < 1:
            raise bad("max_steps", ">= 1")
        if self.physics_preset is not None:
            try:
                check_physics_options(self.physics, self.backend)
            except ConfigError as exc:
                raise ConfigError(str(exc), field="physics_preset") from None

    @property
    def physics(self) -> dict[str, Any]:
        """The backend's ``physics`` options this study sets."""
        return {} if self.physics_preset is None else {"preset": self.physics_preset}

    @property
    def n_episodes(self) -> int:
        """Episodes per run after defaults."""
        if self.episodes is not None:
            return self.episodes
        return len(TABLE2) if self.schedule == "table2" else scenario_spec(self.scenario).episodes

    @property
    def waiting_reward(self) -> float:
        """r0 after defaults."""
        return scenario_spec(self.scenario).r0 if self.r0 is None else self.r0

    def preference_of_run(self) -> list[str]:
        """The human preference of each run."""
        prefs = preferences_for(self.scenario)
        if self.preference == "all":
            return [prefs[r % len(prefs)] for r in range(self.runs)]
        default = scenario_spec(self.scenario).default_preference
        return [self.preference or default] * self.runs

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (probes summarised by label)."""
        d = dataclasses.asdict(self)
        d["agents"] = list(self.agents)
        d["probes"] = [p.label for p in self.probes]
        return d


@dataclass(frozen=True)
class _Unit:
    config: StudyConfig
    agent: str
    preference: str
    runs: tuple[int, ...]


def _probe(agent: Any, probes: Sequence[Probe]) -> np.ndarray:
    out = np.full((agent.n_runs, len(probes)), np.nan)
    for j, p in enumerate(probes):
        fn = getattr(agent, f"{p.kind}_policy", None)
        if fn is None:
            continue
        pi = fn(p.state, p.intention)  # (B, A)
        out[:, j] = pi[:, p.action] / pi[:, 0] if p.relative_to_wait else pi[:, p.action]
    return out


def _run_unit(unit: _Unit) -> tuple[dict[str, np.ndarray], np.ndarray, dict[str, np.ndarray]]:
    cfg = unit.config
    graph = graph_for(cfg.scenario)
    human = preference_human(graph, unit.preference, passive=cfg.human_passive,
                             turn_back=cfg.turn_back)
    runs = list(unit.runs)
    schedule = make_schedule(graph, cfg.schedule, runs, cfg.n_episodes, cfg.seed, human)
    agent = make_agent(unit.agent, graph, human, runs, seed=cfg.seed, r0=cfg.waiting_reward)
    probes = np.full((len(runs), cfg.n_episodes + 1, len(cfg.probes)), np.nan)
    if cfg.probes:
        probes[:, 0] = _probe(agent, cfg.probes)

    def record(e: int, a: Any) -> None:
        probes[:, e + 1] = _probe(a, cfg.probes)

    m = simulate(graph, agent, human, schedule, runs=runs, seed=cfg.seed,
                 r0=cfg.waiting_reward, max_steps=cfg.max_steps,
                 after_episode=record if cfg.probes else None, backend=cfg.backend,
                 physics=cfg.physics)
    metrics = {k: np.asarray(getattr(m, k), dtype=float) for k in METRICS}
    metrics.update({k: np.asarray(v, dtype=float) for k, v in m.extras.items()})
    sched = {"start": schedule.start, "goal": schedule.goal, "turn_back": schedule.turn_back}
    return metrics, probes, sched


def _units(cfg: StudyConfig) -> list[_Unit]:
    by_pref: dict[str, list[int]] = {}
    for r, pref in enumerate(cfg.preference_of_run()):
        by_pref.setdefault(pref, []).append(r)
    units = []
    for agent in cfg.agents:
        for pref, runs in by_pref.items():
            n_chunks = max(1, min(cfg.jobs, len(runs)))
            for chunk in np.array_split(np.asarray(runs), n_chunks):
                units.append(_Unit(cfg, agent, pref, tuple(int(r) for r in chunk)))
    return units


def _execute(cfg: StudyConfig, units: list[_Unit]) -> Iterator[tuple[int, Any]]:
    """Yield (unit index, result) as units finish."""
    if cfg.executor == "serial" or (cfg.executor == "process" and cfg.jobs == 1):
        for i, u in enumerate(units):
            yield i, _run_unit(u)
    elif cfg.executor == "process":
        from concurrent.futures import as_completed

        with ProcessPoolExecutor(max_workers=cfg.jobs) as pool:
            futures = {pool.submit(_run_unit, u): i for i, u in enumerate(units)}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
    else:
        yield from _execute_ray(cfg, units)


def _execute_ray(cfg: StudyConfig, units: list[_Unit]) -> Iterator[tuple[int, Any]]:
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError("executor 'ray' needs Ray: pip install 'hri-envs[ray]'") from exc
    if not ray.is_initialized():
        ray.init(address=cfg.ray_address, num_cpus=None if cfg.ray_address else cfg.jobs,
                 include_dashboard=False, log_to_driver=False)
    remote = ray.remote(_run_unit)
    refs = {remote.remote(u): i for i, u in enumerate(units)}
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        yield refs[done[0]], ray.get(done[0])


def run_study(
    cfg: StudyConfig, *, progress: bool = False, on_unit: Callable[[], None] | None = None
) -> StudyResult:
    """Simulate a study and gather per-run arrays in run order.

    Args:
        cfg: What to simulate.
        progress: Show a progress bar (tqdm) over work units.
        on_unit: Called after each finished unit (for callers with their own progress).
    """
    units = _units(cfg)
    n_e, n_p = cfg.n_episodes, len(cfg.probes)
    keys = METRICS + batch_backend(cfg.backend).extras
    metrics = {a: {k: np.zeros((cfg.runs, n_e)) for k in keys} for a in cfg.agents}
    probes = {a: np.full((cfg.runs, n_e + 1, n_p), np.nan) for a in cfg.agents}
    schedule = {k: np.zeros((cfg.runs, n_e), dtype=bool if k == "turn_back" else np.int64)
                for k in ("start", "goal", "turn_back")}
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(units), desc=f"{cfg.scenario} study", unit="batch", leave=False)
    t0 = time.perf_counter()
    for i, (m, p, sched) in _execute(cfg, units):
        u = units[i]
        rows = list(u.runs)
        for k in keys:
            metrics[u.agent][k][rows] = m[k]
        probes[u.agent][rows] = p
        for k in schedule:
            schedule[k][rows] = sched[k]
        if bar is not None:
            bar.update(1)
        if on_unit is not None:
            on_unit()
    if bar is not None:
        bar.close()
    return StudyResult(cfg, metrics, probes, schedule, time.perf_counter() - t0)


def summarize(result: StudyResult) -> dict[str, Any]:
    """The ``summary.json`` document (docs/benchmark.md, 'summary.json')."""
    cfg = result.config
    agents: dict[str, Any] = {}
    for name, m in result.metrics.items():
        r = m["reward"]
        agents[name] = {
            "reward": {"mean": r.mean(0).tolist(), "q25": np.percentile(r, 25, 0).tolist(),
                       "q75": np.percentile(r, 75, 0).tolist()},
            **{k: {"mean": m[k].mean(0).tolist()} for k in ("correct", "passive", "wrong")},
            **{k: {"mean": m[k].mean(0).tolist()} for k in m if k not in METRICS},
        }
    prefs = sorted(set(cfg.preference_of_run()))
    return {
        "scenario": cfg.scenario,
        "backend": cfg.backend,
        "physics_preset": cfg.physics_preset,
        "schedule": cfg.schedule,
        "preference": prefs[0] if len(prefs) == 1 else "all",
        "r0": cfg.waiting_reward,
        "human_passive": cfg.human_passive,
        "runs": cfg.runs,
        "episodes": cfg.n_episodes,
        "seed": cfg.seed,
        "wall_time_s": round(result.wall_time_s, 3),
        "agents": agents,
    }


def write_outputs(result: StudyResult, out: str | os.PathLike[str], *, plots: bool = True
                  ) -> list[Path]:
    """Write ``summary.json``, ``episodes.csv`` and the plots into ``out``; return the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cfg = result.config
    summary_path = out / "summary.json"
    summary_path.write_text(json.dumps(summarize(result), indent=1) + "\n")
    csv_path = out / "episodes.csv"
    prefs = cfg.preference_of_run()
    extras = [k for k in next(iter(result.metrics.values())) if k not in METRICS]
    with csv_path.open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["agent", "run", "episode", "preference", "start", "goal", "turn_back",
                         *METRICS, *extras])
        names = graph_for(cfg.scenario).support_names
        s = result.schedule
        for agent, m in result.metrics.items():
            for r in range(cfg.runs):
                for e in range(cfg.n_episodes):
                    writer.writerow([
                        agent, r, e + 1, prefs[r], names[s["start"][r, e]], names[s["goal"][r, e]],
                        int(s["turn_back"][r, e]), round(m["reward"][r, e], 6),
                        *(round(m[k][r, e], 6) for k in ("correct", "passive", "wrong")),
                        int(m["steps"][r, e]), int(m["truncated"][r, e]),
                        *(round(m[k][r, e], 6) for k in extras),
                    ])
    paths = [summary_path, csv_path]
    if plots:
        from hri_envs.bench import plots as plotting

        paths += plotting.study_plots(result, out)
    return paths
