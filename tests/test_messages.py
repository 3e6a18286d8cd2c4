"""Messages and help a newcomer reads first (issue 34): the help of ``play``, ``demo`` and
the top level, what ``demo`` says while it compiles, agents refused up front and called by
their class's name, another package named ``baselines`` or ``agents``, the citation file.
"""

import argparse
import datetime
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from agents import protocol
from agents.protocol import Agent, BatchAgent, Batched
from hri_bench.cli import build_parser, main
from hri_bench.run.agents import validate_agent_name
from hri_envs.errors import ActionError, ConfigError

ROOT = Path(__file__).resolve().parents[1]
#: The subcommands of hri_bench/cli/commands.py (those of people.py and results.py are theirs).
COMMANDS = ("study", "figures", "speed", "play", "suite", "demo")


def _subparsers(parser):
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action, action.choices


def test_every_command_has_a_description_and_every_option_a_help():
    action, parsers = _subparsers(build_parser())
    helps = {a.dest: a.help for a in action._choices_actions}
    for name in COMMANDS:
        sub = parsers[name]
        assert sub.description and helps[name], name
        for arg in sub._actions:
            if arg.dest != "help":
                assert arg.help, (name, arg.option_strings or arg.dest)


def test_the_demo_is_called_what_it_is():
    """The full demo (100 runs per study, as `figures --runs 100`) is not "reduced"."""
    action, parsers = _subparsers(build_parser())
    top = {a.dest: a.help for a in action._choices_actions}["demo"]
    text = top + parsers["demo"].description
    assert "reduced" not in text and "full size" in text and "100" in text


def test_the_demo_says_it_is_compiling_before_the_first_figure(monkeypatch, capsys, tmp_path):
    """`make demo` printed nothing for the 46 s numba took to compile the Learner's kernels
    after installing: it says what it does first, as `serve` does."""
    import hri_bench.report.figures as figures
    from agents.learning import algorithm1, partner_mdp

    said = []
    monkeypatch.setattr(partner_mdp, "jit_enabled", lambda: True)
    monkeypatch.setattr(algorithm1, "preload",
                        lambda: said.append(capsys.readouterr().out) or True)
    monkeypatch.setattr(figures, "make_figures", lambda *a, **k: said.append("figures") or [])
    assert main(["demo", "--out", str(tmp_path), "--jobs", "1"]) == 0
    assert "compiled kernels" in said[0] and "a minute or more" in said[0]
    assert said[1] == "figures"
    assert "kernels ready in" in capsys.readouterr().out


class _NoObserve(Agent):
    def begin_episode(self, start):
        pass

    def act(self, observation):
        return 0

    def end_episode(self, trace, intention):
        pass


class _ObserveNotCallable(_NoObserve):
    observe = None


class _Nameless(_NoObserve):
    def observe(self, state, robot_action, human_action, next_state):
        pass

    def act(self, observation):
        return 0.5


class _Named(_Nameless):
    name = "mine"


class _BatchNameless(BatchAgent):
    def begin_episode(self, starts):
        pass

    def act(self, observations, active):
        return np.zeros(self.n_runs, dtype=np.int64)

    def observe(self, states, robot_actions, human_actions, next_states, active):
        pass

    def end_episode(self, traces, intentions):
        pass

    def belief(self):
        return np.full((self.n_runs, 2), 0.7)


def test_an_agent_without_a_protocol_method_is_refused_before_any_simulation(monkeypatch):
    """It passed the check on its name and failed mid-study, when a worker made it."""
    for cls in ("_NoObserve", "_ObserveNotCallable"):
        with pytest.raises(ConfigError, match="does not implement observe") as info:
            validate_agent_name(f"tests.test_messages:{cls}")
        assert info.value.field == "agents"
    missing = protocol.missing_methods
    assert missing(_NoObserve) == ["observe"] and missing(_ObserveNotCallable) == ["observe"]
    assert missing(_Nameless) == [] and missing(_BatchNameless) == []


def test_the_cli_refuses_it_with_exit_2(capsys, tmp_path):
    for command in (["study", "wheel", "--out", str(tmp_path / "study")],
                    ["suite", "--out", str(tmp_path / "suite")]):
        with pytest.raises(SystemExit) as stop:
            main([*command, "--agents", "learner,tests.test_messages:_NoObserve"])
        assert stop.value.code == 2
        assert "does not implement observe" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # refused before anything was written


def test_a_nameless_agent_is_called_by_its_class():
    """Errors called every agent without a `name` "agent 'agent'"."""
    with pytest.raises(ActionError, match="act\\(\\) of agent '_Nameless' returned 0.5"):
        Batched([_Nameless()]).act({"state": np.zeros(1)}, np.ones(1, bool))
    with pytest.raises(ConfigError, match="agent '_BatchNameless' is not a probability"):
        from agents.protocol import read_belief

        read_belief(_BatchNameless(2))
    with pytest.raises(ActionError, match="agent 'mine'"):
        Batched([_Named()]).act({"state": np.zeros(1)}, np.ones(1, bool))
    assert _BatchNameless(1).single().name == "_BatchNameless"
    name = protocol.agent_name
    assert name(_Nameless()) == "_Nameless" and name(_Named()) == "mine"
    assert name(_BatchNameless(2)) == "_BatchNameless"


@pytest.mark.parametrize("name", ["baselines", "agents"])
def test_another_package_of_the_same_name_is_named_at_import(tmp_path, name):
    """`agents` and `baselines` are top-level packages; OpenAI's `baselines` has the same
    name. One that shadows ours is refused when hri_bench is imported, with what to do."""
    (tmp_path / name).mkdir()
    (tmp_path / name / "__init__.py").write_text("")
    done = subprocess.run([sys.executable, "-c", "import hri_bench"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError:") and f"package {name!r} found at" in last
    assert "uninstall it" in last and "Two top-level names" in last
    readme = (ROOT / "README.md").read_text()
    assert "### Two top-level names" in readme and "OpenAI" in readme


def test_the_citation_file_says_when_and_where():
    text = (ROOT / "CITATION.cff").read_text()
    fields = dict(line.split(":", 1) for line in text.splitlines()
                  if line and not line.startswith((" ", "-", "#")) and ":" in line)
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert fields["version"].strip() == version
    datetime.date.fromisoformat(fields["date-released"].strip().strip('"'))
    url = fields["repository-code"].strip().strip('"')
    # the address the results files' schema already names as the project's
    schema = json.loads((ROOT / "hri_bench/suite/results.schema.json").read_text())
    assert url.startswith("https://") and schema["$id"].startswith(url + "/")
