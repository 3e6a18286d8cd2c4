"""A user-written agent, imported by path in the benchmark tests (``module:Class``)."""

import numpy as np

from agents.protocol import Agent


class AlwaysWait(Agent):
    name = "always-wait"

    def begin_episode(self, start):
        pass

    def act(self, observation):
        return 0

    def observe(self, state, robot_action, human_action, next_state):
        pass

    def end_episode(self, trace, intention):
        pass


class RaisesInAct(AlwaysWait):
    """Fails on its first decision (the benchmark must report it and keep the others)."""

    name = "raises"

    def act(self, observation):
        raise RuntimeError("deliberate failure in act")


class OutOfRange(AlwaysWait):
    """Waits, then returns an action outside the action space on its third step."""

    name = "out-of-range"

    def begin_episode(self, start):
        self.t = 0

    def act(self, observation):
        self.t += 1
        return 99 if self.t == 3 else 0


class ExitsInAct(AlwaysWait):
    """Calls ``sys.exit(3)`` on its first decision (a failure of this agent, not the study's)."""

    name = "exits"

    def act(self, observation):
        import sys

        sys.exit(3)


class DividesByZero(AlwaysWait):
    """Raises ZeroDivisionError on its first decision."""

    name = "divides-by-zero"

    def act(self, observation):
        return 1 // 0


NotAnAgent = dict


class ReturnsHalf(AlwaysWait):
    """Returns 0.5: once silently played as 0 (the int64 array truncated it)."""

    name = "returns-half"
    value: object = 0.5

    def act(self, observation):
        return self.value


class ReturnsTrue(ReturnsHalf):
    name = "returns-true"
    value = True


class ReturnsText(ReturnsHalf):
    name = "returns-text"
    value = "3"


class RandomMover(AlwaysWait):
    """Draws every action from the per-run generator the benchmark hands it (the constructor
    contract: ``rng``), so its numbers depend on ``(seed, run)`` only.
    """

    name = "random-mover"

    def __init__(self, graph, rng, max_steps, r0, reward, episodes):
        self.graph, self.rng = graph, rng
        self.given = {"max_steps": max_steps, "r0": r0, "reward": reward, "episodes": episodes}

    def act(self, observation):
        valid = [a for a, ok in enumerate(observation["action_mask"]) if ok]
        return int(self.rng.choice(valid)) if self.rng.random() < 0.5 else 0


class TakesKeywords(AlwaysWait):
    """Takes every contract keyword through ``**kwargs``."""

    name = "takes-keywords"

    def __init__(self, **kwargs):
        self.kwargs = kwargs


class SecondMadeCrashes(Agent):
    """The Learner, except that the second instance made (the second session a server
    starts) raises in its second episode. Reset ``made`` before use."""

    name = "second-made-crashes"
    made = 0

    def __init__(self, graph):
        from agents import Learner

        type(self).made += 1
        self.crashes = type(self).made == 2
        self.inner = Learner(graph).single()
        self.episode = -1

    def begin_episode(self, start):
        self.episode += 1
        self.inner.begin_episode(start)

    def act(self, observation):
        if self.crashes and self.episode == 1:
            raise RuntimeError("deliberate crash of one session")
        return self.inner.act(observation)

    def observe(self, state, robot_action, human_action, next_state):
        self.inner.observe(state, robot_action, human_action, next_state)

    def end_episode(self, trace, intention):
        self.inner.end_episode(trace, intention)


class WaitsForGate(AlwaysWait):
    """Waits in ``act`` until the file named by ``$HRI_TEST_GATE`` exists (at most 120 s), so
    that a study is still running, deterministically, while a test does something beside it.
    While it waits, ``$HRI_TEST_GATE.waiting.PID`` names its process."""

    def act(self, observation):
        import os
        import time
        from pathlib import Path

        gate = Path(os.environ["HRI_TEST_GATE"])
        if not gate.exists():
            Path(f"{gate}.waiting.{os.getpid()}").touch()
        deadline = time.monotonic() + 120
        while not gate.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        return 0


class CountsStarts(AlwaysWait):
    """Exposes a belief: the share of earlier episodes that ended on each support (uniform
    before the first), so the benchmark scores it.
    """

    name = "counts-starts"

    def __init__(self, graph):
        self.counts = np.ones(graph.n_intentions)

    def end_episode(self, trace, intention):
        if intention >= 0:
            self.counts[intention] += 1

    def belief(self):
        return self.counts / self.counts.sum()
