"""The learners' math: the dense reference functions, the sparse and compiled forms, and the
Learner's update (Algorithm 1).

=================  ==============================================================
module             contents
=================  ==============================================================
``algorithm1``     the Learner's update as the paper writes it, its compiled dispatch, the
                   explicit :class:`~agents.learning.algorithm1.Workspace`
``mdp``            bounded soft-max, Bayes filter, loop removal, ME-IRL (dense numpy)
``partner_mdp``    the same on the sparse joint table, with compiled kernels
``_jit``           the compiled kernels (numba)
=================  ==============================================================
"""
