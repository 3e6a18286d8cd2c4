"""Newcomer comfort: what `make demo` suggests runs as printed, and the README names the
extra every example needs.
"""

import re
import shlex
import tomllib
from pathlib import Path

from hri_bench.cli import _NEXT_STEPS, build_parser

ROOT = Path(__file__).resolve().parents[1]


def test_the_demos_next_steps_are_valid_commands():
    lines = [line.split("#")[0].strip() for line in _NEXT_STEPS.splitlines()]
    commands = [shlex.split(line) for line in lines if line.startswith(("hri-bench", "python"))]
    assert len(commands) >= 5
    for words in commands:
        if words[0] == "hri-bench":
            build_parser().parse_args(words[1:])  # exits (SystemExit) if it does not parse
        else:
            assert (ROOT / words[1]).is_file(), words


def test_the_readme_names_the_extra_of_every_example():
    readme = (ROOT / "README.md").read_text()
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
                 ["optional-dependencies"])
    rows = dict(re.findall(r"^\| `examples/(\w+\.py)` \|.*\| ([^|]+) \|$", readme, re.M))
    assert set(rows) == {p.name for p in (ROOT / "examples").glob("*.py")
                         if p.name != "__init__.py"}
    for script, needs in rows.items():
        named = set(re.findall(r"`(\w+)`", needs))
        assert needs.strip() == "none" or (named and named <= extras), (script, needs)
