"""The physical suite (``hri-bench suite --physical``): its results file recomputes from its
runs, replays run for run (the references' too), a forged reference is caught, files merge
only when their references agree, robots of one's own run in a process of their own and see
only the robot's view, and an interrupted suite resumes to the same file.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from hri_bench.cli import main as cli_main
from hri_bench.cli.args import resume_hint
from hri_bench.suite import physical_results as pr
from hri_bench.suite.merged import merged_leaderboard
from hri_bench.suite.physical_audit import merge_physical, replay_physical, validate_physical
from hri_bench.suite.physical_running import run_physical_suite
from hri_envs.errors import ConfigError

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

OWN = "tests.helpers_physical:OwnAdmittance"
NOSY = "tests.helpers_physical:Nosy"
SETTINGS = {"tracks": "hanger-nominal", "runs_scale": 0.01, "jobs": 1}


@pytest.fixture(scope="module")
def suite(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("physical") / "suite"
    doc = run_physical_suite(out, agents=["admittance", OWN, NOSY], **SETTINGS)
    return out, doc


def _forged(doc: dict, agent: str = "upper", by: float = -0.5) -> dict:
    """``doc`` with ``agent``'s returns moved by ``by`` and every statistic recomputed with
    the project's own functions (what a forger would do).
    """
    fake = copy.deepcopy(doc)
    for block in fake["runs"]["0"].values():
        rows = block["agents"][agent]["return"]
        block["agents"][agent]["return"] = [[round(x + by, 6) for x in r] for r in rows]
    fake["statistics"], fake["aggregate"] = pr.compute(fake)
    return json.loads(json.dumps(fake))


def test_the_file_recomputes_from_its_runs_and_an_edited_statistic_is_invalid(suite):
    out, doc = suite
    on_disk = json.loads((out / "results.json").read_text())
    assert validate_physical(on_disk) == []
    edited = copy.deepcopy(on_disk)
    edited["aggregate"]["headline"]["agents"]["admittance"]["mean"] += 0.01
    assert any(p.startswith("aggregate.headline.agents.admittance.mean: recorded")
               for p in validate_physical(edited))
    moved = copy.deepcopy(on_disk)
    moved["runs"]["0"]["hanger-nominal"]["humans"][0] += 1
    assert any("humans are not the suite seed's draws" in p for p in validate_physical(moved))


def test_a_robot_of_one_s_own_runs_in_its_process_and_scores_as_the_built_in(suite):
    _, doc = suite
    block = doc["runs"]["0"]["hanger-nominal"]["agents"]
    assert block[OWN] == block["admittance"]  # the same law, through the host: same numbers
    identity = doc["agents"][OWN]["identity"]
    assert identity["kind"] == "custom" and identity["module"] == "tests.helpers_physical"
    assert len(identity["code_sha256"]) == 64
    # (Nosy raises in its host if its task holds anything named for the goal, the intention
    # or the human: the suite, and so this fixture, would have stopped)


def _same(a, b) -> bool:
    """Deep equality of tasks: dataclasses, plain objects, mappings, sequences, arrays."""
    import dataclasses

    import numpy as np

    if dataclasses.is_dataclass(a) and type(a) is type(b):
        return all(_same(getattr(a, f.name), getattr(b, f.name))
                   for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(a, b)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if type(a) is type(b) and hasattr(a, "__dict__") and not callable(a):  # plain objects
        return _same(vars(a), vars(b))
    return a == b


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_a_robot_of_one_s_own_is_handed_exactly_the_public_task(scenario):
    """What the host rebuilds from the message is the task the env gives a robot (the
    wheel's drawn layout included), field for field."""
    import gymnasium as gym

    from hri_bench.run.physical_host import task_message
    from hri_bench.run.physical_session import task_from_message

    env = gym.make(f"hri_envs/{scenario.capitalize()}PandaContinuous-v1")
    env.reset(seed=3)
    task = env.unwrapped.robot_task()
    assert _same(task_from_message(*task_message(task)), task)


def test_replay_re_simulates_every_agent_the_references_included(suite):
    _, doc = suite
    found = replay_physical(doc, 1, seed=3)
    assert found.skipped == {} and found.differ == []
    assert {c.split()[0] for c in found.checked} == set(doc["agents"])


def test_a_forged_reference_passes_validate_but_not_replay_nor_a_merge(suite, tmp_path):
    out, doc = suite
    fake = _forged(doc)
    assert validate_physical(fake) == []  # self-consistent: only a replay can tell
    assert fake["aggregate"]["headline"]["agents"]["admittance"]["mean"] != \
        doc["aggregate"]["headline"]["agents"]["admittance"]["mean"]
    found = replay_physical(fake, 1, seed=0)
    assert found.differ and all("'upper'" in line for line in found.differ)
    genuine = json.loads((out / "results.json").read_text())
    merged = merge_physical({"a.json": fake, "b.json": genuine})
    assert merged.doc is None and len(merged.refused) == 2
    assert all("'upper'" in line for line in merged.refused)


def test_files_whose_references_agree_merge_into_one_recomputed_board(suite, tmp_path):
    out, doc = suite
    genuine = json.loads((out / "results.json").read_text())
    own_only = copy.deepcopy(genuine)
    for block in own_only["runs"]["0"].values():
        del block["agents"]["admittance"]
    del own_only["agents"]["admittance"]
    own_only["statistics"], own_only["aggregate"] = pr.compute(own_only)
    folder = tmp_path / "files"
    folder.mkdir()
    (folder / "a.json").write_text(json.dumps(json.loads(json.dumps(own_only))))
    (folder / "b.json").write_text(json.dumps(genuine))
    result = merged_leaderboard(sorted(folder.glob("*.json")), tmp_path / "board")
    assert result.refused == [] and result.written
    text = (tmp_path / "board" / "leaderboard.md").read_text()
    assert text.startswith("# hri-envs leaderboard (suite v1, physical)")
    assert "`admittance`" in text and f"`{OWN}`" in text


def test_validate_on_the_command_line(suite, tmp_path, capsys):
    out, doc = suite
    assert cli_main(["validate", str(out / "results.json"), "--replay", "1",
                     "--replay-seed", "1"]) == 0
    assert "replayed run(s) identical, the references' included" in capsys.readouterr().out
    forged = tmp_path / "forged.json"
    forged.write_text(json.dumps(_forged(doc)))
    assert cli_main(["validate", str(forged)]) == 0
    assert cli_main(["validate", str(forged), "--replay", "1", "--replay-seed", "1"]) == 1
    assert "REPLAY FAILED" in capsys.readouterr().err


def test_a_privileged_or_unknown_robot_is_refused_before_anything_runs(tmp_path):
    with pytest.raises(ConfigError, match="privileged"):
        run_physical_suite(tmp_path / "a", agents=["tests.helpers_physical:Privileged"],
                           **SETTINGS)
    with pytest.raises(ConfigError, match="read.*the simulation"):
        run_physical_suite(tmp_path / "b", agents=["upper"], **SETTINGS)
    with pytest.raises(ConfigError, match="unknown physical robot"):
        run_physical_suite(tmp_path / "c", agents=["admitance"], **SETTINGS)
    assert not (tmp_path / "a" / "results.json").exists()


def test_an_interrupted_suite_resumes_to_the_same_runs(suite, tmp_path):
    _, doc = suite
    out = tmp_path / "again"
    seen = []

    def stop_after_two(done: int, total: int) -> None:
        seen.append(done)
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_physical_suite(out, agents=["admittance", OWN, NOSY], progress=stop_after_two,
                           **SETTINGS)
    assert not (out / "results.json").exists()
    assert len(list((out / ".physical-units").glob("*.npz"))) == 2
    resumed: list[int] = []
    again = run_physical_suite(out, agents=["admittance", OWN, NOSY], resume=True,
                               progress=lambda done, total: resumed.append(done), **SETTINGS)
    assert resumed[0] == 2  # the two finished units were not run again
    assert again["runs"] == doc["runs"] and again["statistics"] == doc["statistics"]
    # a robot added to the finished suite: only its unit runs, the others' are kept
    added: list[tuple[int, int]] = []
    more = run_physical_suite(out, agents=["admittance", OWN, NOSY, "variable-admittance"],
                              resume=True, progress=lambda d, t: added.append((d, t)),
                              **SETTINGS)
    assert added[0] == (5, 6)
    kept = more["runs"]["0"]["hanger-nominal"]["agents"]
    assert all(kept[a] == e for a, e in doc["runs"]["0"]["hanger-nominal"]["agents"].items())


def test_the_physical_suite_is_found_after_leading_imports():
    from hri_bench.cli.physical import wants_physical

    assert wants_physical(["--import", "mylab.robots", "--import=x", "suite", "--physical"])
    assert not wants_physical(["--import", "suite", "study", "--physical"])
    assert not wants_physical(["suite", "--out", "x"])


def test_a_robot_that_raises_ends_the_suite_with_one_line(tmp_path, capsys):
    out = tmp_path / "broken"
    argv = ["suite", "--physical", "--out", str(out), "--runs-scale", "0.01", "--tracks",
            "hanger-nominal", "--agents", "tests.helpers_physical:Breaks", "--no-progress"]
    code = cli_main(argv)
    err = capsys.readouterr().err
    assert code == 1 and "a robot failed" in err and "the robot's own bug" in err
    assert "Traceback" not in err and resume_hint(argv) in err  # the command to paste
