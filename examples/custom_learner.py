"""Plug your own learner into the envs and into ``hri-bench``.

A robot policy implements the four calls of ``agents.protocol.Agent``: ``begin_episode``,
``act``, ``observe`` and ``end_episode`` (where it learns, with the human's intention revealed
in hindsight). ``GoalMemory`` below is a small learner in that shape:

- after each episode it remembers the human's action in every state, keyed by the start
  support and the goal the episode revealed;
- during an episode it keeps the goals whose remembered actions agree with what the human
  did so far, and acts when all of them agree on the human's next action; otherwise it
  behaves like the paper's Passive baseline (grasp at the start, let go at a goal, wait).

It runs in a Gymnasium env with ``agents.rollout.run_episode`` and in the benchmark
next to the paper's Learner::

    python examples/custom_learner.py
    PYTHONPATH=examples hri-bench study hanger \\
        --agents learner,custom_learner:GoalMemory,passive,oracle --out out/custom
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import gymnasium as gym
import numpy as np
import tyro

import hri_envs  # noqa: F401  (registers the Gymnasium ids)
from agents.protocol import Agent, Trace
from agents.rollout import run_episode
from hri_bench.run.study import StudyConfig, run_study
from hri_envs.task import mdp
from hri_envs.task.graph import WAIT, TaskGraph
from hri_envs.task.scenarios import scenario_spec


class GoalMemory(Agent):
    """Remembers the human's actions per (start, goal, state); infers the goal by elimination."""

    name = "goal-memory"

    def __init__(self, graph: TaskGraph) -> None:
        self.graph = graph
        self.memory: dict[tuple[int, int, int], int] = {}  # (start, goal, state) -> action
        self.start = 0
        self.lifted = False
        self.goals: set[int] = set()

    def begin_episode(self, start: int) -> None:
        self.start, self.lifted = start, False
        self.goals = set(range(self.graph.n_intentions)) - {start}

    def _passive(self, state: int) -> int:
        actions = mdp.passive_actions(self.graph, np.array(self.start), np.array(self.lifted))
        return int(actions[state])

    def act(self, observation: Mapping[str, Any]) -> int:
        s, mask = int(observation["state"]), observation["action_mask"]
        predicted = {self.memory.get((self.start, g, s)) for g in self.goals}
        if len(predicted) == 1:
            a = predicted.pop()
            if a is not None and a != WAIT and mask[a]:
                return a
        return self._passive(s)

    def observe(self, state: int, robot_action: int, human_action: int, next_state: int) -> None:
        self.lifted |= bool(self.graph.support[next_state] != self.start)
        if human_action == WAIT:
            return
        agree = {g for g in self.goals
                 if self.memory.get((self.start, g, state), human_action) == human_action}
        self.goals = agree or set(range(self.graph.n_intentions)) - {self.start}

    def end_episode(self, trace: Trace, intention: int) -> None:
        start = int(self.graph.support[trace.start_state])
        for s, a in zip(trace.states[:-1], trace.human_actions, strict=True):
            if a != WAIT:
                self.memory[(start, intention, int(s))] = int(a)


@dataclass
class Config:
    scenario: Literal["hanger", "wheel"] = "hanger"
    """the task"""
    runs: int = 20
    """benchmark runs per agent"""
    episodes: int = 8
    """episodes per run"""
    seed: int = 0
    """base seed"""


def main(argv: list[str] | None = None) -> dict[str, list[float]]:
    cfg = tyro.cli(Config, args=argv, description=__doc__.splitlines()[0])

    # 1. In a Gymnasium env, one episode at a time.
    env_id = scenario_spec(cfg.scenario).gym_id
    env = gym.make(env_id)
    robot = GoalMemory(env.unwrapped.graph)  # type: ignore[attr-defined]
    rewards = [run_episode(env, robot, seed=cfg.seed + e).reward for e in range(5)]
    print("GoalMemory in " + env_id + ", reward per episode: "
          + " ".join(f"{r:.2f}" for r in rewards))

    # 2. In the benchmark, next to the paper's Learner (same seeds for every agent).
    sys.path.insert(0, str(Path(__file__).resolve().parent))  # so "custom_learner" imports
    agents = ("learner", "custom_learner:GoalMemory", "passive", "oracle")
    study = run_study(StudyConfig(cfg.scenario, agents=agents, runs=cfg.runs,
                                  episodes=cfg.episodes, seed=cfg.seed))
    curves = {}
    print(f"{cfg.scenario}: mean reward per episode over {cfg.runs} runs")
    for name, metrics in study.metrics.items():
        curves[name] = metrics["reward"].mean(0).tolist()
        print(f"  {name:28s} " + " ".join(f"{r:6.2f}" for r in curves[name]))
    return curves


if __name__ == "__main__":
    main()
