"""``hri-bench play``: you are the human; the Learner is the robot and learns across episodes.

Each step shows the state, the robot's belief over your intention and the action it chose,
and lists your valid actions numbered from 1, as the browser page of ``hri-bench serve``
numbers its keys; you type a number (or ``q`` to stop). The numbers count the valid actions
of the state, they are not the task's action indices (docs/agents.md, "Action numbers").
The robot learns from each finished episode, as in the paper's simulator with a user
interface. The episodes run in the benchmark's own loop
(:func:`hri_bench.run.runner.run_episodes`), with you as its human.

The robot is the Learner with one change: it never makes a grasp toggle the object's next
motion does not need (:func:`hri_envs.task.episode.unneeded_toggle`: letting go on the
start support before the object was lifted, grasping on the goal), and waits instead. The
paper's reward makes a toggle free (docs/task-model.md, "Reward"), so while you wait the
Learner would grasp and let go over and over: a wait on the start support reads, under its
model of you, as "the object is where I want it", and even when it believes otherwise,
letting go costs it nothing where waiting for you costs r0. A person waits to watch what
the robot does; the robot now takes hold once and waits for you.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from agents.config import default_config
from agents.learner import Learner
from hri_bench.run.runner import Schedule, run_episodes
from hri_envs.envs.backends import GraphBatch
from hri_envs.humans.protocol import BatchHuman
from hri_envs.task import episode as rules
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["play"]


class _Quit(Exception):
    """The player typed q."""


class _PlayLearner(Learner):
    """The Learner, waiting where it would make a grasp toggle that the object's next motion
    does not need (the module's docstring says why).
    """

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The Learner's actions, its unneeded toggles replaced by waiting."""
        actions = super().act(observations, active)
        states = np.asarray(observations["state"], dtype=np.int64).reshape(self.n_runs)
        pointless = rules.unneeded_toggle(self.graph, states, actions, self.start, self.lifted)
        return np.where(pointless, WAIT, actions)


class _TerminalHuman(BatchHuman):
    """A person at a terminal in the human's seat: shows the step, reads the action."""

    name = "person"

    def __init__(self, graph: TaskGraph, robot: Learner, read: Callable[[str], str],
                 write: Callable[[str], None]) -> None:
        super().__init__(graph, 1)
        self.robot, self.read, self.write = robot, read, write
        self._last: tuple[int, int, int] | None = None

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """Show the state, the robot's belief and choice, and read the person's action."""
        g = self.graph
        s, a_r = int(observations["state"][0]), int(observations["robot_action"][0])
        self.note_aborted()
        names = g.support_names
        belief = ", ".join(f"{n} {b:.0%}" for n, b in zip(names, self.robot.belief()[0],
                                                          strict=True))
        self.write(f"\nState: {g.state_names[s]}\nRobot belief: {belief}; "
                   f"robot chooses: {g.agent_action_label(s, a_r, robot=True)}")
        options = np.flatnonzero(g.valid[s])
        for i, a in enumerate(options, start=1):  # from 1, as the page's keys
            self.write(f"  [{i}] {g.agent_action_label(s, int(a), robot=False)}")
        while True:
            try:
                answer = self.read("your action> ").strip().lower()
            except EOFError:  # end of input (Ctrl-D, a closed pipe): stop like 'q'
                self.write("")
                raise _Quit from None
            if answer in ("q", "quit"):
                raise _Quit
            if answer.isdigit() and 1 <= int(answer) <= len(options):
                a_h = int(options[int(answer) - 1])
                break
            self.write(f"Type a number from 1 to {len(options)}, or q.")
        self._last = (s, a_r, a_h)
        return np.array([a_h])

    def note_aborted(self) -> None:
        """Say so if the previous joint action was aborted (nothing moved)."""
        if self._last is not None and self.graph.aborted[self._last]:
            self.write("(The joint action was aborted: nothing moved.)")
        self._last = None


def play(
    graph: TaskGraph,
    *,
    episodes: int = 3,
    seed: int = 0,
    max_steps: int = 40,
    read: Callable[[str], str] = input,
    write: Callable[[str], None] = print,
) -> list[float]:
    """Play episodes as the human against the Learner; returns the robot reward per episode.

    Args:
        graph: The scenario's task graph.
        episodes: Number of episodes (a random start support each).
        seed: Seed of the starts and of the robot.
        max_steps: Step limit per episode.
        read: Prompt function (``input`` by default; tests pass their own). End of input
            (``EOFError``) ends the game like typing ``q``.
        write: Output function.
    """
    cfg = default_config(spec_of(graph))
    robot = _PlayLearner(graph, 1, cfg, seed=seed)
    human = _TerminalHuman(graph, robot, read, write)
    names = graph.support_names
    rng = np.random.default_rng(seed)
    starts = np.array([[int(rng.integers(graph.n_intentions)) for _ in range(episodes)]])
    # Your goal is yours alone: the loop's intention is only a placeholder (no turning back).
    schedule = Schedule(starts, (starts + 1) % graph.n_intentions, np.zeros_like(starts, bool))
    write(f"You carry the {graph.scenario.object_name} with the robot. Supports: "
          f"{', '.join(names)}. Choose your actions by number; 'q' quits.")
    write(f"\n=== Episode 1: the object rests on {names[starts[0, 0]]}. "
          "Bring it to another support (or back, after lifting it).")
    totals: list[float] = []
    loop = run_episodes(graph, robot, human, schedule, GraphBatch(graph, [0], seed),
                        r0=cfg.r0, max_steps=max_steps)
    try:
        for result in loop:
            human.note_aborted()
            end = int(result.traces[0].states[-1])
            total = float(result.metrics.reward[0])
            write(f"Episode over at {graph.state_names[end]}; robot reward {total:.2f}. "
                  "The robot learns from it.")
            totals.append(total)
            if result.episode + 1 < episodes:
                write(f"\n=== Episode {result.episode + 2}: the object rests on "
                      f"{names[starts[0, result.episode + 1]]}. "
                      "Bring it to another support (or back, after lifting it).")
    except _Quit:
        pass
    return totals
