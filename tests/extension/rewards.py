"""A reward rule of a user's own, as docs/extending.md, "A reward rule", writes it."""

import numpy as np

from hri_envs.task.episode import RewardRule, register_reward_rule

COSTLY_WAIT = register_reward_rule(RewardRule(
    "costly-wait", "as 'paper', but a robot wait while the human acts costs twice r0 "
    "(at least -1)",
    lambda step: np.where(step.paper == step.r0, max(2 * step.r0, -1.0), step.paper)))
