"""The physical human fitted to recorded sessions (hri_bench.people.physical_fit) and the
population file that seats it (``fitted:<path>``, hri_envs.physics.carry.human.population)."""

import json

import numpy as np
import pytest

from hri_bench.people import physical_fit as pf
from hri_bench.people.synthetic import ScriptedLeader
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.human.population import physical_population, save_population
from hri_envs.physics.scene.kinematics import Pose, compose
from hri_envs.task.scenarios import scenario_graph, scenario_spec


def _episode(params, start, goal, steps=220):
    """An episode where the object follows the reference of ``params`` exactly: the
    recorded targets are that reference's hand."""
    leader = ScriptedLeader(scenario_graph("hanger"), params)
    leader.begin({"layout": [], "start": start, "goal": goal}, {"bodies": ["object"]})
    first = leader.human.lines[0].sample(0.0)
    pos, quat = np.asarray(first.pos), np.asarray(first.quat)
    objects, targets = [], []
    for _ in range(steps):
        objects.append(np.concatenate([pos, quat]))
        ref = leader.human.advance(0.04, pos, quat)
        hand = compose(Pose(ref.pos, ref.quat), *leader.handle)
        targets.append(np.concatenate([hand.pos, hand.quat]))
        pos, quat = np.asarray(ref.pos), np.asarray(ref.quat)
    return pf._Episode(start, goal, [], np.asarray(objects), np.asarray(targets))


def test_the_fit_finds_the_reference_human_that_made_the_targets():
    prefs = scenario_spec("hanger").preferences
    true = HumanParams(speed=0.8, reaction_s=0.6, hesitation_s=0.9, preference=prefs[5])
    episodes = (_episode(true, 0, 1),)
    person = pf._Person("s0001", episodes, HumanParams(stiffness=0.8), 0.5, 220)
    # the true route among others, the timings from the defaults
    fit = pf._fit_person(scenario_graph("hanger"), person, (prefs[0], prefs[5], prefs[20]))
    assert fit.preference == true.preference
    assert fit.speed == pytest.approx(0.8, abs=0.03)
    assert fit.reaction_s == pytest.approx(0.6, abs=0.05)
    assert fit.hesitation_s == pytest.approx(0.9, abs=0.1)
    assert fit.stiffness == pytest.approx(0.4)  # the arm's, scaled by what was asked
    hanger = scenario_graph("hanger")
    assert pf.target_error(hanger, episodes, fit) < 0.005
    assert pf.target_error(hanger, episodes, HumanParams(preference=prefs[5])) > 0.05


def test_a_population_file_seats_its_humans_by_name(tmp_path):
    members = [HumanParams(speed=0.7, reaction_s=0.5), HumanParams(speed=1.2, sex="female",
                                                                    stature_m=1.6)]
    path = save_population(tmp_path / "fit.population.json", "hanger", members,
                           ["fitted/s0001", "fitted/s0002"], source={"dataset": "x"})
    assert json.loads(path.read_text())["schema"] == "hri-envs/physical-population/1"
    pop = physical_population(f"fitted:{path}", "hanger")
    assert pop.members == tuple(members) and pop.families == ("fitted", "fitted")
    assert pop.groups() == {"fitted": (0, 1)}
    with pytest.raises(ConfigError, match="holds 'hanger' humans"):
        physical_population(f"fitted:{path}", "wheel")
    with pytest.raises(ConfigError, match="cannot read"):
        physical_population(f"fitted:{tmp_path / 'none.json'}", "hanger")
    with pytest.raises(ConfigError, match="no committed signatures"):
        pop.signatures()
    # a v1 env draws its human from it at every reset
    from hri_envs.physics.carry.env import CarryEnv

    env = CarryEnv("hanger", version=1, population=f"fitted:{path}")
    seen = set()
    for seed in range(6):
        env.reset(seed=seed)
        seen.add(env.sim.params.speed)
    env.close()
    assert seen <= {0.7, 1.2} and len(seen) == 2


def test_fit_physical_on_synthetic_people_recorded_through_the_page(tmp_path):
    """Scripted members of the train population led the arm through the page's protocol;
    each training participant's fit explains their targets better than the default
    human, and the held-out ones are scored."""
    pytest.importorskip("fastapi")
    pytest.importorskip("pyarrow")
    from hri_bench.people.synthetic import record_synthetic

    dataset = record_synthetic("hanger", "fit-test", sessions=4, episodes=1, data=tmp_path,
                               at_once=2, max_time_s=5.0)
    assert dataset.synthetic and dataset.physical
    fit = pf.fit_physical(dataset)
    assert len(fit.held_out) >= 1 and len(fit.members) == len(fit.train) == 4 - len(
        fit.held_out)
    assert set(fit.train).isdisjoint(fit.held_out)
    s = fit.scores
    assert s["train"] < s["default_train"]
    assert np.isfinite(s["held_out"]) and s["steps_held_out"] > 0
    # the members keep their sessions' arms (the server seated them)
    meta = {m["participant"]: m["human_params"] for m in dataset.sessions()}
    for who, m in zip(fit.train, fit.members, strict=True):
        assert m.stature_m == HumanParams.of(meta[who]).stature_m
    path = fit.save(tmp_path / "fitted.json")
    assert physical_population(f"fitted:{path}", "hanger").members == fit.members
    assert json.loads(path.read_text())["source"]["synthetic"] is True
    with pytest.raises(ConfigError, match="graph sessions"):
        pf.fit_physical(_graph_dataset(tmp_path))


def _graph_dataset(tmp_path):
    from hri_bench.data.datasets import create_dataset

    return create_dataset("graph-only", "hanger", synthetic=True, root=tmp_path)
