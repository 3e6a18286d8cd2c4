"""Recorded sessions: datasets, human models fitted to them, and their replay.

==============  ====================================================================
module          contents
==============  ====================================================================
``datasets``    the multi-agent episode datasets (Parquet, Minari) and their writers
``checks``      every episode file checked on reading (schema, the scenario's graph)
``fit``         behaviour cloning and the Learner's IRL fit of recorded humans
``replay``      a recorded session re-played step by step in the env
==============  ====================================================================

It imports only :mod:`hri_bench.core` of :mod:`hri_bench` (``lint-imports``).
"""
