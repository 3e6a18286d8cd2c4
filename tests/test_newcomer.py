"""Newcomer comfort: what `make demo` suggests runs as printed, and the README names the
extra every example needs.
"""

import importlib
import importlib.util
import re
import shlex
import tomllib
from pathlib import Path

from hri_bench.cli import build_parser
from hri_bench.cli.commands import next_steps

ROOT = Path(__file__).resolve().parents[1]


def _check_command(words):
    """A command as printed works from the checkout: the program exists, hri-bench's
    arguments parse, a script or module it runs exists, a module:Class it names imports.
    """
    assert (ROOT / words[0]).is_file(), words  # .venv/bin/...: run from the checkout
    if words[0].endswith("hri-bench"):
        saved = [w for w in words if "sb3:out/train_maskable_ppo/" in w]
        if saved:  # a model the example writes: it exists once the example ran
            words = [w.replace(",sb3:out/train_maskable_ppo/ppo_hanger.zip", "") for w in words]
        args = build_parser().parse_args(words[1:])  # exits (SystemExit) if it does not parse
        names = [*(getattr(args, "agents", None) or ()), getattr(args, "population", None)]
        for name in names:
            if name and ":" in name and not name.startswith("sb3:"):
                module, _, attr = name.partition(":")
                assert hasattr(importlib.import_module(module), attr), name
    elif words[1] == "-m":
        assert importlib.util.find_spec(words[2]) is not None, words
    else:
        assert (ROOT / words[1]).is_file(), words


def _commands(text):
    """The commands in ``text``: lines and inline code starting with .venv/bin/ (a command
    may continue over lines ending in a backslash)."""
    text = text.replace("\\\n", " ")
    found = re.findall(r"^\s*(\.venv/bin/[^\n#`]+)", text, re.M)
    found += re.findall(r"`(\.venv/bin/[^`]+)`", text)
    return [shlex.split(c) for c in found if "[" not in c]  # "[--reward ...]": an option shown


def test_the_demos_next_steps_are_valid_commands():
    commands = _commands(next_steps(Path("out/demo")))
    assert len(commands) >= 7
    for words in commands:
        _check_command(words)


def _outs(commands):
    return {words[words.index("--out") + 1] for words in commands if "--out" in words}


def test_the_demos_next_steps_write_into_the_demos_folder_not_the_readmes():
    """Following `make demo`'s "what next" and then the README's tour once refused the
    README's first study: both wrote out/wheel."""
    demo = _outs(_commands(next_steps(Path("out/demo"))))
    assert demo and all(o.startswith("out/demo/") for o in demo), demo
    readme = _outs(_commands((ROOT / "README.md").read_text()))
    assert readme and not demo & readme, demo & readme
    assert not any(o == "out/demo" or o.startswith("out/demo/") for o in readme), readme


def test_every_command_in_the_readme_works_from_a_fresh_shell():
    """After the two set-up commands nothing is activated: every command the README shows
    runs as pasted (the tools are called from .venv/bin)."""
    readme = (ROOT / "README.md").read_text()
    commands = _commands(readme)
    assert len(commands) >= 15
    for words in commands:
        if words[0] != ".venv/bin/pip":
            _check_command(words)
    bare = re.findall(r"^\s*(hri-bench|python) ", readme, re.M)  # not runnable as pasted
    assert not bare


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
