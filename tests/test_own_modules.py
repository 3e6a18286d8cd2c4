"""Your own modules in the CLI (issue 43): ``hri-bench --import MODULE``, the imports recorded
in ``summary.json``, ``suite.json`` and ``results.json`` and replayed by ``--config``, the
``hri_envs.plugins`` entry points, ``check_agent`` by name, and errors of Python calls that
name Python parameters.

Before: a study of a family of one's own was run as ``python -c "import mylab.humans,
hri_bench.cli; hri_bench.cli.main()" study ...`` and its ``--config`` replay failed with
"'sloppy' is not a family". The CLI runs in processes of their own here: what a module
registers must not leak into the other tests' registries.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from agents.conformance import check_agent
from hri_bench.run.study import StudyConfig
from hri_envs import imports
from hri_envs.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]

HUMANS = '''
from hri_envs.humans.families import Family, register_family
from hri_envs.humans.rational import rational_human
from hri_envs.humans.scripted import preference_human


def sloppy_human(graph, *, noise: float = 2.0, preference=None):
    """Boltzmann with rationality 1 / noise."""
    return rational_human(preference_human(graph, preference), 1.0 / noise)


register_family(Family("sloppy", "misspecified", sloppy_human, "noisy"))
'''
AGENTS = '''
from baselines import GoalFilter
from hri_bench.run.agents import AgentSpec, register_agent

register_agent(AgentSpec("eager-goalfilter", lambda ctx: GoalFilter(
    ctx.graph, len(ctx.runs), r0=ctx.r0, eta=0.3), role="baseline", description="eager"))
'''


@pytest.fixture
def lab(tmp_path):
    """A folder holding ``mylab`` (a family and an agent of one's own), the CLI's cwd."""
    (tmp_path / "mylab").mkdir()
    (tmp_path / "mylab" / "humans.py").write_text(HUMANS)
    (tmp_path / "mylab" / "agents.py").write_text(AGENTS)
    return tmp_path


def _cli(args, cwd, path=()):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *map(str, path)])}
    return subprocess.run([sys.executable, "-m", "hri_bench.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_a_study_with_imports_records_them_and_its_config_replays_it(lab):
    study = ["study", "wheel", "--population", "sloppy", "--human-param", "noise=4",
             "--agents", "learner,eager-goalfilter", "--runs", "2", "--episodes", "3",
             "--no-progress"]
    done = _cli(["--import", "mylab.humans", "--import=mylab.agents", *study, "--out", "a"],
                lab)
    assert done.returncode == 0, done.stderr
    summary = json.loads((lab / "a" / "summary.json").read_text())
    assert summary["settings"]["imports"] == ["mylab.humans", "mylab.agents"]
    replay = _cli(["study", "--config", "a/summary.json", "--out", "b", "--no-progress"], lab)
    assert replay.returncode == 0, replay.stderr
    for name in ("summary.json", "episodes.csv"):
        assert (lab / "a" / name).read_bytes() == (lab / "b" / name).read_bytes(), name
    # without the import the names mean nothing: refused in one usage error
    plain = _cli([*study, "--out", "c"], lab)
    assert plain.returncode == 2 and "eager-goalfilter" in plain.stderr
    # a recorded module that no longer imports stops the replay, naming it
    (lab / "mylab" / "humans.py").unlink()
    gone = _cli(["study", "--config", "a/summary.json", "--out", "d"], lab)
    assert gone.returncode == 2 and "cannot import module 'mylab.humans'" in gone.stderr
    assert "Traceback" not in gone.stderr
    # a study without imports writes no "imports" (the files of earlier studies stay)
    assert "imports" not in StudyConfig("wheel").settings()


def test_a_bad_import_is_a_usage_error_naming_it(lab):
    done = _cli(["--import", "mylab.nothing", "study", "wheel", "--out", "x"], lab)
    assert done.returncode == 2
    assert "argument --import: cannot import module 'mylab.nothing'" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_suite_with_imports_records_them_and_its_config_replays_it(lab):
    suite = ["suite", "--agents", "learner,eager-goalfilter", "--runs-scale", "0.01",
             "--tracks", "wheel-paper", "--no-progress"]
    done = _cli(["--import", "mylab.agents", *suite, "--out", "s"], lab)
    assert done.returncode == 0, done.stderr
    doc = json.loads((lab / "s" / "suite.json").read_text())
    assert doc["imports"] == ["mylab.agents"]
    results = json.loads((lab / "s" / "results.json").read_text())
    assert results["tracks"]["wheel-paper"]["settings"]["imports"] == ["mylab.agents"]
    replay = _cli(["suite", "--config", "s/suite.json", "--out", "r", "--no-progress"], lab)
    assert replay.returncode == 0, replay.stderr
    for name in ("suite.json", "results.json", "leaderboard.md"):
        assert (lab / "s" / name).read_bytes() == (lab / "r" / name).read_bytes(), name


def _plugin(root: Path, body: str) -> Path:
    """An installed package ``myplug`` (a dist-info on a path of its own) whose entry point
    of the group hri_envs.plugins names its module."""
    site = root / "site"
    (site / "myplug").mkdir(parents=True)
    (site / "myplug" / "__init__.py").write_text(body)
    info = site / "myplug-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: myplug\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{imports.PLUGIN_GROUP}]\nmyplug = myplug\n")
    return site


def test_an_installed_plugin_registers_without_import_and_is_recorded(tmp_path):
    site = _plugin(tmp_path, HUMANS.replace('"sloppy"', '"plugged"'))
    done = _cli(["study", "wheel", "--population", "plugged", "--agents", "passive", "--runs",
                 "2", "--episodes", "2", "--no-progress", "--out", "p"], tmp_path, [site])
    assert done.returncode == 0, done.stderr
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert summary["settings"]["imports"] == ["myplug"]
    broken = _plugin(tmp_path / "broken", "raise RuntimeError('half installed')\n")
    done = _cli(["study", "wheel", "--out", "q"], tmp_path, [broken])
    err = done.stderr.strip()
    assert done.returncode == 1 and "\n" not in err and "Traceback" not in err
    assert "cannot load the plugin (entry point myplug = myplug of the group " \
           "'hri_envs.plugins', from myplug): RuntimeError: half installed" in err


def test_plugins_are_loaded_once_and_a_function_is_called(monkeypatch):
    calls = []

    class Entry:
        name, value, module, attr, dist = "lab", "json:dumps", "json", "dumps", None

        def load(self):
            return lambda: calls.append("called")

    monkeypatch.setattr(imports, "_PLUGINS", None)
    monkeypatch.setattr(imports, "_IMPORTED", [])
    monkeypatch.setattr(imports.importlib.metadata, "entry_points",
                        lambda group: [Entry()] if group == imports.PLUGIN_GROUP else [])
    assert imports.load_plugins() == ("lab = json:dumps",)
    assert imports.load_plugins() == ("lab = json:dumps",) and calls == ["called"]
    assert imports.imported_modules() == ("json",)


def test_check_agent_takes_a_registered_name():
    assert check_agent("goalfilter", "wheel", episodes=2).startswith("agent on the wheel")
    with pytest.raises(ConfigError, match="unknown agent 'nope'; registered: learner") as err:
        check_agent("nope")
    assert err.value.field == "agent"


@pytest.mark.parametrize("call, parameters", [
    (lambda: StudyConfig("wheel", human_params=(("k", 3),)), ("human_params=", "population=")),
    (lambda: StudyConfig("wheel", population="test", human_params=(("k", 3),)),
     ("human_params=",)),
    (lambda: StudyConfig("wheel", population="impatient", human_drift=2,
                         agents=("learner", "blind")), ("human_drift",)),
    (lambda: StudyConfig("wheel", imports=("no.such.module",)), ("'no.such.module'",)),
])
def test_errors_of_python_calls_name_python_parameters(call, parameters):
    with pytest.raises(ConfigError) as err:
        call()
    text = str(err.value)
    assert all(p in text for p in parameters), text
    assert not re.search(r"(?<![\w-])--[a-z]", text), text


def test_the_cli_names_its_flags_for_the_same_error(tmp_path, capsys):
    from hri_bench.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["study", "wheel", "--human-param", "k=3", "--out", str(tmp_path / "x")])
    assert exc.value.code == 2
    assert ("argument --human-param: --human-param sets the parameters of the family that "
            "--population names; no population is given") in capsys.readouterr().err


#: Modules whose messages are the commands' own (their options are the CLI's), and why.
CLI_MESSAGES = {
    "hri_bench/cli": "the command line",
    "hri_bench/people": "hri-bench serve's page and options (docs/people.md)",
    "hri_bench/run/studyio.py": "hri-bench study's output folder (--resume, --overwrite)",
    "hri_bench/run/folders.py": "a command's locked output folder (--resume, --overwrite)",
    "hri_bench/suite/resume.py": "hri-bench suite's output folder (--resume, --overwrite)",
    "hri_bench/suite/merged.py": "hri-bench leaderboard's advice on merging files",
    "hri_bench/report/sample_efficiency.py": "a script's own command line",
}


def test_no_library_error_names_a_command_line_flag():
    """An error a Python call raises names the call's parameters (``human_params=``), never
    the flag a command gives them by (``--human-param``): the CLI translates."""
    found = []
    for top in ("hri_envs", "agents", "baselines", "hri_bench"):
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if any(rel.startswith(prefix) for prefix in CLI_MESSAGES):
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if not (isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call)):
                    continue
                texts = [c.value for c in ast.walk(node.exc)
                         if isinstance(c, ast.Constant) and isinstance(c.value, str)]
                flags = [t for t in texts if re.search(r"(?<![\w-])--[a-z]", t)]
                if flags:
                    found.append(f"{rel}:{node.lineno}: {flags}")
    assert not found, "\n".join(found)


def test_the_import_option_is_documented_in_the_help():
    from hri_bench.cli import build_parser

    text = build_parser().format_help()
    assert "--import MODULE" in text and imports.PLUGIN_GROUP in " ".join(text.split())
