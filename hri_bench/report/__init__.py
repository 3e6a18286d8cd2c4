"""What is made from studies: aggregates, rankings, the paper's figures, speed figures.

=====================  ==============================================================
module                 contents
=====================  ==============================================================
``aggregate``          IQM and probability of improvement across tracks
``ranking``            suite v3's normalised scores and ranking
``figures``            the paper's figures (Figs. 4, 8, 10-12)
``sample_efficiency``  the RL learners' sample efficiency against the Learner
``speed``              env and Learner throughput (``hri-bench speed``)
``jax_speed``          the JAX env's and PPO trainer's figures
=====================  ==============================================================

It imports only :mod:`hri_bench.run`, :mod:`hri_bench.data` and :mod:`hri_bench.core` of
:mod:`hri_bench` (``lint-imports``).
"""
