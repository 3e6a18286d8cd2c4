"""``hri-bench``, the command line (``hri_bench.cli:main`` is the console script).

==============  ====================================================================
module          contents
==============  ====================================================================
``commands``    the parser, :func:`main`, and the study, figures, speed, suite, play
                and demo commands
``people``      ``serve``, ``dataset``, ``replay`` (people in the loop)
``results``     ``validate``, ``leaderboard`` and the suite's ``--config``, ``--seeds``
``__main__``    ``python -m hri_bench.cli``
==============  ====================================================================
"""

from hri_bench.cli.commands import build_parser, main

__all__ = ["build_parser", "main"]
