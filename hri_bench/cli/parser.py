"""The ``hri-bench`` argument parser (:func:`build_parser`): the subcommands of
:mod:`hri_bench.cli.commands` and their flags, with the argument types they check, and which
argument each :class:`~hri_bench.run.study.StudyConfig` field (:data:`STUDY_ARGUMENTS`) and
``--learner-*`` option (:data:`LEARNER_FLAGS`) comes from.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from hri_bench.cli import people_parser
from hri_bench.cli import results as cli_results
from hri_bench.cli.args import bounded, whole
from hri_bench.run.agents import AGENTS, DEFAULT_STUDY_AGENTS, validate_agent_name
from hri_bench.run.study import EXECUTORS, UNIT_TIME_LIMIT
from hri_bench.suite import (
    DEFAULT_AGENTS,
    DEFAULT_AGENTS_V2,
    DEFAULT_AGENTS_V3,
    LATEST,
    SUITE_VERSIONS,
)
from hri_envs.envs.backends import BACKENDS
from hri_envs.errors import ConfigError
from hri_envs.humans.families import FAMILIES
from hri_envs.humans.populations import POPULATIONS
from hri_envs.humans.splits import MIXTURES
from hri_envs.imports import PLUGIN_GROUP
from hri_envs.task.episode import REWARD_RULES
from hri_envs.task.scenarios import SCENARIOS

#: Every schedule name: "random" and the scenarios' fixed schedules.
_SCHEDULES = ("random", *dict.fromkeys(k for s in SCENARIOS.values() for k in s.schedules))


def _human_param(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"give NAME=VALUE (e.g. k=3), got {text!r}")
    return name.strip(), value.strip()


def _agents(text: str) -> tuple[str, ...]:
    names = tuple(a.strip() for a in text.split(",") if a.strip())
    if not names:
        raise argparse.ArgumentTypeError("give at least one agent")
    for n in names:
        try:
            validate_agent_name(n)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc
    return names


_positive = bounded(int, "a whole number >= 1", lambda v: v >= 1)


def _world_counts(text: str) -> tuple[int, ...]:
    """``--physics-worlds``: comma-separated whole numbers >= 1."""
    return tuple(_positive(w.strip()) for w in text.split(","))


_seed = whole


_seconds = bounded(float, "a number of seconds > 0, or inf", lambda v: v > 0)


_probability = bounded(float, "a probability in [0, 1]", lambda v: 0.0 <= v <= 1.0)


_r0 = bounded(float, "a number in (-1, 0)", lambda v: -1.0 < v < 0.0)


_rationality = bounded(float, "a number > 0 or inf", lambda v: v > 0)


#: ``--learner-*`` options: LearnerConfig field -> (flag, metavar, help). Values are checked
#: by :class:`agents.config.LearnerConfig`; its errors name the flag.
LEARNER_FLAGS: dict[str, tuple[str, type, str]] = {
    "beta": ("--learner-beta", float, "β, intention bias of the Bayes filter, in (0, 1]"),
    "robot_temperature": ("--learner-robot-temperature", float, "τ_R of the robot's soft-max"),
    "human_temperature": ("--learner-human-temperature", float, "τ_H of the human estimate"),
    "eta": ("--learner-eta", float, "η, the robot's relative probability bound, in [0, 1]"),
    "learning_rate": ("--learner-learning-rate", float, "λ, the ME-IRL step size"),
    "gamma": ("--learner-gamma", float, "γ of every Q-iteration, in [0, 1)"),
    "r0": ("--learner-r0", float, "r0 in the Learner's robot reward (default: --r0)"),
    "initial_preference": ("--learner-initial-preference", str,
                           "start the human model from this preference (paper Sect. 7)"),
}


#: The ``study`` argument each :class:`~hri_bench.run.study.StudyConfig` field comes from
#: (a :class:`~hri_envs.errors.ConfigError` names the field in its ``field`` attribute).
STUDY_ARGUMENTS = {
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
    "human_rationality": "--human-rationality",
    "population": "--population",
    "human_drift": "--human-drift",
    "reward": "--reward",
    "physics_preset": "--physics-preset",
    "human_params": "--human-param",
    "unit_time_limit": "--unit-time-limit",
}


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="hri-bench",
        description="Benchmark cooperative learners on the paper's human-robot carrying studies.",
    )
    parser.add_argument("--import", dest="imports", action="append", default=[],
                        metavar="MODULE",
                        help="import MODULE first, so that the scenarios, families, reward "
                             "rules and agents it registers count (repeatable; before the "
                             "command; recorded in summary.json and suite.json, so that "
                             "--config replays it); installed packages' entry points of the "
                             f"group {PLUGIN_GROUP!r} are imported too (docs/extending.md)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _study_parser(sub)
    _figures_parser(sub)
    _speed_parser(sub)
    _play_parser(sub)
    _suite_parser(sub)
    cli_results.add_parsers(sub)
    people_parser.add_parsers(sub)
    _demo_parser(sub)
    return parser


def _study_parser(sub: Any) -> None:
    """The ``study`` command (docs/benchmark.md, "hri-bench study")."""
    study = sub.add_parser("study", help="run one study and write summary.json, CSV and plots",
                           description="Run one study: several agents, many independent runs.")
    _study_task_flags(study)
    _study_run_flags(study)
    _study_human_flags(study)
    _study_learner_flags(study)
    _study_output_flags(study)
    study.set_defaults(command_parser=study)  # reports errors found after parsing


def _study_task_flags(study: argparse.ArgumentParser) -> None:
    """The task: scenario, agents, runs, episodes, schedule, the scripted human."""
    study.add_argument("scenario", choices=SCENARIOS, nargs="?",
                       help="the task (may be left out with --config)")
    study.add_argument("--agents", type=_agents, default=DEFAULT_STUDY_AGENTS,
                       help="comma-separated, from " + ",".join(AGENTS) + ", sb3:PATH, "
                            "jaxppo[:PATH] or module:Class (default: the paper's "
                            + ",".join(DEFAULT_STUDY_AGENTS) + ")")
    study.add_argument("--runs", type=_positive, default=100, help="runs per agent (default 100)")
    study.add_argument("--episodes", type=_positive, default=None,
                       help="episodes per run (default: "
                            + ", ".join(f"{n} {s.episodes}" for n, s in SCENARIOS.items())
                            + "".join(f", {n} {k} {len(rows)}" for n, s in SCENARIOS.items()
                                      for k, rows in s.schedules.items()) + ")")
    study.add_argument("--schedule", choices=_SCHEDULES, default="random",
                       help="random start/goal per episode, or a fixed one ("
                            + ", ".join(f"{k}: the {n}'s" for n, s in SCENARIOS.items()
                                        for k in s.schedules) + ", the user study's Table 2)")
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


def _study_run_flags(study: argparse.ArgumentParser) -> None:
    """Seed, execution, backend, step limit and reward rule."""
    study.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    study.add_argument("--jobs", type=_positive, default=1, help="parallel workers (default 1)")
    study.add_argument("--executor", choices=EXECUTORS, default=None,
                       help="serial, process (default when --jobs > 1) or ray")
    study.add_argument("--ray-address", default=None, help="Ray cluster address (executor ray)")
    _time_limit_flag(study)
    study.add_argument("--backend", choices=BACKENDS, default="graph",
                       help="graph (abstract task graph), mujoco (simulated Panda, MuJoCo's C "
                            "library, one run at a time; slow: about 0.2 s per step) or mjwarp "
                            "(the same physics on MuJoCo Warp, every run of a unit in its own "
                            "world at once; the 'mjwarp' extra; docs/physics.md)")
    study.add_argument("--physics-preset", default=None,
                       help="named physics options of the backend (mujoco: "
                            + ", ".join(BACKENDS["mujoco"].presets) + "; docs/physics.md)")
    study.add_argument("--max-steps", type=_positive, default=100,
                       help="step limit per episode (default 100)")
    study.add_argument("--reward", choices=tuple(REWARD_RULES), default="paper",
                       help="reward rule (default paper): "
                            + "; ".join(f"{n}: {r.description}" for n, r in REWARD_RULES.items()))


def _time_limit_flag(parser: argparse.ArgumentParser) -> None:
    """``--unit-time-limit`` (``study`` and ``suite``)."""
    parser.add_argument("--unit-time-limit", type=_seconds, default=None,
                        metavar="S",
                        help="the most wall seconds one unit of work (an agent's chunk of "
                             "runs: at most 1,000 episodes, or one run on mujoco) may take; "
                             "a unit over it, like a worker process that dies, stops the "
                             "study with an error naming it, its finished units kept for "
                             f"--resume (default {UNIT_TIME_LIMIT:g}, none on mjwarp, whose "
                             "speed is its device's; inf: no limit)")


def _study_human_flags(study: argparse.ArgumentParser) -> None:
    """Humans other than the scripted one: Boltzmann, a population, a drift."""
    study.add_argument("--human-rationality", type=_rationality, default=float("inf"),
                       metavar="BETA",
                       help="Boltzmann human: samples softmax(BETA * Q_pref) (docs/benchmark.md);"
                            " inf (default) = the deterministic scripted human")
    study.add_argument("--population", default=None, metavar="NAME",
                       help="draw each run's human from a population: "
                            + ", ".join(f"{n}{' (held out)' if p.held_out else ''}"
                                        for n, p in POPULATIONS.items())
                            + "; a split or a part of one ("
                            + ", ".join(dict.fromkeys(n for n, _ in MIXTURES)) + "); a family ("
                            + ", ".join(FAMILIES) + "); recorded:DATASET or "
                            "recorded-irl:DATASET (a model fitted to recorded sessions); "
                            "module:Class (your own)")
    study.add_argument("--human-param", type=_human_param, action="append", default=None,
                       dest="human_params", metavar="NAME=VALUE",
                       help="a parameter of the family given as --population (repeatable), "
                            "e.g. --population impatient --human-param k=3")
    study.add_argument("--human-drift", type=_positive, default=None, metavar="K",
                       help="the human switches to another preference after K episodes")


def _study_learner_flags(study: argparse.ArgumentParser) -> None:
    """The ``--learner-*`` changes to the Learner's configuration."""
    for field_name, (flag, kind, text) in LEARNER_FLAGS.items():
        study.add_argument(flag, type=kind, default=None, dest=f"learner_{field_name}",
                           metavar="P" if kind is str else "X", help=text)
    study.add_argument("--learner-no-passive-prior", action="store_true",
                       help="the Learner's bounded soft-max without the passive baseline "
                            "(paper Sect. 7)")


def _study_output_flags(study: argparse.ArgumentParser) -> None:
    """Where the study goes, and replaying or resuming one."""
    study.add_argument("--out", required=True, type=Path,
                       help="output directory (new or empty, unless --resume or --overwrite)")
    study.add_argument("--resume", action="store_true",
                       help="continue the interrupted study in --out (same settings and --jobs)")
    study.add_argument("--overwrite", action="store_true",
                       help="start afresh in a non-empty --out (replaces the study's files)")
    study.add_argument("--config", type=Path, default=None,
                       help="re-run the study a summary.json describes (its 'settings'); "
                            "only --out, --jobs, --executor, --ray-address, --resume, "
                            "--overwrite and --no-progress may be given with it")
    study.add_argument("--no-progress", action="store_true", help="hide the progress bar")


def _figures_parser(sub: Any) -> None:
    """The ``figures`` command."""
    figs = sub.add_parser("figures", help="reproduce the paper's figures as PNGs",
                          description="Run the studies behind Figs. 4, 8, 10a-c, 11 and 12.")
    figs.add_argument("--out", required=True, type=Path, help="output directory")
    figs.add_argument("--runs", type=_positive, default=100, help="runs per study (default 100)")
    figs.add_argument("--jobs", type=_positive, default=1, help="worker processes (default 1)")
    figs.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    figs.add_argument("--only", default=None,
                      help="comma-separated subset of fig10a,fig10b,fig10c,fig11,fig12,fig8,fig4")
    figs.add_argument("--wheel-episodes", type=_positive, default=20,
                      help="episodes per wheel run (default 20)")


def _speed_parser(sub: Any) -> None:
    """The ``speed`` command."""
    speed = sub.add_parser("speed", help="measure env and Learner throughput",
                           description="Measure parallel_env_steps_per_s, vector_env_steps_per_s "
                                       "(1024 envs), learner_update_ms (wheel) and "
                                       "learner_update_batched_ms_per_run (100 runs), "
                                       "hanger_study_s (9 preferences x 100 runs x 8 episodes, "
                                       "Learner only) and machine_ms (a fixed numpy workload "
                                       "to compare machines by).")
    speed.add_argument("--json", action="store_true", help="end with one JSON line")
    speed.add_argument("--jobs", type=_positive, default=1,
                       help="worker processes for the hanger study (default 1)")
    speed.add_argument("--size", choices=("full", "tiny"), default="full",
                       help="full: the published figures (default); tiny: a smoke test in "
                            "seconds whose figures are not comparable")
    speed.add_argument("--no-jax", action="store_true",
                       help="skip the JAX env and PPO training figures (measured when the "
                            "jax extra is installed)")
    speed.add_argument("--physics", action="store_true",
                       help="add the physics figures (not in the default run: minutes on a "
                            "CPU): world-steps/s and real-time factor of MuJoCo Warp for 1, "
                            "64, 1,024 and 4,096 worlds on Warp's device (named), beside "
                            "MuJoCo's C library; the first run on a machine also compiles "
                            "Warp's kernels (about 1.5 min, then cached)")
    speed.add_argument("--physics-worlds", type=_world_counts, default=None,
                       help="comma-separated numbers of worlds for --physics (default "
                            "1,64,1024,4096)")


def _play_parser(sub: Any) -> None:
    """The ``play`` command."""
    game = sub.add_parser(
        "play", help="play the human in the terminal against the Learner",
        description="You are the human, the Learner is the robot and learns between "
                    "episodes. Each step shows the state, the robot's belief over your goal "
                    "and the action it chose, and lists your valid actions numbered from 1 "
                    "(as the keys of hri-bench serve's page); type a number, or q to stop "
                    "(the end of input, Ctrl-D, stops too). Your goal is yours alone: choose "
                    "a support and carry the object there.")
    game.add_argument("scenario", choices=SCENARIOS, help="the task")
    game.add_argument("--episodes", type=_positive, default=3,
                      help="episodes to play, each from a random start support (default 3)")
    game.add_argument("--seed", type=_seed, default=0,
                      help="seed of the starts and of the robot, >= 0 (default 0)")


def _demo_parser(sub: Any) -> None:
    """The ``demo`` command (``make demo``)."""
    demo = sub.add_parser(
        "demo", help="the main job (make demo): the paper's figures at full size, then what next",
        description="The main job of make demo: the studies behind the paper's figures that "
                    "hri-bench figures draws (Figs. 4, 8, 10a-c, 11 and 12) at full size, 100 "
                    "runs per study and 20 wheel episodes (hri-bench figures --runs 100), "
                    "written as PNGs into --out; then the commands to try next. The first run "
                    "after installing also compiles the Learner's kernels (about a minute, "
                    "once). Fig. 6 needs the physics: examples/physics_table2.py.")
    demo.add_argument("--out", type=Path, default=Path("out/demo"),
                      help="output directory (default out/demo)")
    demo.add_argument("--jobs", type=_positive, default=2,
                      help="worker processes (default 2)")


def _suite_parser(sub: Any) -> None:
    """The ``suite`` command's flags (docs/benchmark.md, "Suite")."""
    suite = sub.add_parser("suite", help="run the versioned benchmark suite and a leaderboard",
                           description="Run every track of the benchmark suite (one study "
                           "each) and write suite.json, leaderboard.md and one figure per "
                           "track.")
    suite.add_argument("--out", required=True, type=Path,
                       help="output directory (new or empty, unless --resume or --overwrite)")
    suite.add_argument("--physical", action="store_true",
                       help="the physical suite instead (robots that feel the human on the "
                            "continuous envs; its flags: hri-bench suite --physical --help)")
    suite.add_argument("--resume", action="store_true",
                       help="continue the suite interrupted in --out (same settings): tracks "
                            "and units already finished are not run again")
    suite.add_argument("--overwrite", action="store_true",
                       help="start afresh in a non-empty --out (removes only the suite's own "
                            "files: its outputs, every track's figure, seed-S folders)")
    suite.add_argument("--suite-version", choices=SUITE_VERSIONS, default=LATEST,
                       help=f"the track set (default {LATEST}: the test split v2's four groups "
                            "of humans as headline tracks, normalised to the reachable "
                            "reference; 2: the test split with a reference or bracket on every "
                            "track; 1: the first ten tracks; 1 and 2 as they were)")
    suite.add_argument("--jobs", type=_positive, default=1,
                       help="parallel workers per track (default 1)")
    suite.add_argument("--agents", type=_agents, default=None,
                       help="agents to rank, comma-separated, e.g. learner,mypkg.mod:MyAgent "
                            f"(default v3: {','.join(DEFAULT_AGENTS_V3)}; v2: "
                            f"{','.join(DEFAULT_AGENTS_V2)}; v1: {','.join(DEFAULT_AGENTS)}; "
                            "the references and the floor are added where they fit)")
    suite.add_argument("--executor", choices=EXECUTORS, default=None,
                       help="serial, process (default with --jobs > 1) or ray")
    suite.add_argument("--runs-scale", type=bounded(float, "a number > 0",
                                                     lambda v: math.isfinite(v) and v > 0),
                       default=1.0, help="multiply every track's runs (default 1)")
    suite.add_argument("--tracks", default=None,
                       help="comma-separated track names (default: all)")
    suite.add_argument("--seed", type=_seed, default=0, help="base seed, >= 0 (default 0)")
    suite.add_argument("--population", action="append", default=[], metavar="NAME",
                       help="add a track of its own on a recorded population "
                            "(recorded:DATASET or recorded-irl:DATASET; repeatable)")
    _time_limit_flag(suite)
    suite.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    cli_results.add_suite_flags(suite)  # --config, --seeds (docs/results.md)
    suite.set_defaults(command_parser=suite)
