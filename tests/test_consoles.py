"""Consoles say what happened (issue 43): ``hri-bench suite`` ends with its ranking, a study's
lines about references and files name what ran and the real path, and the commands printed
can be pasted as they are.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from hri_bench.cli import main
from hri_bench.cli.args import invocation, resume_hint
from hri_bench.cli.commands import ranking_excerpt

ROOT = Path(__file__).resolve().parents[1]


def test_the_suite_ends_with_the_ranking_of_its_leaderboard(tmp_path, capsys):
    out = tmp_path / "suite"
    assert main(["suite", "--out", str(out), "--runs-scale", "0.01", "--tracks",
                 "wheel-paper,hanger-test-adaptive", "--no-progress"]) == 0
    printed = capsys.readouterr().out.rstrip("\n")
    board = (out / "leaderboard.md").read_text()
    table = ranking_excerpt(board)
    assert printed.endswith(table)
    assert table.splitlines()[0].startswith("| rank | agent | headline")
    assert "`learner`" in table and "References" in table and "`informed`" in table
    assert f"The ranking, from the top of {out / 'leaderboard.md'}:" in printed


def test_the_ranking_of_every_version_is_its_first_table():
    v1 = "# suite v1\n\nSeed 0.\n\n## Overview\n\nMean regret.\n\n| track | `a` |\n|---|---|\n" \
         "| t | 0.1 |\n\n## t\n\n| agent | regret |\n|---|---|\n"
    assert ranking_excerpt(v1) == "| track | `a` |\n|---|---|\n| t | 0.1 |"


def _study(args, capsys, tmp_path):
    assert main(["study", "wheel", "--runs", "2", "--episodes", "2", "--no-progress",
                 *args, "--out", str(tmp_path / "s")]) == 0
    return capsys.readouterr().out


def test_a_study_says_a_bracket_only_where_its_references_ran(tmp_path, capsys):
    """Before: "a bracket (qmdp below, informed above) is reported" under a study of a
    family's humans in which neither ran."""
    alone = _study(["--population", "impatient", "--agents", "passive"], capsys, tmp_path)
    line = next(x for x in alone.splitlines() if "regret vs blind" in x)
    assert "is reported" not in line
    assert "no reference ran for a bracket (add qmdp and informed to the agents" in line
    both = _study(["--population", "impatient", "--agents", "passive,qmdp,informed",
                   "--overwrite"], capsys, tmp_path)
    line = next(x for x in both.splitlines() if "regret vs blind" in x)
    assert line.endswith("a bracket (qmdp below, informed above) is reported")


def test_a_studys_regret_note_names_the_file_that_computes_it(tmp_path, capsys):
    out = _study(["--agents", "passive"], capsys, tmp_path)
    line = next(x for x in out.splitlines() if "regret vs blind" in x)
    path = line.rsplit("(", 1)[1].rstrip(")")
    assert path == "hri_bench/run/regret.py" and (ROOT / path).is_file(), line


def test_the_resume_command_is_printed_as_it_can_be_pasted(monkeypatch):
    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("PATH", "/usr/bin:/bin")  # the checkout's virtualenv not activated
    monkeypatch.setattr(sys, "argv", [str(ROOT / ".venv" / "bin" / "hri-bench")])
    assert invocation() == ".venv/bin/hri-bench"
    assert resume_hint(["study", "wheel", "--out", "out/x", "--overwrite"]) == \
        ".venv/bin/hri-bench study wheel --out out/x --resume"
    monkeypatch.setenv("PATH", f"{ROOT / '.venv' / 'bin'}{os.pathsep}/usr/bin")  # activated
    assert invocation() == "hri-bench"
    monkeypatch.setattr(sys, "argv", [str(ROOT / "hri_bench" / "cli" / "__main__.py")])
    assert invocation().endswith(" -m hri_bench.cli")
    assert os.path.exists(invocation().split(" -m ")[0])


@pytest.mark.parametrize("name", ["README.md", "docs/benchmark.md"])
def test_the_docs_name_no_module_where_it_is_not(name):
    """Paths the pages and the console name exist (the regret module moved into run/)."""
    import re

    text = (ROOT / name).read_text()
    for path in re.findall(r"`?((?:hri_bench|hri_envs|agents|baselines)/[\w/]+\.py)", text):
        assert (ROOT / path).is_file(), path
