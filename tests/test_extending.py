"""One way to extend everything: a scenario, a human family, a reward rule and an agent, each
added in one file as docs/extending.md says, pass their conformance checks and run in a
study, while suites v1, v2 and v3 stay byte for byte as they were."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: Runs in a process of its own: registering is global, and no other test should see it.
SCRIPT = textwrap.dedent("""
    import json, sys
    from pathlib import Path
    out = Path(sys.argv[1])

    from hri_bench.suite import TRACKS_BY_VERSION, run_suite
    from hri_bench.run import provenance
    from hri_bench.suite import default_agents

    SMALL = {"1": ("hanger-paper,wheel-drift", 0.01), "2": ("wheel-test-inconsistent", 0.05),
             "3": ("wheel-test-inconsistent,hanger-paper", 0.05),
             "4": ("wheel-test-inconsistent,hanger-paper", 0.05)}

    def published(tag):
        seen = {}
        for v, tracks in TRACKS_BY_VERSION.items():
            seen[v] = {"hash": provenance.suite_hash(v, list(tracks.values())),
                       "tracks": list(tracks), "agents": list(default_agents(v))}
            names, scale = SMALL[v]
            run_suite(out / tag / v, version=v, tracks=names, runs_scale=scale,
                      agents=("learner", "passive"))
        return seen

    before = published("before")

    from tests import scenario_box
    from tests.extension import agent, family, rewards
    scenario_box.register()

    from agents.conformance import check_agent
    from baselines import GoalFilter
    from hri_envs.conformance import check_human, check_reward_rule, check_scenario
    from hri_envs.humans.spec import HumanSpec
    report = [check_scenario("box"),
              check_human(HumanSpec(population="sloppy", params=(("noise", 4.0),)), "box"),
              check_reward_rule("costly-wait"),
              check_agent(lambda graph: GoalFilter(graph, 1, r0=-0.3, eta=0.3), "box")]

    from hri_bench.run.study import StudyConfig, run_study
    result = run_study(StudyConfig("box", agents=("learner", "eager-goalfilter", "informed"),
                                   runs=4, episodes=3, population="sloppy",
                                   human_params=(("noise", 4.0),), reward="costly-wait"))
    rewards = {a: float(m["reward"].mean()) for a, m in result.metrics.items()}

    after = published("after")
    (out / "report.json").write_text(json.dumps(
        {"before": before, "after": after, "checks": report, "rewards": rewards}))
""")


@pytest.mark.xdist_group("suite")
def test_a_scenario_family_reward_rule_and_agent_added_one_file_each(tmp_path):
    files = [ROOT / "tests" / "scenario_box.py", *sorted((ROOT / "tests" / "extension").glob(
        "[!_]*.py"))]
    assert len(files) == 4  # one file each, as the guide says
    done = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path)], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads((tmp_path / "report.json").read_text())
    scenario, human, rule, agent = report["checks"]  # what each check says it checked
    assert scenario.startswith("scenario 'box': 36 states, 12 actions") and "check_env" in scenario
    assert human.startswith("human HumanSpec(") and "population='sloppy'" in human
    assert "with valid actions, reproducible by seed" in human
    assert rule.startswith("reward rule 'costly-wait': rewards in [")
    assert agent.startswith("agent on the box: 3 episodes") and agent.endswith("reproducible")
    assert set(report["rewards"]) == {"learner", "eager-goalfilter", "informed"}
    assert all(-100.0 <= r <= 0.0 for r in report["rewards"].values())
    # Registering changed no published suite: definitions, and their files byte for byte.
    assert report["before"] == report["after"]
    for version in ("1", "2", "3"):
        for name in ("suite.json", "results.json", "leaderboard.md"):
            before = (tmp_path / "before" / version / name).read_bytes()
            assert before == (tmp_path / "after" / version / name).read_bytes(), (version, name)
