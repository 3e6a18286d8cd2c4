"""The scripts of ``benchmarks/`` explain every option in ``--help``."""

import argparse
import importlib
import sys
from pathlib import Path

import pytest

SCRIPTS = sorted(p.stem for p in (Path(__file__).parent.parent / "benchmarks").glob("*.py")
                 if p.stem not in ("__init__", "train_jax_ppo"))  # tyro: test_jax_ppo.py


class _Parsed(Exception):
    """Raised instead of parsing: the test has the parser."""


@pytest.mark.parametrize("name", SCRIPTS)
def test_every_option_has_a_help_text(name, monkeypatch):
    if name == "rl_reward_rules":
        pytest.importorskip("sb3_contrib")
    if name == "physics_speed":
        pytest.importorskip("mujoco")
    module = importlib.import_module(f"benchmarks.{name}")
    seen = []

    def parse_args(self, *args, **kwargs):
        seen.append(self)
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_args)
    monkeypatch.setattr(sys, "argv", [f"{name}.py"])
    with pytest.raises(_Parsed):
        module.main()
    (parser,) = seen
    assert parser.description, name
    bare = [a.option_strings for a in parser._actions
            if a.option_strings and not (a.help and a.help.strip())]
    assert not bare, f"{name}: options without help {bare}"
