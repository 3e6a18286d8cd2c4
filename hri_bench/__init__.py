"""The benchmark: batched simulation of the paper's studies, metrics, plots and the CLI.

Its sub-packages import one way, each only those below it (``lint-imports``)::

    cli                 the hri-bench command line
    suite | people      the versioned suite and results files | people in the loop
    report              aggregates, rankings, the paper's figures, speed
    run                 agents, humans, the simulation loop, a study and its files
    data                recorded datasets, fitted humans, replay
    core                statistics, plots, atomic files, importing module:Class

The modules' former names (``hri_bench.study``, ...) still import, with a
``DeprecationWarning``, until the next release (:data:`MOVED`; CHANGELOG.md, "Deprecated").
"""

import importlib.util as _util
from pathlib import Path as _Path

from hri_envs.moved import register as _register_moved


def _check_own_packages() -> None:
    """Refuse to start when another package named ``agents`` or ``baselines`` (OpenAI's
    ``baselines`` has the same name) shadows this project's: both are installed as top-level
    packages beside ``hri_bench`` (README, "Two top-level names").

    Raises:
        ImportError: Naming the package found, where, and what to do.
    """
    here = _Path(__file__).resolve().parent.parent
    for name in ("agents", "baselines"):
        spec = _util.find_spec(name)
        origin = None if spec is None or spec.origin is None else _Path(spec.origin).resolve()
        if origin is not None and origin.parent.parent != here:
            raise ImportError(
                f"the package {name!r} found at {origin.parent} is not hri-envs' own "
                f"({here / name}): another package of that name (OpenAI's 'baselines' has "
                "one) shadows it; uninstall it from this environment, or give hri-envs a "
                "virtualenv of its own (README, \"Two top-level names\")", name=name)


_check_own_packages()

#: The former flat modules -> their modules now (a package's modules follow it).
MOVED: dict[str, str] = {
    **{f"hri_bench.{m}": f"hri_bench.core.{m}"
       for m in ("atomic", "imports", "stats", "results", "plots", "pictures")},
    **{f"hri_bench.{m}": f"hri_bench.data.{m}" for m in ("datasets", "fit", "replay")},
    **{f"hri_bench.{m}": f"hri_bench.run.{m}"
       for m in ("agents", "provenance", "humans", "regret", "runner", "study", "studyio",
                 "metrics")},
    **{f"hri_bench.{m}": f"hri_bench.report.{m}"
       for m in ("aggregate", "ranking", "figures", "sample_efficiency", "speed",
                 "jax_speed")},
    **{f"hri_bench.{m}": f"hri_bench.suite.{m}" for m in ("results_v3", "submission", "audit")},
    **{f"hri_bench.{m}": f"hri_bench.people.{m}" for m in ("recording", "play", "serve")},
    "hri_bench.cli_people": "hri_bench.cli.people",
    "hri_bench.cli_results": "hri_bench.cli.results",
}
_register_moved(MOVED)
