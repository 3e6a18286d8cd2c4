"""The benchmark's floor: what every other part of :mod:`hri_bench` may use.

==============  ====================================================================
module          contents
==============  ====================================================================
``atomic``      files written whole or not at all
``imports``     ``module:Class`` specs imported with errors that say what is allowed
``stats``       bootstrap CIs, IQM, the power analysis
``results``     :class:`~hri_bench.core.results.StudyResult`, a study's arrays
``plots``       the figures' style and a study's plots (matplotlib)
``pictures``    the task's picture as a PNG, for the web page
==============  ====================================================================

It imports nothing else of :mod:`hri_bench` (``lint-imports``).
"""
