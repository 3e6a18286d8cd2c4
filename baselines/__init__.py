"""The paper's baselines (Sect. 4.6) and the Oracle upper bound, as batched agents."""

from baselines.maxent import MaxEntIRL
from baselines.simple import Imitator, Oracle, Passive

__all__ = ["Imitator", "MaxEntIRL", "Oracle", "Passive"]
