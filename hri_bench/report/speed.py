"""``hri-bench speed``: throughput of the envs and the Learner on this machine.

Besides the throughput figures, :func:`machine_ms` times a fixed numpy workload in the same
run, so that figures from different machines (or from one machine under different load)
can be compared as ratios to it. :data:`SIZES` names how much work each figure does:
``"full"`` for the published figures, ``"tiny"`` for a smoke test that runs in seconds.
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np

from agents.learner import Learner
from agents.learning import partner_mdp
from agents.learning.algorithm1 import Workspace
from agents.protocol import Trace
from hri_bench.report.jax_speed import measure_jax
from hri_bench.run.study import StudyConfig, graph_for, run_study
from hri_envs.envs.speed import parallel_env_steps_per_s, vector_env_steps_per_s
from hri_envs.errors import ConfigError
from hri_envs.task.mdp import one_blas_thread, softmax
from hri_envs.task.scenarios import graph_of, hanger
from hri_envs.task.scenarios.hanger import PREFERENCES as HANGER_PREFERENCES

__all__ = [
    "HANGER_STUDY_PREFERENCES",
    "PHYSICS_PERIODS",
    "PHYSICS_WORLDS",
    "SIZES",
    "SpeedSize",
    "hanger_study_s",
    "learner_update_batched_ms_per_run",
    "learner_update_ms",
    "machine_ms",
    "measure",
    "measure_physics",
]

#: Nine hanger preferences for the paper's simulation study (it does not list its nine):
#: the most frequent one and every fourth of the others.
HANGER_STUDY_PREFERENCES: tuple[str, ...] = (
    "down-over-rotate/over-rotate-up",
    *[p for p in HANGER_PREFERENCES if p != "down-over-rotate/over-rotate-up"][::4][:8],
)


class SpeedSize(NamedTuple):
    """How much work each figure of :func:`measure` does.

    Attributes:
        parallel_steps: Joint steps per timed repeat of the parallel env.
        vector_envs: Envs of the vector env.
        vector_steps: Vector steps per timed repeat.
        env_repeats: Timed repeats of each env figure (the fastest counts).
        update_repeats: Learner updates timed for ``learner_update_ms``.
        batch_runs: Runs of the batched Learner (``learner_update_batched_ms_per_run``).
        batch_repeats: Batched updates timed.
        study_runs: Runs per preference of the hanger study.
        study_episodes: Episodes per run of the hanger study.
        machine_repeats: Timed repeats of the :func:`machine_ms` workload.
    """

    parallel_steps: int
    vector_envs: int
    vector_steps: int
    env_repeats: int
    update_repeats: int
    batch_runs: int
    batch_repeats: int
    study_runs: int
    study_episodes: int
    machine_repeats: int


#: ``"full"``: the published figures; ``"tiny"``: every measurement for real, in seconds
#: (for tests and a quick look; its figures are not comparable to the full ones).
SIZES: dict[str, SpeedSize] = {
    "full": SpeedSize(50_000, 1024, 1_000, 3, 200, 100, 10, 100, 8, 5),
    "tiny": SpeedSize(200, 4, 25, 1, 2, 3, 1, 1, 2, 1),
}


def _wheel_trace() -> tuple[Any, Trace]:
    """The wheel's graph and a typical straight episode from the rack to stand B."""
    graph = graph_for("wheel")
    w = graph.waypoint_state
    states = np.array([0, 1, 3, w(0, 3, 1), w(1, 3, 1), w(1, 1, 1), w(1, 1, 0), 7, 4])
    return graph, Trace(states, np.zeros(8, np.int64), np.zeros(8, np.int64))


def _update_seconds(n_runs: int, repeats: int) -> float:
    """Seconds per Learner update of ``n_runs`` runs on the wheel trace (after a warm-up)."""
    graph, trace = _wheel_trace()
    learner = Learner(graph, n_runs, workspace=Workspace())
    traces, intentions = [trace] * n_runs, np.ones(n_runs, np.int64)
    learner.end_episode(traces, intentions)  # warm-up
    t0 = time.perf_counter()
    for _ in range(repeats):
        learner.end_episode(traces, intentions)
    return (time.perf_counter() - t0) / repeats


def learner_update_ms(scenario: str = "wheel", repeats: int = 200) -> float:
    """Milliseconds for one Learner update (loop removal, IRL step, π̂_H and robot Q), one run.

    Args:
        scenario: Only "wheel" (the trace is a wheel episode).
        repeats: Updates timed after one warm-up.
    """
    if scenario != "wheel":
        raise ConfigError(f"the update is timed on a wheel trace; scenario must be 'wheel', "
                          f"got {scenario!r}", field="scenario")
    return _update_seconds(1, repeats) * 1e3


def learner_update_batched_ms_per_run(runs: int = 100, repeats: int = 10) -> float:
    """Milliseconds per run of one batched Learner update of ``runs`` runs (wheel trace).

    Args:
        runs: Runs advanced together (the studies batch 100).
        repeats: Batched updates timed after one warm-up.
    """
    return _update_seconds(runs, repeats) / runs * 1e3


def machine_ms(repeats: int = 5) -> float:
    """Milliseconds for a fixed numpy workload: the machine's speed, to compare figures by.

    The workload (seeded, always the same, BLAS on one thread like the Learner's update) is
    the update's arithmetic at the studies' batch size, ten times over: 300 linear solves of
    36 x 36, 300 products (432 x 36) @ (36 x 1), and a soft-max over 300 x 36 x 12 values.
    The fastest of ``repeats`` counts. Divide a figure by it (or compare ratios of it) to
    set figures from different machines or loads side by side.
    """
    rng = np.random.default_rng(0)
    a = rng.random((300, 36, 36)) + 36 * np.eye(36)
    b = rng.random((300, 36, 1))
    t = rng.random((300, 432, 36))
    z = rng.random((300, 36, 12))
    valid = np.ones((36, 12), dtype=bool)
    best = np.inf
    with one_blas_thread():
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(10):
                v = np.linalg.solve(a, b)
                np.matmul(t, v)
                softmax(z, valid, 1.0)
            best = min(best, time.perf_counter() - t0)
    return float(best * 1e3)


def hanger_study_s(runs: int = 100, episodes: int = 8, jobs: int = 1) -> float:
    """Seconds for the paper's hanger simulation study: 9 preferences × ``runs`` × ``episodes``,
    Learner only (graph backend).
    """
    t0 = time.perf_counter()
    for i, pref in enumerate(HANGER_STUDY_PREFERENCES):
        cfg = StudyConfig("hanger", agents=("learner",), runs=runs, episodes=episodes,
                          preference=pref, seed=i, jobs=jobs,
                          executor="process" if jobs > 1 else "serial")
        run_study(cfg)
    return time.perf_counter() - t0


#: Worlds stepped together for the physics figures (``--physics``), per size.
PHYSICS_WORLDS: dict[str, tuple[int, ...]] = {"full": (1, 64, 1024, 4096), "tiny": (1, 2)}
#: Control periods (4 physics steps each) timed per world count, per size.
PHYSICS_PERIODS: dict[str, int] = {"full": 25, "tiny": 2}


#: Wall seconds each continuous env is timed for (beside raw ``mj_step``), per size.
CONTINUOUS_SECONDS: dict[str, float] = {"full": 10.0, "tiny": 1.0}


def continuous_figures(seconds: float) -> dict[str, Any]:
    """The continuous envs (hanger, wheel; torque drive; the upper reference acting) on one
    core: simulated seconds per CPU second of the env and of raw ``mj_step`` of the env's own
    physics states, and their ratio (:func:`hri_bench.report.continuous_speed.c_speed`).
    """
    from hri_bench.report.continuous_speed import c_speed

    out: dict[str, Any] = {}
    for scenario in ("hanger", "wheel"):
        c = c_speed(scenario, "torque", seconds)
        out[f"continuous_{scenario}_env_rtf_cpu"] = round(c["env_rtf_cpu"], 1)
        out[f"continuous_{scenario}_raw_rtf_cpu"] = round(c["replay_rtf_cpu"], 1)
        out[f"continuous_{scenario}_env_over_raw"] = round(
            c["env_rtf_cpu"] / c["replay_rtf_cpu"], 3)
    return out


def measure_physics(size: str = "full", worlds: tuple[int, ...] | None = None,
                    device: str | None = None) -> dict[str, Any]:
    """The physics figures: MuJoCo Warp for each number of worlds, beside MuJoCo's C library.

    Both run the C backend's speed workload (the robot carrying the hanger between supports
    A and B, the human following; contacts, sensors, controller and IK on). A world-step is
    one 2 ms physics step of one world; the real-time factor is the simulated seconds of all
    worlds per wall second. ``physics_warp_setup_s`` is the time to build and place the
    first count's worlds and run one control period: on a machine without Warp's kernel
    cache it includes the kernels' compilation (about 1.5 min of one core), later runs load
    them from the cache (``physics_warp_kernel_cache``). Without the ``mjwarp`` extra only
    the C figures and a note are given.

    Args:
        size: A key of :data:`SIZES` ("tiny": 1 and 2 worlds, 2 periods, a smoke test).
        worlds: The numbers of worlds (default :data:`PHYSICS_WORLDS` of the size).
        device: Warp's device (default: Warp's default, a GPU where there is one).
    """
    from hri_envs.physics.panda.speed import physics_realtime_factor

    if size not in SIZES:
        raise ConfigError(f"size must be one of {sorted(SIZES)}, got {size!r}", field="size")
    c = physics_realtime_factor(graph_of(hanger.SPEC), repeats=1)
    dt = 0.002
    figures: dict[str, Any] = {
        "physics_c_world_steps_per_s": round(c.realtime_factor / dt, 1),
        "physics_c_realtime_factor": round(c.realtime_factor, 2),
    }
    figures.update(continuous_figures(CONTINUOUS_SECONDS[size]))
    try:  # the mjwarp extra: its modules, then Warp itself (the cache's folder)
        from hri_envs.physics.panda.warp.speed import warp_world_steps
        from hri_envs.physics.scene.warp.device import kernel_cache_dir

        cache = kernel_cache_dir()
    except ImportError as exc:
        figures["physics_warp"] = f"not measured: {exc}"
        return figures
    by_steps: dict[str, float] = {}
    by_rtf: dict[str, float] = {}
    setup = None
    dev = ""
    for n in worlds if worlds is not None else PHYSICS_WORLDS[size]:
        res = warp_world_steps(n, graph_of(hanger.SPEC), periods=PHYSICS_PERIODS[size],
                               device=device)
        setup = res.setup_s if setup is None else setup
        dev = res.device
        by_steps[str(n)] = round(res.world_steps_per_s, 1)
        by_rtf[str(n)] = round(res.realtime_factor, 2)
    figures.update({
        "physics_warp_device": dev,
        "physics_warp_world_steps_per_s_by_worlds": by_steps,
        "physics_warp_realtime_factor_by_worlds": by_rtf,
        "physics_warp_setup_s": round(setup or 0.0, 1),
        "physics_warp_kernel_cache": cache,
    })
    return figures


def measure(jobs: int = 1, size: str = "full", jax: bool = False) -> dict[str, Any]:
    """All speed figures as a dict (keys: docs/benchmark.md, 'Other subcommands').

    Args:
        jobs: Worker processes for the hanger study.
        size: A key of :data:`SIZES`: "full" (the published figures) or "tiny".
        jax: Add the JAX env's and PPO training's figures
            (:func:`hri_bench.report.jax_speed.measure_jax`; a note when the extra is missing).

    Raises:
        ConfigError: ``size`` is not a key of :data:`SIZES`.
    """
    if size not in SIZES:
        raise ConfigError(f"size must be one of {sorted(SIZES)}, got {size!r}", field="size")
    z = SIZES[size]
    par = parallel_env_steps_per_s(steps=z.parallel_steps, repeats=z.env_repeats)
    vec = vector_env_steps_per_s(num_envs=z.vector_envs, steps=z.vector_steps,
                                 repeats=z.env_repeats)
    figures = {
        "parallel_env_steps_per_s": round(par.steps_per_s, 1),
        "vector_env_steps_per_s": round(vec.steps_per_s, 1),
        "learner_update_ms": round(learner_update_ms("wheel", z.update_repeats), 4),
        "learner_update_batched_ms_per_run": round(
            learner_update_batched_ms_per_run(z.batch_runs, z.batch_repeats), 4),
        "hanger_study_s": round(hanger_study_s(z.study_runs, z.study_episodes, jobs=jobs), 3),
        "machine_ms": round(machine_ms(z.machine_repeats), 3),
        "learner_threads": partner_mdp.threads(),
    }
    if jax:
        figures.update(measure_jax(size, vec.steps_per_s))
    return figures
