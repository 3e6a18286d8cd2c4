"""A step table with a deterministic human folded in: one look-up per output and step.

:class:`~hri_envs.task.episode.StepTable` answers a joint step from the context and both
agents' actions. When the human is a fixed function of (start, ι, state) (a scripted human
that neither samples nor waits at random), the human's action is itself a look-up, and the
two look-ups fuse: :class:`GreedyStepTable` is indexed by the context, ι and the robot's
action only, and also says which action the human took. Every entry is copied from the
:class:`~hri_envs.task.episode.StepTable` (no rule is restated here); the batched robot env
(:class:`~hri_envs.envs.vector.RobotVectorEnv`) steps with it.
"""

from __future__ import annotations

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import IntArray, StepTable

__all__ = ["GreedyStepTable"]


class GreedyStepTable:
    """:class:`~hri_envs.task.episode.StepTable` with the human's action given by a table.

    The flat index of a step is ``j = c K A + ι A + a_R``: ``c`` is the step table's
    context ``(start 2 + lifted) S + s`` (``lifted`` before the step), ``ι`` the human's
    current goal, ``a_R`` the robot's action. Every table below holds, at ``j``, what the
    step table holds at ``c A A + a_R A + a_H`` with ``a_H = human[start, ι, s]``, except
    that a step which ends the episode leads to the ended-episode context :attr:`over`
    (``c = 2 K S``), where the step table's neutral values are kept and the human waits.

    Args:
        steps: The step table of the scenario's rules.
        human: (K, K, S) int, the human's action ``human[start, ι, s]``; only valid
            actions (:attr:`hri_envs.task.graph.TaskGraph.valid`) are used by the envs, but
            any action in ``0 .. A - 1`` is looked up correctly.

    Attributes:
        stride: K A, the step of the context in the flat index.
        goal_stride: A, the step of ι in the flat index.
        over: ``c K A`` of the ended-episode context.
        key0: (K,) int64, ``c K A`` of each support's start context (resting, not lifted).
        state0: (K,) int64, the start state of each support (the step table's).
        human_action: (C K A,) int64 with C = 2 K S + 1, the human's action in the step.
        next_key: (C K A,) int64, ``c' K A`` of the context after the step (:attr:`over`
            after a step that ends the episode).
        next_state, reward, aborted, robot_invalid, terminated: (C K A,), as the step
            table's entries of the same name.
    """

    def __init__(self, steps: StepTable, human: np.ndarray) -> None:
        rules = steps.rules
        n_s, n_a, n_k = rules.n_states, rules.n_actions, rules.n_supports
        human = np.asarray(human)
        if human.shape != (n_k, n_k, n_s) or human.dtype.kind not in "iu":
            raise ConfigError(f"the human's action table must be integers of shape "
                              f"{(n_k, n_k, n_s)} (start, goal, state), got {human.dtype} "
                              f"{human.shape}", field="human")
        if human.size and (human.min() < 0 or human.max() >= n_a):
            raise ConfigError(f"the human's actions must lie in 0..{n_a - 1}", field="human")
        self.steps = steps
        self.stride = n_k * n_a
        self.goal_stride = n_a
        n_c = 2 * n_k * n_s  # contexts of running episodes; the next one is "over"
        self.over = n_c * self.stride
        c = np.arange(n_c)
        start, s = c // (2 * n_s), c % n_s
        a_h = np.full((n_c + 1, n_k), WAIT, dtype=np.int64)  # (C, K)
        a_h[:n_c] = human[start[:, None], np.arange(n_k)[None, :], s[:, None]]
        # The step table's index of every (c, ι, a_R), in the order of this table's index.
        base = np.arange(n_c + 1)[:, None, None] * steps.stride  # (C, 1, 1)
        j = (base + np.arange(n_a)[None, None, :] * n_a + a_h[:, :, None]).reshape(-1)

        def pick(table: np.ndarray) -> np.ndarray:
            out: np.ndarray = table.take(j)
            out.setflags(write=False)
            return out

        self.human_action = np.repeat(a_h.reshape(-1), n_a)
        self.human_action.setflags(write=False)
        self.next_key = np.where(steps.terminated.take(j), self.over,
                                 steps.next_key.take(j) // steps.stride * self.stride)
        self.next_key.setflags(write=False)
        self.next_state = pick(steps.next_state)
        self.reward = pick(steps.reward)
        self.aborted = pick(steps.aborted)
        self.robot_invalid = pick(steps.robot_invalid)
        self.terminated = pick(steps.terminated)
        self.state0 = steps.state0
        self.key0 = steps.key0 // steps.stride * self.stride
        self.key0.setflags(write=False)

    def key(self, state: IntArray, start: IntArray, lifted: np.ndarray | bool) -> np.ndarray:
        """``c K A``: the flat index of the context ``(state, start, lifted)``, arrays broadcast."""
        return self.steps.key(state, start, lifted) // self.steps.stride * self.stride
