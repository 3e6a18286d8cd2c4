"""Sample efficiency: cooperation reward against episodes of interaction with the same human.

The paper's point is that the Learner adapts to a human within a handful of episodes. This
study makes it measurable next to standard deep RL trained against the same scripted human:

- **Learner**: :func:`~hri_bench.run.study.run_study`; its reward in its e-th episode with
  the human (mean and interquartile range over runs);
- **MaskablePPO** and **MaskedDQN** (:mod:`agents.rl`): trained on the Gymnasium env with
  the same human; at increasing numbers n of *training episodes* the frozen policy is
  evaluated on fixed evaluation episodes (random start and goal, drawn from the study's
  seed like the Learner's), per training seed;
- **Oracle** (knows ι: the ceiling, reward 0), **Passive** and the uniformly **random**
  valid-action policy as references.

Normalised score: ``(R - R_random) / (R_oracle - R_random)``, the usual RL normalisation
with the random policy at 0 and the expert (here the Oracle) at 1. "Episodes to 90 % of the
Oracle" is the first point of an agent's mean curve whose score is >= 0.9; "episodes to
r0" the first whose mean reward is within 0.01 of ``r0`` per episode.

A robot that cannot see ι pays about one ``r0`` per episode at best: it has to wait where
the human's first move reveals the goal (guessing costs -1 half of the time). So no such
agent reaches the Oracle's 0, and in the Passive-to-Oracle normalisation, which is also
reported, its ceiling is about ``1 - r0 / R_passive`` (77 % on the hanger).

Run it (under a minute on two cores)::

    python -m hri_bench.report.sample_efficiency --out docs/figures

writes ``sample_efficiency.png`` and ``sample_efficiency.json`` (by default into
``out/sample_efficiency``, never into the tracked docs: the command above, which regenerates
the docs' figure, names ``--out docs/figures``).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from baselines import Oracle, Passive
from hri_bench.run.runner import make_schedule, simulate
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios import SCENARIOS, NamedScenario

__all__ = [
    "RL_ALGORITHMS",
    "SampleEfficiencyConfig",
    "SampleEfficiencyResult",
    "episodes_to_reach",
    "main",
    "plot",
    "run_sample_efficiency",
]

RL_ALGORITHMS: tuple[str, ...] = ("ppo", "dqn")
_STEPS_PER_EPISODE = 15
@dataclass(frozen=True)
class SampleEfficiencyConfig(NamedScenario):
    """What to measure.

    Attributes:
        scenario: "hanger" or "wheel".
        preference: The scripted human's preference (None: the scenario's default).
        r0: Robot reward for waiting while the human acts (None: the paper's).
        runs: Learner runs; the RL policies are evaluated on the first ``eval_runs`` of them.
        episodes: Learner episodes per run.
        eval_runs: Evaluation runs of each RL checkpoint (and of the random policy).
        eval_episodes: Episodes per evaluation run.
        algorithms: RL algorithms to train, from :data:`RL_ALGORITHMS`.
        ppo_checkpoints: Training episodes at which MaskablePPO is evaluated.
        dqn_checkpoints: Training episodes at which MaskedDQN is evaluated.
        rl_seeds: Training seeds per algorithm.
        n_envs: Envs MaskablePPO trains on (the numpy vector env).
        seed: Base seed of the Learner study and of the evaluation episodes.
        threshold: Normalised score that counts as reaching the Oracle.
    """

    scenario: str = "hanger"
    preference: str | None = None
    r0: float | None = None
    runs: int = 100
    episodes: int = 20
    eval_runs: int = 50
    eval_episodes: int = 8
    algorithms: tuple[str, ...] = RL_ALGORITHMS
    ppo_checkpoints: tuple[int, ...] = (25, 50, 100, 200, 400, 800, 1600, 3200)
    dqn_checkpoints: tuple[int, ...] = (10, 25, 50, 100, 200, 400)
    rl_seeds: tuple[int, ...] = (0, 1, 2)
    n_envs: int = 8
    seed: int = 0
    threshold: float = 0.9

    def __post_init__(self) -> None:
        if self.spec.gym_id is None:  # (an unknown one raises there)
            raise ConfigError(f"scenario {self.scenario!r} registers no Gymnasium id to train "
                              "RL on", field="scenario")
        bad = [a for a in self.algorithms if a not in RL_ALGORITHMS]
        if bad:
            raise ConfigError(f"unknown algorithm(s) {bad}; allowed: {', '.join(RL_ALGORITHMS)}",
                              field="algorithms")
        for name in ("runs", "episodes", "eval_runs", "eval_episodes", "n_envs"):
            if getattr(self, name) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}", field=name)
        if self.eval_runs > self.runs:
            raise ConfigError(f"eval_runs must be <= runs ({self.runs}), got {self.eval_runs}",
                              field="eval_runs")
        for name in ("ppo_checkpoints", "dqn_checkpoints"):
            points = getattr(self, name)
            if not points or list(points) != sorted(set(points)) or points[0] < 1:
                raise ConfigError(f"{name} must be increasing positive episode counts, "
                                  f"got {points}", field=name)
        if not self.rl_seeds:
            raise ConfigError("rl_seeds must name at least one seed, got none", field="rl_seeds")
        if not 0.0 < self.threshold <= 1.0:
            raise ConfigError(f"threshold must be in (0, 1], got {self.threshold}",
                              field="threshold")

    @property
    def waiting_reward(self) -> float:
        """r0 after defaults."""
        return self.spec.r0 if self.r0 is None else self.r0


@dataclass
class SampleEfficiencyResult:
    """Curves and references of one study (rewards are per episode, ≤ 0).

    Attributes:
        config: What was measured.
        learner_episodes: (E,) 1 .. E.
        learner_reward: (E,) mean reward of the Learner's e-th episode.
        learner_q25: (E,) its 25th percentile over runs.
        learner_q75: (E,) its 75th percentile.
        rl_episodes: Per algorithm, (C,) training episodes at the checkpoints (mean over
            seeds of the count actually reached).
        rl_reward: Per algorithm, (seeds, C) evaluated mean reward per checkpoint.
        rl_steps: Per algorithm, (seeds, C) env steps taken by then.
        references: Mean reward of "oracle", "passive" and "random".
        wall_time_s: Per part ("learner", "ppo", ...), seconds.
    """

    config: SampleEfficiencyConfig
    learner_episodes: np.ndarray
    learner_reward: np.ndarray
    learner_q25: np.ndarray
    learner_q75: np.ndarray
    rl_episodes: dict[str, np.ndarray] = field(default_factory=dict)
    rl_reward: dict[str, np.ndarray] = field(default_factory=dict)
    rl_steps: dict[str, np.ndarray] = field(default_factory=dict)
    references: dict[str, float] = field(default_factory=dict)
    wall_time_s: dict[str, float] = field(default_factory=dict)

    def normalized(self, reward: np.ndarray | float, floor: str = "random") -> np.ndarray:
        """Score ``(R - R_floor) / (R_oracle - R_floor)``; ``floor`` is "random" or "passive"."""
        low, high = self.references[floor], self.references["oracle"]
        return (np.asarray(reward, dtype=float) - low) / (high - low)

    def curves(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Per agent, (episodes of interaction, mean reward)."""
        out = {"learner": (self.learner_episodes, self.learner_reward)}
        for algo, reward in self.rl_reward.items():
            out[algo] = (self.rl_episodes[algo], reward.mean(axis=0))
        return out

    def episodes_to_threshold(self, floor: str = "random") -> dict[str, float | None]:
        """Per agent, episodes until the mean curve first reaches the threshold (None: never)."""
        return {name: episodes_to_reach(x, self.normalized(y, floor), self.config.threshold)
                for name, (x, y) in self.curves().items()}

    def episodes_to_blind_optimum(self, tolerance: float = 0.01) -> dict[str, float | None]:
        """Per agent, episodes until the mean reward first reaches ``r0 - tolerance``: one
        wait per episode, the best a robot that cannot see ι can expect (see module docs).
        """
        level = self.config.waiting_reward - tolerance
        return {name: episodes_to_reach(x, y, level) for name, (x, y) in self.curves().items()}

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        cfg = asdict(self.config)
        return {
            "config": cfg,
            "references": self.references,
            "learner": {"episodes": self.learner_episodes.tolist(),
                        "reward": self.learner_reward.tolist(),
                        "q25": self.learner_q25.tolist(), "q75": self.learner_q75.tolist()},
            "rl": {a: {"episodes": self.rl_episodes[a].tolist(),
                       "reward": self.rl_reward[a].tolist(),
                       "steps": self.rl_steps[a].tolist()} for a in self.rl_reward},
            "episodes_to_90pct_oracle": self.episodes_to_threshold("random"),
            "episodes_to_90pct_oracle_from_passive": self.episodes_to_threshold("passive"),
            "episodes_to_r0_per_episode": self.episodes_to_blind_optimum(),
            "final_score": {name: float(self.normalized(y[-1]))
                            for name, (_, y) in self.curves().items()},
            "final_score_from_passive": {name: float(self.normalized(y[-1], "passive"))
                                         for name, (_, y) in self.curves().items()},
            "wall_time_s": self.wall_time_s,
        }


def episodes_to_reach(episodes: np.ndarray, score: np.ndarray, threshold: float) -> float | None:
    """The first ``episodes[i]`` with ``score[i] >= threshold``, or None."""
    hit = np.flatnonzero(np.asarray(score) >= threshold - 1e-12)
    return float(episodes[hit[0]]) if hit.size else None


def _reference(cfg: SampleEfficiencyConfig, agent: Any) -> float:
    """Mean reward of a fixed agent on the evaluation episodes."""
    graph = cfg.graph
    human = preference_human(graph, cfg.preference)
    runs = np.arange(cfg.eval_runs)
    schedule = make_schedule(graph, "random", runs, cfg.eval_episodes, cfg.seed, human)
    m = simulate(graph, agent, human, schedule, runs=runs, seed=cfg.seed,
                 r0=cfg.waiting_reward)
    return float(m.reward.mean())


def _train_curve(cfg: SampleEfficiencyConfig, algo: str, seed: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(episodes, reward, steps) at the checkpoints of one training run."""
    from agents.rl import EpisodeCheckpoints, train_dqn, train_maskable_ppo  # the rl extra
    from agents.sb3 import SB3BatchAgent  # the rl extra too

    checkpoints = cfg.ppo_checkpoints if algo == "ppo" else cfg.dqn_checkpoints
    episodes: list[float] = []
    rewards: list[float] = []
    steps: list[float] = []

    def evaluate(model: Any, n_episodes: int) -> None:
        agent = SB3BatchAgent(model, cfg.eval_runs, graph=cfg.graph)
        while len(rewards) < len(checkpoints) and checkpoints[len(rewards)] <= n_episodes:
            episodes.append(n_episodes)
            rewards.append(_reference(cfg, agent))
            steps.append(model.num_timesteps)

    callback = EpisodeCheckpoints(checkpoints, evaluate)
    env_kwargs = {"preference": cfg.preference, "r0": cfg.waiting_reward}
    # Step budget: the callback stops training at the last checkpoint long before this
    # (episodes take ~10 steps even for the random policy); DQN's exploration schedule is
    # a fraction of it.
    budget = _STEPS_PER_EPISODE * checkpoints[-1]
    train: Callable[..., Any] = train_maskable_ppo if algo == "ppo" else train_dqn
    n_envs = cfg.n_envs if algo == "ppo" else 1
    env_id = cfg.spec.gym_id
    model = train(env_id, budget, n_envs=n_envs, vec="vector", seed=seed,
                  callback=callback, **env_kwargs)
    if len(rewards) < len(checkpoints):  # budget spent first: evaluate where training ended
        evaluate(model, max(callback.episodes, checkpoints[-1]))
    return np.array(episodes), np.array(rewards), np.array(steps)


def run_sample_efficiency(cfg: SampleEfficiencyConfig, *, verbose: bool = False
                          ) -> SampleEfficiencyResult:
    """Measure the curves of :class:`SampleEfficiencyResult` (see the module docs)."""
    from agents.rl import RandomMasked  # the rl extra (stable-baselines3, torch)

    say = print if verbose else (lambda *a, **k: None)
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    study = run_study(StudyConfig(
        cfg.scenario, agents=("learner",), runs=cfg.runs,
        episodes=cfg.episodes, preference=cfg.preference, r0=cfg.r0, seed=cfg.seed),
        progress=verbose)
    learner = study.metrics["learner"]["reward"]
    graph = cfg.graph
    n = cfg.eval_runs
    references = {
        "oracle": _reference(cfg, Oracle(graph, preference_human(graph, cfg.preference), n)),
        "passive": _reference(cfg, Passive(graph, n)),
        "random": _reference(cfg, RandomMasked(n, seed=cfg.seed)),
    }
    times["learner"] = time.perf_counter() - t0
    say(f"learner and references in {times['learner']:.1f} s: "
        + ", ".join(f"{k} {v:.2f}" for k, v in references.items()))
    result = SampleEfficiencyResult(
        cfg, np.arange(1, cfg.episodes + 1), learner.mean(0),
        np.percentile(learner, 25, 0), np.percentile(learner, 75, 0), references=references)
    bar = None
    if verbose:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(cfg.algorithms) * len(cfg.rl_seeds), unit="training run",
                   desc="RL training", leave=False)
    for algo in cfg.algorithms:
        t0 = time.perf_counter()
        curves = []
        for s in cfg.rl_seeds:
            curves.append(_train_curve(cfg, algo, s))
            if bar is not None:
                bar.update(1)
        result.rl_episodes[algo] = np.mean([c[0] for c in curves], axis=0)
        result.rl_reward[algo] = np.array([c[1] for c in curves])
        result.rl_steps[algo] = np.array([c[2] for c in curves])
        times[algo] = time.perf_counter() - t0
        say(f"{algo}: {len(cfg.rl_seeds)} seeds in {times[algo]:.1f} s; final reward "
            f"{result.rl_reward[algo][:, -1].mean():.2f}")
    if bar is not None:
        bar.close()
    result.wall_time_s = {k: round(v, 2) for k, v in times.items()}
    return result


_LABELS = {"learner": "Learner (paper, Alg. 1)", "ppo": "MaskablePPO", "dqn": "MaskedDQN"}


def plot(result: SampleEfficiencyResult, path: str | Path) -> Path:
    """Draw reward against episodes of interaction (log scale) and save it to ``path``.

    The figure is made without pyplot, so no display and no backend choice are needed.
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    from hri_bench.core.plots import agent_style  # matplotlib, as above

    cfg = result.config
    fig = Figure(figsize=(7.2, 4.2))
    ax = fig.subplots()
    color, dashes = agent_style("learner")  # each agent's colour and line in every figure
    x = result.learner_episodes
    ax.fill_between(x, result.learner_q25, result.learner_q75, color=color, alpha=0.18, lw=0)
    ax.plot(x, result.learner_reward, marker="o", ls=dashes, ms=3, color=color,
            label=_LABELS["learner"], lw=1.8)
    refs = result.references
    # Zoom on the range between the random policy and the Oracle; a half-trained greedy
    # policy can deadlock (the episode runs to the step limit), far below it.
    bottom = 1.6 * min(refs["random"], result.learner_reward.min(), -1.0)
    clipped_any = False
    for algo, reward in result.rl_reward.items():
        color, dashes = agent_style(algo)
        xs, mean = result.rl_episodes[algo], reward.mean(0)
        ax.fill_between(xs, reward.min(0), reward.max(0), color=color, alpha=0.15, lw=0)
        ax.plot(xs, np.maximum(mean, bottom), marker="s", ls=dashes, ms=3, color=color, lw=1.8,
                label=f"{_LABELS[algo]} ({len(cfg.rl_seeds)} seeds, min-max)")
        low = mean < bottom
        if low.any():
            clipped_any = True
            ax.plot(xs[low], np.full(low.sum(), bottom), "v", ms=7, color=color, clip_on=False)
    for name, label in (("oracle", "Oracle (knows ι)"), ("passive", "Passive"),
                        ("random", "random valid action")):
        color, dashes = agent_style(name)
        ax.axhline(refs[name], color=color, ls=dashes, lw=1.5, label=label)
    level = refs["random"] + cfg.threshold * (refs["oracle"] - refs["random"])
    ax.axhline(level, color="#bbbbbb", ls="-", lw=1,
               label=f"{cfg.threshold:.0%} of the way from random to Oracle")
    ax.set_ylim(bottom, 0.25)
    if clipped_any:
        ax.text(0.01, 0.02, "▼ below the axis: the greedy policy deadlocks until the step limit",
                transform=ax.transAxes, fontsize=7.5, color="#444444")
    ax.set_xscale("log")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))  # 10, not 10¹
    ax.set_xlabel("episodes of interaction with the same human (log scale)")
    ax.set_ylabel("robot cooperation reward per episode")
    ax.set_title(f"{cfg.scenario}: sample efficiency against one scripted human")
    ax.spines[["top", "right"]].set_visible(False)
    # below the axes, where it hides no curve
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2,
              frameon=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    return path


#: Where ``main`` writes without ``--out`` (not the tracked docs/figures).
DEFAULT_OUT = Path("out/sample_efficiency")


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m hri_bench.report.sample_efficiency --out DIR``."""
    parser = argparse.ArgumentParser(
        prog="python -m hri_bench.report.sample_efficiency",
        description="Cooperation reward against episodes of interaction: Learner vs "
                    "MaskablePPO and MaskedDQN vs the Oracle.")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"output directory (default {DEFAULT_OUT}; the docs' figure: "
                             "--out docs/figures)")
    parser.add_argument("--scenario", choices=tuple(SCENARIOS), default="hanger")
    parser.add_argument("--preference", default=None, help="the scripted human's preference")
    parser.add_argument("--algorithms", default=",".join(RL_ALGORITHMS),
                        help="comma-separated subset of ppo,dqn (default both)")
    parser.add_argument("--seeds", type=int, default=3, help="training seeds per algorithm")
    parser.add_argument("--max-ppo-episodes", type=int, default=3200,
                        help="last MaskablePPO checkpoint, in training episodes")
    parser.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    args = parser.parse_args(argv)
    algos = tuple(a.strip() for a in args.algorithms.split(",") if a.strip())
    checkpoints = tuple(c for c in SampleEfficiencyConfig.ppo_checkpoints
                        if c < args.max_ppo_episodes) + (args.max_ppo_episodes,)
    try:
        cfg = SampleEfficiencyConfig(args.scenario, preference=args.preference,
                                     algorithms=algos, rl_seeds=tuple(range(args.seeds)),
                                     ppo_checkpoints=checkpoints, seed=args.seed)
    except ValueError as exc:
        parser.error(str(exc))
    result = run_sample_efficiency(cfg, verbose=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    png = plot(result, out / "sample_efficiency.png")
    summary = result.to_dict()
    (out / "sample_efficiency.json").write_text(json.dumps(summary, indent=1) + "\n")
    def count(n: float | None) -> str:
        return "never" if n is None else f"{n:.0f}"

    print(f"episodes to reach {cfg.threshold:.0%} of the Oracle (random = 0, Oracle = 1), and "
          f"to reach r0 = {cfg.waiting_reward} per episode (the best without seeing ι):")
    for name, n in summary["episodes_to_90pct_oracle"].items():
        to_r0 = count(summary["episodes_to_r0_per_episode"][name])
        final, from_passive = (summary[k][name] for k in ("final_score",
                                                           "final_score_from_passive"))
        print(f"  {name:8s} {count(n):>6s}  {to_r0:>6s}   (last point: {final:.0%}; "
              f"Passive = 0: {from_passive:.0%})")
    print(f"wrote {png} and {out / 'sample_efficiency.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
