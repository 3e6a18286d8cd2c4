"""Moved modules: each old name imports for one release, with a DeprecationWarning naming the
new place, as the same module object; the project's own code uses the new names only."""

import importlib
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import hri_bench
import hri_envs

ROOT = Path(__file__).resolve().parents[1]

#: Every public name the module hri_bench.suite had before it became a package.
SUITE_NAMES = (
    "ALPHA", "CONVERGED", "DEFAULT_AGENTS", "DEFAULT_AGENTS_V2", "DEFAULT_AGENTS_V3", "DELTA",
    "DELTA_V3", "DIMINISHING", "ERRORS_LOG", "FLOOR", "INTENTION_BLIND", "INTENTION_BLIND_V3",
    "LATEST", "MAX_BLOCKS", "MAX_RUNS", "MAX_RUNS_V3", "MIN_BLOCKS", "MIN_RUNS", "MIN_RUNS_V3",
    "PILOT_SD", "PILOT_V3", "POWER", "SUITE_VERSION", "SUITE_VERSIONS", "TRACKS",
    "TRACKS_BY_VERSION", "TRACKS_V2", "TRACKS_V3", "Track", "TrackV3", "check_version",
    "default_agents", "detectable_v3", "episodes_to_converge", "leaderboard", "leaderboard_v2",
    "leaderboard_v3", "population_track", "power_v3", "run_suite", "select_tracks",
    "track_config", "track_figure", "track_references", "track_summary", "track_summary_v2",
    "track_summary_v3",
)


def _warning(old, new):
    return rf"^{re.escape(old)} moved to {re.escape(new)}; the old name goes in the next release$"


OLD_AND_NEW = {**hri_bench.MOVED, "hri_bench.serve.app": "hri_bench.people.serve.app",
               # the physics by env family (a module of an old package follows it: mjwarp's)
               **{old: new for old, new in hri_envs.MOVED.items() if isinstance(new, str)},
               "hri_envs.physics.mjwarp.device": "hri_envs.physics.scene.warp.device"}


@pytest.mark.parametrize(("old", "new"), sorted(OLD_AND_NEW.items()))
def test_an_old_module_name_warns_and_is_the_same_module(old, new, monkeypatch):
    monkeypatch.delitem(sys.modules, old, raising=False)
    with pytest.warns(DeprecationWarning, match=_warning(old, new)):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)  # one module: its state is not duplicated
    assert module.__name__ == module.__spec__.name == new


def test_from_the_package_import_an_old_module(monkeypatch):
    monkeypatch.delitem(sys.modules, "hri_bench.study", raising=False)
    monkeypatch.delattr(hri_bench, "study", raising=False)
    with pytest.warns(DeprecationWarning, match=_warning("hri_bench.study", "hri_bench.run.study")):
        from hri_bench import study
    from hri_bench.run import study as new

    assert study is new


def test_the_old_human_module_forwards_each_name_to_where_it_is(monkeypatch):
    from hri_envs.humans import scripted
    from hri_envs.task.scenarios import hanger, wheel

    monkeypatch.delitem(sys.modules, "hri_envs.task.humans", raising=False)
    with pytest.warns(DeprecationWarning, match=r"^hri_envs\.task\.humans moved to "
                      r"hri_envs\.humans\.scripted .*; the old name goes in the next release$"):
        from hri_envs.task.humans import (
            HANGER_DEFAULT_PREFERENCE,
            HANGER_PREFERENCES,
            WHEEL_PREFERENCES,
            ScriptedHuman,
            preference_human,
        )
    assert preference_human is scripted.preference_human
    assert ScriptedHuman is scripted.ScriptedHuman
    assert (HANGER_PREFERENCES, HANGER_DEFAULT_PREFERENCE, WHEEL_PREFERENCES) == (
        hanger.PREFERENCES, hanger.DEFAULT_PREFERENCE, wheel.PREFERENCES)
    old = sys.modules["hri_envs.task.humans"]
    assert set(old.__all__) == set(hri_envs.MOVED["hri_envs.task.humans"].public)
    for name in old.__all__:
        assert getattr(old, name) is not None
    with pytest.raises(AttributeError):
        old.no_such_name  # noqa: B018


def test_the_suite_package_keeps_every_name_of_the_module_without_a_warning():
    import hri_bench.suite as suite

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        missing = [n for n in SUITE_NAMES if not hasattr(suite, n)]
        from hri_bench.suite import LATEST, TRACKS_V2, run_suite  # noqa: F401
    assert not missing
    assert set(SUITE_NAMES) <= set(suite.__all__)


def test_the_console_script_and_its_function_are_where_they_were():
    from hri_bench.cli import build_parser, main
    from hri_bench.cli.commands import build_parser as parser_there
    from hri_bench.cli.commands import main as main_there

    assert (main, build_parser) == (main_there, parser_there)


def test_the_test_suites_own_imports_raise_no_deprecation_warning():
    """``python -W error::DeprecationWarning``: every test module imports (JAX's too: in a
    process of its own)."""
    modules = sorted(f"tests.{p.stem}" for p in (ROOT / "tests").glob("*.py")
                     if p.stem != "__init__")
    code = "import " + ", ".join(modules)
    run = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code],
                         cwd=ROOT, capture_output=True, text=True,
                         env={**os.environ, "MUJOCO_GL": "egl"})
    assert run.returncode == 0, run.stderr[-3000:]


_OLD = re.compile(r"\bhri_bench[./](" + "|".join(
    sorted((k.split(".", 1)[1] for k in hri_bench.MOVED), key=len, reverse=True))
    + r")\b(?!/)|\bhri_bench/(suite|cli)\.py\b")


def test_the_project_names_modules_by_their_new_names():
    """Tests, examples, benchmarks, docs and the library itself: no old module name (nor
    ``hri_bench/<old>.py``); only the list of moved names and the changelog give them, and
    the regret note that summary.json and suite.json have always carried (byte for byte)."""
    allowed = {Path("hri_bench/__init__.py"), Path("tests/test_moved.py"), Path("CHANGELOG.md")}
    note = "mean over runs (hri_bench/regret.py)"
    files = [*ROOT.glob("*.md"), *ROOT.glob("docs/*.md"),
             *(p for d in ("hri_bench", "hri_envs", "agents", "baselines", "tests", "examples",
                           "benchmarks") for p in (ROOT / d).rglob("*.py"))]
    found = []
    for path in files:
        if path.relative_to(ROOT) in allowed:
            continue
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if _OLD.search(line) and "getLogger(" not in line and note not in line:
                found.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not found, "\n".join(found)


@pytest.mark.parametrize(("package", "name", "home"), [
    ("hri_envs.physics.scene", "build_scene", "hri_envs.physics.scene.build"),
    ("hri_envs.physics.carry", "CarrySim", "hri_envs.physics.carry.sim"),
])
def test_a_module_that_became_a_package_forwards_its_old_names(package, name, home):
    """hri_envs.physics.scene and .carry were modules; their names still resolve, warned."""
    module = importlib.import_module(package)
    with pytest.warns(DeprecationWarning, match=_warning(f"{package}.{name}", f"{home}.{name}")):
        value = getattr(module, name)
    assert value is getattr(importlib.import_module(home), name)
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        module.nothing_here  # noqa: B018
