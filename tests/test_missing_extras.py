"""Every missing extra gives one line with the install command (issue 43).

After ``make demo`` (the ``bench`` extra only), ``gymnasium.make(
"hri_envs/HangerPandaContinuous-v0")`` ended in a raw 20-line ``ModuleNotFoundError`` while
``HangerPanda-v0`` said in one line what to install. Here, in a process of its own per
situation, the registry is walked with an extra's modules missing
(:mod:`tests.helpers_extras`): every Gymnasium id, backend, drive, vector form and
PettingZoo module either works or raises one of the library's errors whose message is one
line with the command that installs what is missing; every ``hri-bench`` command that needs
a missing module exits with that one line on standard error, and no traceback.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from functools import cache
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from hri_bench.cli import build_parser
from tests.helpers_extras import COMMANDS, WITHOUT_EXTRAS

ROOT = Path(__file__).resolve().parents[1]
INSTALL = re.compile(r"\.venv/bin/pip install -c constraints\.txt -e '\.\[([\w,]+)\]'")
#: Extras no command or id needs (tools, clients tested elsewhere).
NOT_WALKED = ("dev", "clients", "plot")


def _canon(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requires(dist: str, extra: str = "") -> set[str]:
    out = set()
    for text in metadata.requires(dist) or []:
        req = Requirement(text)
        if req.marker is None or req.marker.evaluate({"extra": extra}):
            out.add(_canon(req.name))
    return out


def _closure(names: set[str]) -> set[str]:
    seen: set[str] = set()
    todo = list(names)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        try:
            metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        seen.add(name)
        todo += _requires(name)
    return seen


@cache
def situations() -> dict[str, tuple[frozenset[str], frozenset[str]]]:
    """Per situation, the extras not installed and the top-level modules missing then.

    ``without-X``: every extra but X (and those sharing a requirement with it, e.g.
    ``mjwarp`` with ``mujoco``) installed; ``base``: none; ``demo``: ``bench`` only. A module
    is missing when no installed extra (nor the base) brings its distribution.
    """
    base = _requires("hri-envs")
    extras = [x for x in metadata.metadata("hri-envs").get_all("Provides-Extra")
              if x not in NOT_WALKED]
    direct = {x: _requires("hri-envs", x) - base for x in extras}
    modules = {m: {_canon(d) for d in ds} for m, ds in metadata.packages_distributions().items()
               if not m.startswith("_")}

    def missing(installed: list[str]) -> frozenset[str]:
        kept = _closure(base) | set().union(*(_closure(direct[y]) for y in installed))
        gone = set().union(*(_closure(direct[y]) for y in extras)) - kept
        return frozenset(m for m, ds in modules.items() if ds & gone and not ds & kept)

    out = {}
    for x in extras:
        absent = frozenset(y for y in extras if direct[y] & direct[x])
        if absent not in {a for a, _ in out.values()}:  # mujoco's is mjwarp's
            out[f"without-{x}"] = (absent, missing([y for y in extras if y not in absent]))
    out["base"] = (frozenset(extras), missing([]))
    out["demo"] = (frozenset(x for x in extras if x != "bench"), missing(["bench"]))
    return out


def _walk(situation: str, tmp_path: Path) -> list[dict]:
    _, hidden = situations()[situation]
    done = subprocess.run([sys.executable, "-m", "tests.helpers_extras", ",".join(sorted(hidden)),
                           str(tmp_path)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=1200, env={**os.environ, "PYTHONPATH": str(ROOT),
                                             "MUJOCO_GL": "egl"})
    assert done.returncode == 0, done.stderr[-5000:]
    return [json.loads(line) for line in done.stdout.splitlines()]


def _installs(text: str, absent: frozenset[str]) -> bool:
    """``text`` gives the command installing extras that are all among ``absent``."""
    found = INSTALL.search(text)
    return found is not None and set(found.group(1).split(",")) <= absent


@pytest.mark.parametrize("situation", sorted(situations()))
def test_every_form_works_or_says_in_one_line_what_to_install(situation, tmp_path):
    absent, hidden = situations()[situation]
    if not hidden:
        pytest.skip(f"{situation}: every module it brings comes with another extra here")
    rows = _walk(situation, tmp_path)
    assert rows, "nothing was walked"
    bad = []
    for row in rows:
        if row["ok"]:
            continue
        if "stderr" in row:  # a command
            err = row["stderr"].strip()
            if not (row["code"] in (1, 2) and "\n" not in err and "Traceback" not in err
                    and _installs(err, absent)):
                bad.append(f"{row['what']}: exit {row['code']}:\n{err[-1500:]}")
        elif not (row["ours"] and "\n" not in row["message"]
                  and _installs(row["message"], absent)):
            bad.append(f"{row['what']}: {row['type']}: {row['message']}\n{row['traceback']}")
    assert not bad, f"{situation} (missing {sorted(hidden)}):\n\n" + "\n\n".join(bad)


def test_every_command_is_walked_or_needs_no_extra():
    """A new command is decided on here: what it needs, or that it needs nothing."""
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    walked = {c[0] for c, _ in COMMANDS}
    assert set(commands) == walked | set(WITHOUT_EXTRAS), set(commands) ^ (
        walked | set(WITHOUT_EXTRAS))


def test_the_situations_hide_what_a_newcomer_lacks():
    """``make demo`` installs ``bench`` only: the physics, the web and RL packages are
    missing then, and their forms are walked."""
    _, demo = situations()["demo"]
    assert {"mujoco", "mink", "pyarrow", "fastapi", "torch", "jax", "ray"} <= demo
    assert not {"matplotlib", "numba", "scipy"} & demo
    _, base = situations()["base"]
    assert {"matplotlib", "tqdm", "scipy", "numba"} <= base
