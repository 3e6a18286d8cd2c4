"""The paper's baselines (Sect. 4.6), the Oracle, the goal filter, the count-based QMDP
learner and the exact references, as batched agents (bounds.py and product.py:
``informed``, ``blind``, ``qmdp``).
"""

from baselines.countqmdp import CountQMDP
from baselines.goalfilter import GoalFilter
from baselines.maxent import MaxEntIRL
from baselines.simple import Imitator, Oracle, Passive

__all__ = ["CountQMDP", "GoalFilter", "Imitator", "MaxEntIRL", "Oracle", "Passive"]
