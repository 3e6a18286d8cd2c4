"""``hri-bench leaderboard``: validated results files merged into one leaderboard.

:func:`merged_leaderboard` validates every file (:func:`hri_bench.suite.submission.validate`),
keeps those of the first file's suite and runs scale whose runs do not contradict another
file's (:func:`hri_bench.suite.audit.conflicts`), merges them
(:func:`hri_bench.suite.submission.merge`) and writes ``leaderboard.md`` with the figure
(docs/results.md, "hri-bench leaderboard DIR").
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, NamedTuple

from hri_bench.core.atomic import atomic_writer
from hri_bench.suite import results_v3, results_v4
from hri_bench.suite.audit import conflicts
from hri_bench.suite.markdown import code, escape
from hri_bench.suite.physical_results import FORMAT as PHYSICAL_FORMAT
from hri_bench.suite.submission import (
    FORMAT,
    lead_section,
    load,
    merge,
    profile_figure,
    task_section,
    validate,
)
from hri_envs.errors import ConfigError

__all__ = ["HEADING", "Merged", "merged_leaderboard"]


class Merged(NamedTuple):
    """What :func:`merged_leaderboard` did."""

    #: The files written (``leaderboard.md`` and the figure); empty when none was valid.
    written: list[Path]
    #: One line per refused results file.
    refused: list[str]
    #: One line per file skipped as not a results file (``format`` not :data:`FORMAT`:
    #: a suite's ``suite.json`` and ``suite_log.json``, say).
    skipped: list[str]


#: The first line of every leaderboard :func:`merged_leaderboard` writes.
HEADING = "# hri-envs leaderboard (suite v"


def merged_leaderboard(files: Iterable[Path], out: Path) -> Merged:
    """Validate ``files``, merge the valid ones, write ``leaderboard.md`` and
    ``profiles.png`` (``ranking.png``, suite v3) into ``out``.

    A file that is JSON but not a results file (its ``format`` is not :data:`FORMAT`) is
    skipped, not refused: a suite's folder holds its ``suite.json`` beside ``results.json``.
    """
    refused, skipped, valid = [], [], {}
    physical: dict[str, Any] = {}
    for path in files:
        try:
            doc = load(path)
        except ConfigError as exc:
            refused.append(f"{path}: {exc}")
            continue
        kind = doc.get("format") if isinstance(doc, dict) else None
        if kind == PHYSICAL_FORMAT:
            physical[str(path)] = doc
            continue
        if kind != FORMAT:
            skipped.append(f"{path}: skipped: not a results file (its format is {kind!r}, "
                           f"not {FORMAT!r})")
            continue
        problems = validate(doc)
        if problems:
            refused.append(f"{path}: refused: " + "; ".join(problems[:5])
                           + (f" (and {len(problems) - 5} more)" if len(problems) > 5 else ""))
        else:
            valid[path.name] = doc
    if physical and not valid and not refused:
        return _physical(physical, out, skipped)
    skipped += [f"{p}: skipped: a physical suite's results (merge them in a folder of their "
                "own)" for p in physical]
    valid, apart = _mergeable(valid)
    refused += apart
    if not valid:
        return Merged([], refused, skipped)
    merged = merge(valid)
    out.mkdir(parents=True, exist_ok=True)
    subs = []
    for fname, doc in valid.items():
        sub = doc.get("submission") or {}
        who = ", ".join(escape(sub[k]) for k in ("name", "lab") if sub.get(k)) or "(unnamed)"
        subs.append(f"- {code(fname)}: {who}; agents {', '.join(code(a) for a in doc['agents'])};"
                    f" seeds {doc['seeds']}, runs scale {doc['runs_scale']}")
    version = next(iter(valid.values()))["suite"]["version"]
    v3 = merged["schema_version"] in (results_v3.SCHEMA_VERSION, results_v3.SCHEMA_V4)
    if merged["schema_version"] == results_v3.SCHEMA_V4:
        refs = [a for a, r in merged.get("roles", {}).items() if r["reference"]]
        sections = [results_v4.lead_section(merged), results_v3.failure_section(merged, refs)]
    elif v3:
        sections = [results_v3.lead_section(merged), results_v3.failure_section(merged)]
    else:
        sections = [lead_section(merged)]
    text = "\n".join([f"{HEADING}{version})",
                      "", "Merged from validated results files (`hri-bench validate`):", "",
                      *subs, "", *sections, task_section(merged)])
    with atomic_writer(out / "leaderboard.md") as f:
        f.write(text + "\n")
    for stale in ("ranking.png", "profiles.png"):  # another version's, from an earlier merge
        (out / stale).unlink(missing_ok=True)
    fig = (results_v3.ranking_figure(merged, out / "ranking.png") if v3
           else profile_figure(merged, out / "profiles.png"))
    return Merged([out / "leaderboard.md", fig], refused, skipped)


def _physical(docs: Mapping[str, Any], out: Path, skipped: list[str]) -> Merged:
    """A folder of physical results files: validated, merged
    (:func:`hri_bench.suite.physical_audit.merge_physical`), ``leaderboard.md`` and the
    figures written.
    """
    from hri_bench.suite.physical_audit import merge_physical, validate_physical  # noqa: PLC0415
    from hri_bench.suite.physical_board import leaderboard, write_figures  # noqa: PLC0415

    refused, valid = [], {}
    for path, doc in docs.items():
        problems = validate_physical(doc)
        if problems:
            refused.append(f"{path}: refused: " + "; ".join(problems[:5]))
        else:
            valid[path] = doc
    result = merge_physical(valid)
    refused += result.refused
    if result.doc is None:
        return Merged([], refused, skipped)
    out.mkdir(parents=True, exist_ok=True)
    body = leaderboard(result.doc).split("\n", 1)[1]  # its own title replaced
    text = "\n".join([f"{HEADING}{result.doc['suite_version']}, physical)", "",
                      "Merged from validated physical results files (`hri-bench validate`):",
                      "", *(f"- {code(Path(f).name)}: agents "
                            f"{', '.join(code(a) for a in docs[f]['agents'])}"
                            for f in result.merged), body])
    with atomic_writer(out / "leaderboard.md") as f:
        f.write(text)
    for stale in ("profiles.png",):
        (out / stale).unlink(missing_ok=True)
    return Merged([out / "leaderboard.md", *write_figures(result.doc, out)], refused, skipped)


def _mergeable(valid: Mapping[str, Mapping[str, Any]]
               ) -> tuple[dict[str, Mapping[str, Any]], list[str]]:
    """The validated files that can be merged with the first one, and one line per file
    refused: another suite (version or hash) or runs scale than the first file's, or runs
    that contradict another file's under the same code identity and seed
    (:func:`hri_bench.suite.audit.conflicts`: both files are refused, the runs named).
    """
    if not valid:
        return {}, []
    first_name, first = next(iter(valid.items()))
    keep: dict[str, Mapping[str, Any]] = {}
    refused = []
    for name, doc in valid.items():
        if doc["suite"]["hash"] != first["suite"]["hash"]:
            refused.append(f"{name}: refused: suite v{doc['suite']['version']} "
                           f"({doc['suite']['hash'][:12]}…), {first_name} is suite "
                           f"v{first['suite']['version']} ({first['suite']['hash'][:12]}…): "
                           "results of different suites are not merged")
        elif doc["runs_scale"] != first["runs_scale"]:
            refused.append(f"{name}: refused: runs scale {doc['runs_scale']}, {first_name} has "
                           f"{first['runs_scale']}: results of different run counts are not "
                           "merged (run the suite with the same --runs-scale)")
        else:
            keep[name] = doc
    clash = conflicts(keep)
    bad = sorted({n for c in clash for n in c.files})
    for n in bad:
        refused.append(f"{n}: refused: " + "; ".join(c.text for c in clash if n in c.files)
                       + " (hri-bench validate --replay tells which file is genuine)")
    keep = {n: d for n, d in keep.items() if n not in bad}
    return keep, refused
