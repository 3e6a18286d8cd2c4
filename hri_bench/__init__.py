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

from hri_envs.moved import register as _register_moved

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
