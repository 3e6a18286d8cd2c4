"""``hri-bench``: reproduce the paper's studies and figures, measure speed, play the human.

Subcommands::

    hri-bench study {hanger,wheel} --out DIR [options]   one study: summary, CSV, plots
    hri-bench figures --out DIR [--runs N] [--jobs J]     the paper's figures (Figs. 4, 8, 10-12)
    hri-bench speed [--json]                              env and Learner throughput
    hri-bench play {hanger,wheel}                         you are the human, in the terminal
    hri-bench demo --out DIR                              the main job of ``make demo``

Bad arguments exit with code 2 and a message naming the argument and what is allowed.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hri_envs.bench.agents import BUILTIN_AGENTS
from hri_envs.bench.runner import TABLE2
from hri_envs.bench.study import EXECUTORS
from hri_envs.envs.backends import BACKENDS
from hri_envs.errors import ConfigError
from hri_envs.task.scenarios import SCENARIOS

__all__ = ["build_parser", "main"]


def _agents(text: str) -> tuple[str, ...]:
    from hri_envs.bench.agents import validate_agent_name

    names = tuple(a.strip() for a in text.split(",") if a.strip())
    if not names:
        raise argparse.ArgumentTypeError("give at least one agent")
    for n in names:
        try:
            validate_agent_name(n)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc
    return names


def _bounded(kind: type, allowed: str, ok: Callable[[Any], bool]) -> Callable[[str], Any]:
    """An argparse ``type`` parsing ``kind`` and checking it, with a message saying what is
    allowed.
    """

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {text!r}") from None
        if not ok(value):
            raise argparse.ArgumentTypeError(f"expected {allowed}, got {value}")
        return value

    return parse


_positive = _bounded(int, "a whole number >= 1", lambda v: v >= 1)
_probability = _bounded(float, "a probability in [0, 1]", lambda v: 0.0 <= v <= 1.0)
_r0 = _bounded(float, "a number in (-1, 0)", lambda v: -1.0 < v < 0.0)

#: The ``study`` argument each :class:`~hri_envs.bench.study.StudyConfig` field comes from
#: (a :class:`~hri_envs.errors.ConfigError` names the field in its ``field`` attribute).
_STUDY_ARGUMENTS = {
    "scenario": "scenario",
    "agents": "--agents",
    "runs": "--runs",
    "episodes": "--episodes",
    "schedule": "--schedule",
    "preference": "--preference",
    "r0": "--r0",
    "human_passive": "--human-passive",
    "turn_back": "--turn-back",
    "seed": "--seed",
    "jobs": "--jobs",
    "executor": "--executor",
    "ray_address": "--ray-address",
    "backend": "--backend",
    "max_steps": "--max-steps",
    "physics_preset": "--physics-preset",
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="hri-bench",
        description="Benchmark cooperative learners on the paper's human-robot carrying studies.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    study = sub.add_parser("study", help="run one study and write summary.json, CSV and plots",
                           description="Run one study: several agents, many independent runs.")
    study.add_argument("scenario", choices=SCENARIOS)
    study.add_argument("--agents", type=_agents, default=BUILTIN_AGENTS,
                       help=f"comma-separated, from {','.join(BUILTIN_AGENTS)} or module:Class "
                            "(default: all built-in)")
    study.add_argument("--runs", type=_positive, default=100, help="runs per agent (default 100)")
    study.add_argument("--episodes", type=_positive, default=None,
                       help="episodes per run (default: "
                            + ", ".join(f"{n} {s.episodes}" for n, s in SCENARIOS.items())
                            + f", table2 {len(TABLE2)})")
    study.add_argument("--schedule", choices=("random", "table2"), default="random",
                       help="random start/goal per episode, or the user study's Table 2")
    study.add_argument("--preference", default=None,
                       help="the scripted human's preference ("
                            + "; ".join(f"{n}: {', '.join(s.preferences[:2])}"
                                        + (", ..." if len(s.preferences) > 2 else "")
                                        for n, s in SCENARIOS.items())
                            + "; 'all' cycles over all; default: "
                            + ", ".join(f"{n} {s.default_preference}"
                                        for n, s in SCENARIOS.items()) + ")")
    study.add_argument("--r0", type=_r0, default=None,
                       help="robot reward for waiting while the human acts, in (-1, 0) "
                            "(default: "
                            + ", ".join(f"{n} {s.r0}" for n, s in SCENARIOS.items()) + ")")
    study.add_argument("--human-passive", type=_probability, default=0.0,
                       help="probability that the human waits in a step (default 0)")
    study.add_argument("--turn-back", type=_probability, default=0.0,
                       help="probability per episode that the human turns back halfway")
    study.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    study.add_argument("--jobs", type=_positive, default=1, help="parallel workers (default 1)")
    study.add_argument("--executor", choices=EXECUTORS, default=None,
                       help="serial, process (default when --jobs > 1) or ray")
    study.add_argument("--ray-address", default=None, help="Ray cluster address (executor ray)")
    study.add_argument("--backend", choices=BACKENDS, default="graph",
                       help="graph (abstract task graph) or mujoco (simulated Panda; slow: "
                            "about 0.2 s per step)")
    study.add_argument("--physics-preset", default=None,
                       help="named physics options of the backend (mujoco: "
                            + ", ".join(BACKENDS["mujoco"].presets) + "; docs/physics.md)")
    study.add_argument("--max-steps", type=_positive, default=100,
                       help="step limit per episode (default 100)")
    study.add_argument("--out", required=True, type=Path, help="output directory")
    study.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    study.set_defaults(command_parser=study)  # reports errors found after parsing

    figs = sub.add_parser("figures", help="reproduce the paper's figures as PNGs",
                          description="Run the studies behind Figs. 4, 8, 10a-c, 11 and 12.")
    figs.add_argument("--out", required=True, type=Path, help="output directory")
    figs.add_argument("--runs", type=_positive, default=100, help="runs per study (default 100)")
    figs.add_argument("--jobs", type=_positive, default=1, help="worker processes (default 1)")
    figs.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    figs.add_argument("--only", default=None,
                      help="comma-separated subset of fig10a,fig10b,fig10c,fig11,fig12,fig8,fig4")
    figs.add_argument("--wheel-episodes", type=_positive, default=20,
                      help="episodes per wheel run (default 20)")

    speed = sub.add_parser("speed", help="measure env and Learner throughput",
                           description="Measure parallel_env_steps_per_s, vector_env_steps_per_s "
                                       "(1024 envs), learner_update_ms (wheel) and "
                                       "hanger_study_s (9 preferences x 100 runs x 8 episodes, "
                                       "Learner only).")
    speed.add_argument("--json", action="store_true", help="end with one JSON line")
    speed.add_argument("--jobs", type=_positive, default=1,
                       help="worker processes for the hanger study (default 1)")

    play = sub.add_parser("play", help="play the human in the terminal against the Learner")
    play.add_argument("scenario", choices=SCENARIOS)
    play.add_argument("--episodes", type=_positive, default=3)
    play.add_argument("--seed", type=int, default=0)

    demo = sub.add_parser("demo", help="the main job: a reduced but real set of the figures")
    demo.add_argument("--out", type=Path, default=Path("out/demo"))
    demo.add_argument("--jobs", type=_positive, default=2)
    return parser


def _config_error(parser: argparse.ArgumentParser, exc: ConfigError,
                  arguments: dict[str, str]) -> None:
    """Exit with status 2 like argparse does, naming the argument the bad field came from."""
    argument = arguments.get(exc.field or "")
    parser.error(f"argument {argument}: {exc}" if argument else str(exc))


def _study(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from hri_envs.bench.study import StudyConfig, run_study, write_outputs

    executor = args.executor or ("process" if args.jobs > 1 else "serial")
    try:
        cfg = StudyConfig(
            args.scenario, agents=args.agents, runs=args.runs, episodes=args.episodes,
            schedule=args.schedule, preference=args.preference, r0=args.r0,
            human_passive=args.human_passive, turn_back=args.turn_back, seed=args.seed,
            jobs=args.jobs, executor=executor, backend=args.backend, max_steps=args.max_steps,
            ray_address=args.ray_address, physics_preset=args.physics_preset,
        )
    except ConfigError as exc:
        _config_error(parser, exc, _STUDY_ARGUMENTS)
    result = run_study(cfg, progress=not args.no_progress)
    paths = write_outputs(result, args.out)
    print(f"{cfg.scenario} study: {len(cfg.agents)} agents x {cfg.runs} runs x "
          f"{cfg.n_episodes} episodes in {result.wall_time_s:.1f} s")
    for name, m in result.metrics.items():
        print(f"  {name:10s} reward first {m['reward'][:, 0].mean():7.2f}  "
              f"last {m['reward'][:, -1].mean():7.2f}")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _figures(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from hri_envs.bench.figures import FIGURES, make_figures

    only = FIGURES if args.only is None else tuple(f.strip() for f in args.only.split(","))
    bad = [f for f in only if f not in FIGURES]
    if bad:
        parser.error(f"--only: unknown figure(s) {', '.join(bad)}; allowed: {', '.join(FIGURES)}")
    t0 = time.perf_counter()
    paths = make_figures(args.out, runs=args.runs, jobs=args.jobs,
                         executor="process" if args.jobs > 1 else "serial", seed=args.seed,
                         only=only, wheel_episodes=args.wheel_episodes,
                         progress=sys.stderr.isatty())
    print(f"figures in {time.perf_counter() - t0:.1f} s: " + ", ".join(str(p) for p in paths))
    return 0


def _speed(args: argparse.Namespace) -> int:
    from hri_envs.bench.speed import measure

    figures = measure(jobs=args.jobs)
    targets = {"parallel_env_steps_per_s": ">= 30,000", "vector_env_steps_per_s": ">= 1,000,000",
               "learner_update_ms": "<= 2", "hanger_study_s": "<= 5"}
    for key, value in figures.items():
        print(f"{key:26s} {value:>14,.3f}   (target {targets[key]})")
    if args.json:
        print(json.dumps(figures))
    return 0


def _demo(args: argparse.Namespace) -> int:
    from hri_envs.bench.figures import make_figures

    t0 = time.perf_counter()
    print("hri-bench demo: the wheel studies (Fig. 10a-c, 100 runs x 20 episodes), the Learner's "
          "policies (Figs. 11-12) and the hanger studies (Figs. 4 and 8)")
    paths = make_figures(args.out, runs=100, jobs=args.jobs,
                         executor="process" if args.jobs > 1 else "serial", wheel_episodes=20,
                         progress=sys.stderr.isatty())
    print(f"done in {time.perf_counter() - t0:.0f} s; plots:")
    for p in paths:
        print(f"  {p}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``hri-bench`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "study":
        return _study(args, args.command_parser)
    if args.command == "figures":
        return _figures(args, parser)
    if args.command == "speed":
        return _speed(args)
    if args.command == "play":
        from hri_envs.bench.play import play

        play(args.scenario, episodes=args.episodes, seed=args.seed)
        return 0
    return _demo(args)


if __name__ == "__main__":
    sys.exit(main())
