"""Regenerate the README's physical suite table from a physical suite's ``results.json``.

    .venv/bin/hri-bench suite --physical --out out/physical --jobs 2
    .venv/bin/python benchmarks/physical_readme_table.py out/physical

replaces what stands between ``<!-- physical-suite:begin -->`` and
``<!-- physical-suite:end -->`` in README.md (``--readme``) with the suite's headline table
(:func:`hri_bench.suite.physical_board.headline_table`, the top of its ``leaderboard.md``)
and a line saying where it came from: from its ``suite_log.json``, the units' CPU time and
the last command's wall time, jobs and load. ``--check`` exits 1 when the README's table
differs (nothing written).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from hri_bench.suite.physical_audit import validate_physical
from hri_bench.suite.physical_board import headline_table

BEGIN, END = "<!-- physical-suite:begin -->", "<!-- physical-suite:end -->"


def table(folder: Path) -> str:
    """The README's block for the suite in ``folder`` (valid results only)."""
    doc = json.loads((folder / "results.json").read_text())
    problems = validate_physical(doc)
    if problems:
        raise SystemExit(f"{folder / 'results.json'} is not valid: {problems[0]}")
    log = json.loads((folder / "suite_log.json").read_text())
    load = ", ".join(f"{x:.1f}" for x in log["load_average"])
    cpu = float(log.get("cpu_time_s", 0.0))
    source = (f"Physical suite v{doc['suite_version']} (hash `{doc['suite_hash'][:12]}`), "
              f"seed {', '.join(map(str, doc['seeds']))}, runs scale {doc['runs_scale']}: "
              f"{cpu / 60:.0f} core-minutes of simulation in its units (about "
              f"{cpu / 120:.0f} min with --jobs 2 on an idle 2-core machine); the last "
              f"command on its folder took {log['wall_time_s'] / 60:.1f} min with --jobs "
              f"{log['jobs']} (machine load at its end: {load} over 1, 5, 15 min).")
    return f"{BEGIN}\n{headline_table(doc)}\n\n{source}\n{END}"


def main() -> int:
    """Replace (or ``--check``) the README's table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("suite", type=Path, help="the physical suite's --out folder")
    p.add_argument("--readme", type=Path, default=Path("README.md"),
                   help="the page whose table to replace (default README.md)")
    p.add_argument("--check", action="store_true", help="exit 1 if the table differs")
    args = p.parse_args()
    text = args.readme.read_text()
    if BEGIN not in text or END not in text:
        print(f"{args.readme} has no {BEGIN} ... {END} block", file=sys.stderr)
        return 1
    head, rest = text.split(BEGIN, 1)
    tail = rest.split(END, 1)[1]
    new = head + table(args.suite) + tail
    if args.check:
        return 0 if new == text else 1
    args.readme.write_text(new)
    print(f"wrote the physical suite's table into {args.readme}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
