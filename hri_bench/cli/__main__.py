"""``python -m hri_bench.cli``: the ``hri-bench`` command."""

import sys

from hri_bench.cli.commands import main

sys.exit(main())
