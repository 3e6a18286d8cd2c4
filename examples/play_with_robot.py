"""Be the human: carry the object with the paper's Learner as your robot partner.

In a terminal you choose your action each step and watch the robot's belief about your goal
change; after each episode the robot learns your preferences. ``--auto`` lets a scripted
human play instead (a random goal per episode, moving by the scenario's default
preference), which is how the example runs unattended::

    python examples/play_with_robot.py            # you play (the same as `hri-bench play`)
    python examples/play_with_robot.py --auto     # a scripted human plays 4 episodes
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

import numpy as np
import tyro

from hri_bench.people.play import play
from hri_bench.run.study import graph_for
from hri_envs.humans.scripted import preference_human


@dataclass
class Config:
    scenario: Literal["hanger", "wheel"] = "hanger"
    """the task"""
    episodes: int = 4
    """episodes to play"""
    seed: int = 0
    """seed of the start supports, the robot and the scripted human's goals"""
    auto: bool = False
    """let a scripted human answer the prompts"""
    quiet: bool = False
    """with --auto: print only the result of each episode"""


class ScriptedPlayer:
    """Answers ``play``'s prompts like a scripted human.

    It reads what ``play`` prints (the episode's start support, the current state and the
    numbered list of the human's actions) and answers with the number of the action its
    preference takes towards a goal it drew for the episode.
    """

    def __init__(self, scenario: str, seed: int, quiet: bool) -> None:
        self.graph = graph_for(scenario)
        self.human = preference_human(self.graph)
        self.rng = np.random.default_rng(seed)
        self.quiet = quiet
        self.start = self.goal = self.state = 0

    def write(self, text: str) -> None:
        names = self.graph.support_names
        if m := re.search(r"=== Episode \d+: the object rests on (\w+)\.", text):
            self.start = names.index(m.group(1))
            others = [k for k in range(len(names)) if k != self.start]
            self.goal = int(self.rng.choice(others))
            text += f"\n(scripted human: my goal is {names[self.goal]})"
        if m := re.search(r"State: (.*)\n", text):
            self.state = self.graph.state_names.index(m.group(1))
        if not self.quiet or text.lstrip().startswith(("===", "Episode over")):
            print(text)

    def read(self, prompt: str) -> str:
        action = int(self.human.preferred_action(np.array([self.state]), np.array([self.start]),
                                                 np.array([self.goal]))[0])
        options = np.flatnonzero(self.graph.valid[self.state])
        answer = str(int(np.flatnonzero(options == action)[0]) + 1)  # play numbers from 1
        if not self.quiet:
            print(f"{prompt}{answer}")
        return answer


def main(argv: list[str] | None = None) -> list[float]:
    cfg = tyro.cli(Config, args=argv, description=__doc__.splitlines()[0])
    if cfg.auto:
        player = ScriptedPlayer(cfg.scenario, cfg.seed, cfg.quiet)
        rewards = play(player.graph, episodes=cfg.episodes, seed=cfg.seed,
                       read=player.read, write=player.write)
    else:
        rewards = play(graph_for(cfg.scenario), episodes=cfg.episodes, seed=cfg.seed)
    print("robot reward per episode: " + " ".join(f"{r:.2f}" for r in rewards))
    return rewards


if __name__ == "__main__":
    main()
