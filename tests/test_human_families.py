"""Each new human model does what defines it, on a small hand-made case.

The humans sit in a :class:`FiniteStateHumans` seat (or are scripted tables); each test
feeds them states and robot actions by hand and checks the action, the internal state and,
for the inconsistent ones, the intention they report.
"""

from __future__ import annotations

import numpy as np
import pytest

from hri_envs.errors import ConfigError
from hri_envs.humans.adaptive import follower_human, trust_human, wary_human
from hri_envs.humans.finite_state import FiniteStateHuman, FiniteStateHumans
from hri_envs.humans.inconsistent import fickle_human, moody_human
from hri_envs.humans.misspecified import (
    avoid_human,
    impatient_human,
    low_human,
    rotate_low_human,
)
from hri_envs.humans.scripted import ScriptedHuman, preference_human
from hri_envs.task.actions import PUT_ON, ROTATE, TOGGLE, WAIT
from hri_envs.task.mdp import passive_actions
from hri_envs.task.scenarios import scenario_graph

A, B, C = 0, 1, 2


def seat(model, seed=0):
    h = FiniteStateHumans(model)
    h.seed(np.random.default_rng(seed))
    return h


def step(h, s, start, goal, robot, s_next=None):
    """One step of a one-row seat by hand: the human's action for ``robot``'s action."""
    g = h.graph
    obs = {"state": np.array([s]), "start": np.array([start]), "intention": np.array([goal]),
           "last_human_action": np.array([WAIT]), "action_mask": g.valid[[s]].astype(np.int8),
           "robot_action": np.array([robot])}
    one = np.ones(1, dtype=bool)
    a_h = int(h.act(obs, one)[0])
    nxt = int(g.next_state[s, robot, a_h]) if s_next is None else s_next
    h.observe(np.array([s]), np.array([robot]), np.array([a_h]), np.array([nxt]), one)
    return a_h, nxt


def route(human: ScriptedHuman, start: int, goal: int) -> list[tuple[int, int]]:
    """(state, action) along the human's route from taking off to putting on, robot waiting
    (and joining the grasp)."""
    g = human.graph
    s = int(g.mounting_state[start])
    out = []
    for _ in range(30):
        a = int(human.route_table[start, goal, s])
        out.append((s, a))
        if a == PUT_ON:
            return out
        s = int(g.next_state[s, WAIT, a])
    raise AssertionError("no put-on within 30 steps")


# --------------------------------------------------------------------------- misspecified
def test_low_human_carries_at_the_lowest_height(wheel):
    z = wheel.position[:, 2]
    low = low_human(wheel, w=4.0)
    straight = preference_human(wheel, "straight")
    lowest = z[~wheel.is_support_state].min()
    path = route(low, A, B)  # rack (1.7 m) to stand B (1.1 m)
    assert path[0][1] == wheel.move_to_height(0)  # first down to the lowest waypoint ...
    moved_over = [s for s, a in path if a == wheel.move_over(B)]
    assert z[moved_over[0]] == pytest.approx(lowest)  # ... and across there
    # Its own cost (a step, plus 4 per metre above the lowest waypoint entered) is below the
    # straight route's, although it takes a step more.

    def cost(path):
        entered = [int(wheel.next_state[s, WAIT, a]) for s, a in path[:-1]]
        return sum(1 + 4.0 * (z[s] - lowest) for s in entered)

    other = route(straight, A, B)
    assert len(path) == len(other) + 1 and cost(path) < cost(other) - 1.0


def test_avoid_human_keeps_away_from_its_support(hanger):
    p_c = hanger.scenario.supports[C].position
    near = np.exp(-((hanger.position - p_c) ** 2).sum(-1) / (2 * 0.5 ** 2))
    avoid = avoid_human(hanger, support="C", w=3.0, sigma=0.5)
    default = preference_human(hanger)
    for start, goal in ((A, B), (B, A)):
        mine = sum(near[s] for s, _ in route(avoid, start, goal))
        theirs = sum(near[s] for s, _ in route(default, start, goal))
        assert mine < theirs - 0.1, (start, goal)
    with pytest.raises(ConfigError, match="support must be one of A, B, C"):
        avoid_human(hanger, support="D")


def test_rotate_low_human_rotates_at_the_lowest_height(wheel):
    z = wheel.position[:, 2]
    lowest = z[~wheel.is_support_state].min()
    rot = rotate_low_human(wheel, w=4.0)
    straight = preference_human(wheel, "straight")
    turn = [s for s, a in route(rot, C, A) if a == ROTATE]
    assert len(turn) == 1 and z[turn[0]] == pytest.approx(lowest)
    assert [z[s] for s, a in route(straight, C, A) if a == ROTATE] == [pytest.approx(1.7)]


def test_impatient_human_answers_k_robot_waits_by_waiting_then_takes_over(wheel):
    human = impatient_human(wheel, k=2)
    h = seat(human)
    a_star = int(preference_human(wheel).route_table[A, B, wheel.mounting_state[A]])
    s = int(wheel.mounting_state[A])  # held by both above the rack; it wants to move over
    h.begin_episode(np.array([A]), np.array([B]))
    assert step(h, s, A, B, WAIT)[0] == WAIT and h.z[0] == 1
    assert step(h, s, A, B, WAIT)[0] == WAIT and h.z[0] == 2
    assert step(h, s, A, B, WAIT)[0] == a_star  # the third wait: it takes over
    # A robot that leads does not count; a new episode forgets the count.
    h.end_episode()
    h.begin_episode(np.array([A]), np.array([B]))
    assert h.z[0] == 0
    assert step(h, s, A, B, a_star)[0] == a_star and h.z[0] == 0
    assert step(h, s, A, B, WAIT)[0] == WAIT
    # Grasping at the start is not a move it expects the robot to lead.
    rest = int(wheel.support_state(A, 0))
    assert step(h, rest, A, B, WAIT)[0] == TOGGLE
    # Without the robot's action (a seat that does not know it) it is the scripted human.
    obs = {"state": np.array([s]), "start": np.array([A]), "intention": np.array([B]),
           "last_human_action": np.array([WAIT]), "action_mask": wheel.valid[[s]]}
    assert h.act(obs, np.ones(1, dtype=bool))[0] == a_star


# --------------------------------------------------------------------------- adaptive
def test_follower_switches_to_the_robots_route_after_k_proposals(wheel):
    human = follower_human(wheel, k=2, preference="straight", other="detour")
    straight = preference_human(wheel, "straight").route_table
    detour = preference_human(wheel, "detour").route_table
    s = int(wheel.mounting_state[A])
    mine, theirs = int(straight[A, B, s]), int(detour[A, B, s])
    assert mine != theirs  # over to B vs rotate first
    h = seat(human)
    h.begin_episode(np.array([A]), np.array([B]))
    assert step(h, s, A, B, theirs)[0] == mine  # the first proposal: it insists on its own
    assert h.z[0] == 1
    assert step(h, s, A, B, mine)[0] == mine and h.z[0] == 0  # the robot followed: reset
    assert step(h, s, A, B, theirs)[0] == mine and h.z[0] == 1
    h.end_episode()  # the count carries over to the next episode
    h.begin_episode(np.array([A]), np.array([B]))
    assert h.z[0] == 1
    assert step(h, s, A, B, theirs)[0] == theirs  # the second in a row: it moves with it
    assert h.z[0] == 2  # now on the detour route, no proposals counted
    # From now on it follows the detour by itself, with a waiting robot too.
    s2 = int(wheel.next_state[s, WAIT, theirs])
    assert step(h, s2, A, B, WAIT)[0] == int(detour[A, B, s2])


def test_trust_rises_with_good_robot_motions_falls_with_wrong_ones(wheel):
    human = trust_human(wheel, levels=4, start=0, rise=1, fall=2, passive=0.8)
    table = preference_human(wheel).route_table
    s = int(wheel.mounting_state[A])
    good = int(table[A, B, s])
    wrong = int(wheel.move_over(C))
    assert human.law[0, A, B, s, 0, WAIT] == 0.0  # no trust: it never waits
    assert human.law[4, A, B, s, 0, WAIT] == pytest.approx(0.8)  # full trust: 0.8
    h = seat(human)
    h.begin_episode(np.array([A]), np.array([B]))
    for level in (1, 2, 3, 4, 4):
        step(h, s, A, B, good, s_next=s)
        assert h.z[0] == level
    step(h, s, A, B, wrong, s_next=s)
    assert h.z[0] == 2
    step(h, s, A, B, WAIT, s_next=s)  # waiting changes nothing
    assert h.z[0] == 2
    # At full trust it lets the robot lead four times in five.
    h.z[:] = 4
    waits = [step(h, s, A, B, good, s_next=s)[0] == WAIT for _ in range(2000)]
    assert np.mean(waits) == pytest.approx(0.8, abs=0.03)


def test_wary_human_yields_first_and_resists_more_after_wrong_motions(wheel):
    human = wary_human(wheel, levels=2, forgive=1)
    table = preference_human(wheel).route_table
    s = int(wheel.mounting_state[A])
    good, wrong = int(table[A, B, s]), int(wheel.move_over(C))
    h = seat(human)
    h.begin_episode(np.array([A]), np.array([B]))
    assert step(h, s, A, B, good, s_next=s)[0] == good and h.z[0] == 0
    assert step(h, s, A, B, wrong, s_next=s)[0] == WAIT  # it yields: the robot moves it
    assert h.z[0] == 1
    assert human.law[1, A, B, s, wrong, WAIT] == pytest.approx(0.5)  # half and half now
    step(h, s, A, B, wrong, s_next=s)
    assert h.z[0] == 2
    assert all(step(h, s, A, B, wrong, s_next=s)[0] == good for _ in range(20))  # resists
    h.end_episode()
    assert h.z[0] == 1  # it forgives one level between episodes


# --------------------------------------------------------------------------- inconsistent
def test_fickle_human_changes_its_mind_and_reports_it(wheel):
    human = fickle_human(wheel, hazard=1.0, changes=1)
    h = seat(human)
    h.begin_episode(np.array([A]), np.array([B]))
    rest = int(wheel.support_state(A, 0))
    assert step(h, rest, A, B, WAIT)[0] == TOGGLE  # grasping: on a support, no change of mind
    assert h.revised_intentions() is None
    s = int(wheel.mounting_state[A])
    step(h, s, A, B, WAIT)  # into free space: it changes its mind (hazard 1)
    new = h.revised_intentions()
    assert new is not None and new[0] in (A, C) and h.z[0] == 1
    step(h, s, A, int(new[0]), WAIT)
    assert h.revised_intentions() is None  # at most one change per episode
    h.end_episode()
    assert h.z[0] == 0


def test_fickle_human_in_the_robot_env_reaches_its_new_goal():
    from hri_envs.envs.robot import RobotEnv

    graph = scenario_graph("wheel")
    env = RobotEnv("wheel", human=fickle_human(graph, hazard=1.0))
    changed = reached = 0
    for seed in range(8):
        env.reset(seed=seed)
        first = env.intention
        done, info = False, {}
        while not done:  # the Passive robot: grasp at the start, let go at the goal
            ep = env._episode
            a = int(passive_actions(graph, np.array(ep.start), np.array(ep.lifted))[ep.state])
            _, _, term, trunc, info = env.step(a)
            done = term or trunc
        changed += env.intention != first
        reached += bool(info["reached_intention"])
    assert changed == 8 and reached == 8


def test_moody_human_changes_preference_at_random_episodes(wheel):
    always = moody_human(wheel, p=1.0, preferences=("straight", "detour"))
    h = seat(always)
    seen = []
    for _ in range(4):
        h.begin_episode(np.array([A]), np.array([B]))
        seen.append(int(h.z[0]))
        h.end_episode()
    assert seen == [0, 1, 0, 1]
    half = FiniteStateHumans([moody_human(wheel, p=0.5)] * 400)
    half.seed([np.random.default_rng(i) for i in range(400)])
    switches = []
    for _ in range(10):
        before = half.z.copy()
        half.end_episode()
        switches.append(np.mean(half.z != before))
    assert np.mean(switches) == pytest.approx(0.5, abs=0.05)
    with pytest.raises(ConfigError, match="at least two different"):
        moody_human(wheel, preferences="straight")


def test_a_scripted_human_is_the_one_state_case(wheel):
    scripted = preference_human(wheel, "detour", passive=0.2)
    model = FiniteStateHuman.from_scripted(scripted)
    assert model.n_z == 1 and not model.remembers
    # Passivity is folded into the law: where the route moves in free space, the human waits
    # with the passive rate and moves with the rest.
    moving = [(s, a) for s, a in route(scripted, A, B)
              if not wheel.is_support_state[s] and a != WAIT]
    assert moving
    for s, a in moving:
        assert model.law[0, A, B, s, 0, WAIT] == pytest.approx(0.2)
        assert model.law[0, A, B, s, 0, a] == pytest.approx(0.8)
    with pytest.raises(ConfigError, match="turns back"):
        FiniteStateHuman.from_scripted(preference_human(wheel, turn_back=0.5))


def test_a_seats_draws_do_not_depend_on_the_rows_beside_it(wheel):
    """Row r reads its own generator's uniforms in order, whatever else is in the batch."""
    model = trust_human(wheel, start=4, passive=0.5)
    s = int(wheel.mounting_state[A])
    good = int(preference_human(wheel).route_table[A, B, s])

    def actions(n_rows, row):
        h = FiniteStateHumans([model] * n_rows)
        h.seed([np.random.default_rng([7, r]) for r in range(n_rows)])
        h.begin_episode(np.full(n_rows, A), np.full(n_rows, B))
        out = []
        for t in range(150):
            active = np.ones(n_rows, dtype=bool)
            active[(np.arange(n_rows) + t) % 3 == 0] = False  # rows pausing at other times
            obs = {"state": np.full(n_rows, s), "start": np.full(n_rows, A),
                   "intention": np.full(n_rows, B), "robot_action": np.full(n_rows, good)}
            a = h.act(obs, active)
            h.observe(obs["state"], obs["robot_action"], a, obs["state"], active)
            if active[row]:
                out.append(int(a[row]))
        return out

    assert actions(5, 2) == actions(3, 2)  # the same row, beside two or four others
    assert actions(5, 2) != actions(5, 1)  # its own stream
    assert 0.3 < np.mean(np.array(actions(5, 2)) == WAIT) < 0.7


def test_cost_to_goal_is_the_fixed_point_of_one_step():
    # The shared distance of the misspecified humans and the goal filter: 0 on the goal held
    # by both, and everywhere else in free space one motion plus the best next state's cost.
    from hri_envs.task import mdp
    from hri_envs.task.actions import BOTH, PUT_ON, WAIT
    from hri_envs.task.scenarios import scenario_graph

    g = scenario_graph("wheel")
    free = ~g.is_support_state
    moves = g.valid & (np.arange(g.n_actions) >= PUT_ON)[None] & free[:, None]
    dist = mdp.cost_to_goal(g, np.where(moves, 1.0, np.inf))
    goals = np.arange(g.n_intentions)
    assert np.all(dist[goals, g.support_state(goals, BOTH)] == 0)
    nxt = g.next_state[:, WAIT, :]
    one_step = np.where(moves[None], 1.0 + dist[:, nxt], np.inf).min(-1)
    assert np.array_equal(dist[:, free], one_step[:, free])
    assert np.isfinite(dist[:, free]).all()  # every free state reaches every goal
