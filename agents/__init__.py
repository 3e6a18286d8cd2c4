"""Robot policies: the agent protocol, the paper's Learner (Algorithm 1) and its math.

- :mod:`agents.protocol`: the protocol every policy implements (:class:`Agent`,
  :class:`BatchAgent`); :mod:`agents.rollout`: :func:`~agents.rollout.run_episode`, any
  protocol agent in a robot env.
- :mod:`agents.learner`: the Learner.
- :mod:`agents.learning`: its math: the update as Algorithm 1 (``algorithm1``), the bounded
  soft-max, Bayes filter and ME-IRL as batched functions (``mdp``) and their sparse, compiled
  forms (``partner_mdp``).
- :mod:`agents.config`: validated parameters with the paper's defaults.
- :mod:`agents.sb3`: a trained stable-baselines3 / sb3-contrib model as a protocol agent;
  :mod:`agents.rl`: training helpers (MaskablePPO, masked DQN, vector envs for SB3). Both
  need the ``rl`` extra and are not imported here.
"""

from agents.config import LearnerConfig, default_config
from agents.learner import Learner, LearnerStateError
from agents.protocol import Agent, BatchAgent, Batched, Trace

__all__ = [
    "Agent",
    "BatchAgent",
    "Batched",
    "Learner",
    "LearnerConfig",
    "LearnerStateError",
    "Trace",
    "default_config",
]
