"""Agents of one's own run in a process of their own and see the robot's view only (issue 41,
item 1): the three cheats of tests/helpers_cheats.py are blind there, the benchmark's process
never imports their code, the messages carry data only, and a process that dies is its
agent's failure.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hri_bench.run import isolation
from hri_bench.run.agents import agent_privilege, validate_agent_name
from hri_bench.run.isolation import IN_PROCESS, agent_streams
from hri_bench.run.study import StudyConfig, run_study
from hri_bench.run.wire import WireError, read_message, write_message

ROOT = Path(__file__).resolve().parent.parent
CHEATS = "tests.helpers_cheats"
WAITS = "tests.helpers_agents:AlwaysWait"


def _study(*agents, **settings):
    cfg = StudyConfig("wheel", agents=agents, runs=6, episodes=3, seed=0,
                      population="test-v2-scripted", **settings)
    result = run_study(cfg, keep_going=True)
    return result, {a: m["reward"] for a, m in result.metrics.items()}


def test_the_cheats_are_blind_in_their_own_process():
    _, rewards = _study(f"{CHEATS}:ReadsFrames", f"{CHEATS}:RebuildsHumans", WAITS,
                        "informed", "qmdp")
    # Neither found the human, ι, the seed or the runs: each waits as AlwaysWait does.
    assert np.array_equal(rewards[f"{CHEATS}:ReadsFrames"], rewards[WAITS])
    assert np.array_equal(rewards[f"{CHEATS}:RebuildsHumans"], rewards[WAITS])
    assert rewards[WAITS].mean() < rewards["qmdp"].mean() - 10


def test_in_the_benchmark_s_process_the_same_cheats_would_work(monkeypatch):
    """What the host takes away: made in this process, both play their references."""
    monkeypatch.setenv(IN_PROCESS, "1")
    _, rewards = _study(f"{CHEATS}:ReadsFrames", f"{CHEATS}:RebuildsHumans", "informed",
                        "qmdp")
    assert np.array_equal(rewards[f"{CHEATS}:ReadsFrames"], rewards["informed"])
    assert np.array_equal(rewards[f"{CHEATS}:RebuildsHumans"], rewards["qmdp"])


def test_an_agent_declaring_privilege_is_handed_the_intention_and_is_a_reference():
    name = f"{CHEATS}:DeclaresPrivileged"
    _, rewards = _study(name, WAITS)
    assert not np.array_equal(rewards[name], rewards[WAITS])  # it moved: it was handed ι
    assert agent_privilege(name).sees_intention and agent_privilege(name).reference
    assert not agent_privilege(f"{CHEATS}:ReadsFrames").reference
    assert agent_privilege("oracle").reference and agent_privilege("qmdp").reference
    assert not agent_privilege("countqmdp").reference


def test_the_benchmark_never_imports_an_agent_of_one_s_own():
    code = (
        "import sys\n"
        "from hri_bench.run.agents import agent_identity, validate_agent_name\n"
        "from hri_bench.run.study import StudyConfig, run_study\n"
        f"names = ['{CHEATS}:' + c for c in ('ReadsFrames', 'DeclaresPrivileged', "
        "'RebuildsHumans')]\n"
        "for n in names:\n    validate_agent_name(n)\n    agent_identity(n)\n"
        "run_study(StudyConfig('wheel', agents=tuple(names), runs=2, episodes=1))\n"
        f"print('{CHEATS}' in sys.modules)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"  # its module-level code never ran there


def test_an_agent_that_requires_the_seed_or_its_runs_is_refused_before_it_runs(tmp_path,
                                                                            monkeypatch):
    (tmp_path / "wants_seed.py").write_text(
        "from tests.helpers_agents import AlwaysWait\n"
        "class WantsSeed(AlwaysWait):\n"
        "    def __init__(self, graph, seed, run):\n        pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(Exception, match="requires seed, run in its constructor"):
        validate_agent_name("wants_seed:WantsSeed")


def test_its_streams_come_from_a_keyed_hash_not_from_seed_and_run():
    a, b = agent_streams(5, [7])[0].random(), agent_streams(6, [7])[0].random()
    assert a != b and a == agent_streams(5, [7])[0].random()
    assert a != np.random.default_rng([5, 7]).random()


def test_a_process_that_dies_is_its_agent_s_failure_and_the_others_go_on(monkeypatch):
    monkeypatch.delenv("HRI_TEST_GATE", raising=False)
    result, rewards = _study("tests.helpers_faults:ExitsProcess", "passive")
    assert set(rewards) == {"passive"}
    assert "its process ended with exit status 3" in result.failures[
        "tests.helpers_faults:ExitsProcess"]


def test_what_an_agent_prints_does_not_reach_the_messages(tmp_path, monkeypatch):
    (tmp_path / "chatty.py").write_text(
        "from tests.helpers_agents import AlwaysWait\n"
        "class Chatty(AlwaysWait):\n"
        "    def act(self, observation):\n"
        "        print('\\x00' * 16, 'hello')\n        return 0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    _, rewards = _study("chatty:Chatty", WAITS)
    assert np.array_equal(rewards["chatty:Chatty"], rewards[WAITS])


def test_a_message_holds_data_only():
    stream = io.BytesIO()
    write_message(stream, {"kind": "step"}, {"a": np.arange(3), "b": np.ones((2, 2)),
                                             "c": np.array([True, False])})
    stream.seek(0)
    header, arrays = read_message(stream)
    assert header == {"kind": "step"} and arrays["a"].tolist() == [0, 1, 2]
    assert arrays["b"].dtype == np.float64 and arrays["c"].dtype == bool
    text = json.dumps({"arrays": [["x", "|O", [1]]]}).encode()
    for bad in (text, json.dumps({"arrays": [["x", "<f8", [2**40]]]}).encode(), b"[1]"):
        with pytest.raises(WireError):
            read_message(io.BytesIO(len(bad).to_bytes(8, "big") + bad + b"\0" * 8))


def test_one_message_per_step(monkeypatch):
    sent = []
    real = isolation._Host.request

    def counting(self, header, arrays=None):
        sent.append(header["kind"])
        return real(self, header, arrays)

    monkeypatch.setattr(isolation._Host, "request", counting)
    result, _ = _study(WAITS)
    steps = int(result.metrics[WAITS]["steps"].max(0).sum())  # the batch's longest episodes
    assert sent.count("step") == steps and sent.count("end") == 3
    assert "belief" not in sent


def test_in_its_own_process_an_agent_gives_the_numbers_it_gives_here(monkeypatch):
    """Every metric, the belief scores included, of an agent with a belief and a learner
    that draws from its streams: the host changes what the agent can see, not what it does.
    """
    agents = ("tests.helpers_agents:CountsStarts", "tests.helpers_agents:RandomMover")
    isolated, _ = _study(*agents)
    monkeypatch.setenv(IN_PROCESS, "1")
    here, _ = _study(*agents)
    for a in agents:
        for k, v in here.metrics[a].items():
            assert np.array_equal(v, isolated.metrics[a][k], equal_nan=True), (a, k)
    assert np.isfinite(here.metrics[agents[0]]["log_loss"]).all()
