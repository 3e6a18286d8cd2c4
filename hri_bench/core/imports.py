"""``module:Class`` names on the command line (agents and humans of your own): the project's
one importer, :mod:`hri_envs.imports` (humans are described below the benchmark, in
:class:`hri_envs.humans.spec.HumanSpec`, which imports them too).
"""

from hri_envs.imports import import_class, import_object

__all__ = ["import_class", "import_object"]
