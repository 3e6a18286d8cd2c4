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
``_jit``           the compiled kernels (numba), one file: numba's cache follows the
                   file of a kernel only, so a kernel calling one of another file would
                   keep its cached old code after an edit there
=================  ==============================================================
"""
