"""Running studies: the agents, the humans, the one simulation loop, a study and its files.

==================  ====================================================================
module              contents
==================  ====================================================================
``agents``          the robot agents by name, and an agent's code identity
``builtin_agents``  the built-in agents' specs (registered when it is imported)
``provenance``      package versions, the suite's and tracks' hashes, code changes
``humans``          a human class of the user's (``--population module:Class``)
``regret``          the references (``blind``, ``informed``, ``qmdp``) and regret
``runner``          the one simulation loop (:func:`~hri_bench.run.runner.run_episodes`)
``study``           a study: configuration, execution (serial, processes, Ray), summary
``studyio``         a study's folder: resume, locks, signals, outputs
``metrics``         the task's metrics per agent
==================  ====================================================================

It imports only :mod:`hri_bench.data` and :mod:`hri_bench.core` of :mod:`hri_bench`
(``lint-imports``).
"""
