"""The learners' math: the dense reference functions, the sparse and compiled forms, and the
Learner's update (Algorithm 1).

=================  ==============================================================
module             contents
=================  ==============================================================
``algorithm1``     the Learner's update as the paper writes it, its compiled dispatch
``learner_data``   the update's tables, parameters, models and the explicit
                   :class:`~agents.learning.algorithm1.Workspace` (re-exported by
                   ``algorithm1``)
``mdp``            bounded soft-max, Bayes filter, loop removal, ME-IRL (dense numpy)
``partner_mdp``    the same on the sparse joint table, with compiled kernels
``compiled``       whether the kernels are on, their threads, the checks of their inputs
``_jit``           the compiled kernels (numba); Algorithm 1's steps in ``_jit_learner``,
                   the loop they all run in ``_jit_mdps``
=================  ==============================================================
"""
