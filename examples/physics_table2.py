"""The user study's episodes (paper Table 2) on the simulated Panda: Learner vs baselines.

    python examples/physics_table2.py [--runs 3] [--out out/physics_table2] [--physics JSON]

Runs the Learner, the Passive agent and the Imitator on the hanger's Table 2 schedule with
the physics backend (MuJoCo, mink IK, compliant control; the robot only sees the human
actions it infers), prints reward and correct/passive/wrong per agent, and plots the linear
interaction impulse per episode like the paper's Fig. 6 (``impulse.png``) and the mean
reward per episode (``reward.png``). Numbers go to ``summary.json``.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro
from tqdm.auto import tqdm

from hri_bench.run.agents import make_agent
from hri_bench.run.runner import make_schedule, simulate
from hri_envs.envs.config import check_physics_options, scenario_graph
from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios.hanger import TABLE2


@dataclass
class Config:
    runs: int = 3
    """independent runs per agent (each learns from scratch)"""
    agents: str = "learner,passive,imitator"
    """comma-separated agents"""
    episodes: int = 9
    """episodes of Table 2 to run (all nine by default)"""
    seed: int = 0
    """base seed (run r depends on (seed, r) only)"""
    out: str = "out/physics_table2"
    """output directory"""
    physics: str = ""
    """physics options as a JSON object, e.g. '{"attempt_invalid": true}' (docs/physics.md)"""


def main() -> None:
    cfg = tyro.cli(Config, description=__doc__.splitlines()[0])
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    physics = check_physics_options(json.loads(cfg.physics) if cfg.physics else None, "mujoco")
    graph = scenario_graph("hanger")
    human = preference_human(graph)
    runs = list(range(cfg.runs))
    schedule = make_schedule(graph, "table2", runs, cfg.episodes, cfg.seed)
    results: dict[str, dict[str, list[float]]] = {}
    agents = cfg.agents.split(",")
    bar = tqdm(total=len(agents) * cfg.episodes, unit="episode", desc="physics, Table 2")
    for name in agents:
        t0 = time.perf_counter()
        agent = make_agent(name, graph, human, runs, seed=cfg.seed, r0=-0.33)
        bar.set_postfix_str(name)
        m = simulate(graph, agent, human, schedule, runs=runs, seed=cfg.seed, r0=-0.33,
                     max_steps=40, backend="mujoco", physics=physics,
                     after_episode=lambda e, a: bar.update(1))
        results[name] = {
            "reward": m.reward.mean(0).tolist(),
            "correct": m.correct.mean(0).tolist(),
            "passive": m.passive.mean(0).tolist(),
            "wrong": m.wrong.mean(0).tolist(),
            "linear_impulse": m.extras["linear_impulse"].mean(0).tolist(),
            "angular_impulse": m.extras["angular_impulse"].mean(0).tolist(),
            "duration_s": m.extras["duration_s"].mean(0).tolist(),
            "graph_agrees": m.extras["graph_agrees"].mean(0).tolist(),
            "inference_accuracy": m.extras["inference_accuracy"].mean(0).tolist(),
            "hold_accuracy": m.extras["hold_accuracy"].mean(0).tolist(),
            "physical_fault": m.extras["physical_fault"].mean(0).tolist(),
            "truncated": m.truncated.mean(0).tolist(),
            "wall_s": [time.perf_counter() - t0],
        }
        r = results[name]
        tqdm.write(f"{name:9s} reward/episode {np.mean(r['reward']):6.2f}  correct "
                   f"{np.mean(r['correct']):.2f} passive {np.mean(r['passive']):.2f} wrong "
                   f"{np.mean(r['wrong']):.2f}  linear impulse/episode "
                   f"{np.mean(r['linear_impulse']):6.1f} N s  graph agrees "
                   f"{np.mean(r['graph_agrees']):.3f}  inferred right "
                   f"{np.mean(r['inference_accuracy']):.3f}  hold sensed right "
                   f"{np.mean(r['hold_accuracy']):.3f}  physical faults/episode "
                   f"{np.mean(r['physical_fault']):.2f}  ({r['wall_s'][0]:.0f} s)")
    bar.close()
    (out / "summary.json").write_text(json.dumps(results, indent=1) + "\n")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from hri_bench.core.plots import agent_style  # each agent's colour in every figure
    except ImportError:
        print("matplotlib is not installed: no plots (pip install 'hri-envs[bench]')")
        return
    labels = [f"{i + 1}\n{s}{'(' + g + ')' if t else ''}{g if not t else s}"
              for i, (s, g, t) in enumerate(TABLE2[: cfg.episodes])]
    x = np.arange(cfg.episodes)
    for key, ylabel, fname in (("linear_impulse", "linear impulse [N s]", "impulse.png"),
                               ("reward", "robot cooperation reward", "reward.png")):
        fig, ax = plt.subplots(figsize=(7, 3.2))
        width = 0.8 / len(results)
        for j, (name, r) in enumerate(results.items()):
            ax.bar(x + (j - (len(results) - 1) / 2) * width, r[key], width, label=name,
                   color=agent_style(name)[0])
        ax.set_xticks(x, labels, fontsize=7)
        ax.set_xlabel("episode (paper Table 2)")
        ax.set_ylabel(ylabel)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / fname, dpi=120)
        plt.close(fig)
    print(f"wrote {out / 'impulse.png'}, {out / 'reward.png'}, {out / 'summary.json'}")


if __name__ == "__main__":
    main()
