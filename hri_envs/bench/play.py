"""``hri-bench play``: you are the human; the Learner is the robot and learns across episodes.

Each step shows the state, the robot's belief over your intention and the action it chose,
and lists your valid actions; you type a number (or ``q`` to stop). The robot learns from
each finished episode, as in the paper's simulator with a user interface.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from agents.config import default_config
from agents.learner import Learner
from hri_envs.bench.study import graph_for
from hri_envs.task.protocol import Trace

__all__ = ["play"]


def play(
    scenario: str,
    *,
    episodes: int = 3,
    seed: int = 0,
    max_steps: int = 40,
    read: Callable[[str], str] = input,
    write: Callable[[str], None] = print,
) -> list[float]:
    """Play episodes as the human against the Learner; returns the robot reward per episode.

    Args:
        scenario: "hanger" or "wheel".
        episodes: Number of episodes (a random start support each).
        seed: Seed of the starts and of the robot.
        max_steps: Step limit per episode.
        read: Prompt function (``input`` by default; tests pass their own).
        write: Output function.
    """
    graph = graph_for(scenario)
    cfg = default_config(scenario)
    robot = Learner(graph, 1, cfg, seed=seed)
    reward = graph.reward(cfg.r0)
    names = graph.support_names
    rng = np.random.default_rng(seed)
    totals: list[float] = []
    write(f"You carry the {graph.scenario.object_name} with the robot. Supports: "
          f"{', '.join(names)}. Choose your actions by number; 'q' quits.")
    for episode in range(episodes):
        start = int(rng.integers(graph.n_intentions))
        write(f"\n=== Episode {episode + 1}: the object rests on {names[start]}. "
              f"Bring it to another support (or back, after lifting it).")
        robot.begin_episode(np.array([start]))
        s, lifted, total = graph.support_state(start), False, 0.0
        states, r_actions, h_actions = [s], [], []
        for _ in range(max_steps):
            a_r = int(robot.act({"state": np.array([s])}, np.ones(1, bool))[0])
            belief = ", ".join(f"{n} {b:.0%}" for n, b in zip(names, robot.belief[0], strict=True))
            write(f"\nState: {graph.state_names[s]}\nRobot belief: {belief}; "
                  f"robot chooses: {graph.agent_action_label(s, a_r, robot=True)}")
            options = np.flatnonzero(graph.valid[s])
            for i, a in enumerate(options):
                write(f"  [{i}] {graph.agent_action_label(s, int(a), robot=False)}")
            while True:
                answer = read("your action> ").strip().lower()
                if answer in ("q", "quit"):
                    return totals
                if answer.isdigit() and int(answer) < len(options):
                    a_h = int(options[int(answer)])
                    break
                write(f"Type a number from 0 to {len(options) - 1}, or q.")
            s_next = int(graph.next_state[s, a_r, a_h])
            total += float(reward[s, a_r, a_h])
            if graph.aborted[s, a_r, a_h]:
                write("(The joint action was aborted: nothing moved.)")
            robot.observe(np.array([s]), np.array([a_r]), np.array([a_h]), np.array([s_next]),
                          np.ones(1, bool))
            states.append(s_next)
            r_actions.append(a_r)
            h_actions.append(a_h)
            s = s_next
            lifted |= bool(graph.left_start(s, start))
            if graph.episode_over(s, start, lifted):
                break
        at_rest = graph.support[s] >= 0 and graph.grasp[s] == 0
        ended = int(graph.support[s]) if at_rest else -1  # -1: cut off, nothing revealed
        write(f"Episode over at {graph.state_names[s]}; robot reward {total:.2f}. "
              "The robot learns from it.")
        trace = Trace(np.array(states), np.array(r_actions, dtype=np.int64),
                      np.array(h_actions, dtype=np.int64))
        robot.end_episode([trace], np.array([ended]))
        totals.append(total)
    return totals
