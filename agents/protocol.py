"""The agent protocol; it lives in :mod:`hri_envs.task.protocol`, below the envs that drive it.

Kept here so that ``from agents.protocol import Agent`` goes on working.
"""

from hri_envs.task.protocol import Agent, BatchAgent, Batched, Trace, run_streams

__all__ = ["Agent", "BatchAgent", "Batched", "Trace", "run_streams"]
