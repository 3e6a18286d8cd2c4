"""A user-written agent, imported by path in the benchmark tests (``module:Class``)."""

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
