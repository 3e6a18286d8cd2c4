"""Study runs on the physics backend: :func:`simulate_physics` for ``hri-bench study
--backend mujoco``, the counterpart of :func:`hri_envs.bench.runner.simulate`.

The physics is not batched: within each episode the runs are simulated one after the other
(the agent sees one active run at a time, which the batched agent protocol allows), and the
agent learns from all runs' episodes at once at the end of the episode, exactly as with the
graph backend. Every random draw of run ``r`` derives from ``(seed, r)``: the human's action
draws from ``(seed, r, 1)`` as on the graph, the human's force noise from ``(seed, r, 3)``,
the wheel's stand layouts from ``(seed, r, 4)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from hri_envs.bench.runner import EpisodeMetrics, Schedule
from hri_envs.physics.ik import IKFailure
from hri_envs.physics.observer import physical_reward
from hri_envs.physics.sim import PandaSim
from hri_envs.task.geometry import sample_wheel_layout, wheel_scenario
from hri_envs.task.graph import ROBOT_BIT, TOGGLE, WAIT, TaskGraph
from hri_envs.task.humans import ScriptedHuman
from hri_envs.task.protocol import BatchAgent, Trace

__all__ = ["robot_correct", "simulate_physics"]

EXTRAS = ("linear_impulse", "angular_impulse", "duration_s", "graph_agrees")


def robot_correct(graph: TaskGraph, s: int, a_r: int, a_h: int, s_next: int) -> bool:
    """Whether the robot acted and the next state is the one it acted towards (Sect. 6.3)."""
    if a_r == WAIT or graph.aborted[s, a_r, a_h]:
        return False
    if a_r == TOGGLE:
        return bool((graph.grasp[s] ^ graph.grasp[s_next]) & ROBOT_BIT)
    s1 = int(graph.next_state[s, WAIT, a_h]) if a_h == TOGGLE else s
    return int(graph.next_state[s1, a_r, WAIT]) == s_next


def simulate_physics(
    graph: TaskGraph,
    agent: BatchAgent,
    human: ScriptedHuman,
    schedule: Schedule,
    *,
    runs: Sequence[int] | np.ndarray,
    seed: int,
    r0: float,
    max_steps: int = 100,
    after_episode: Callable[[int, BatchAgent], None] | None = None,
) -> EpisodeMetrics:
    """Simulate ``schedule`` for a batch of runs with one agent on the simulated Panda.

    Same arguments and result as :func:`hri_envs.bench.runner.simulate`; the result's
    ``extras`` hold, each (B, E): ``linear_impulse`` [N s] and ``angular_impulse``
    [N m s] (the human's interaction wrench integrated over the episode, paper Fig. 6),
    ``duration_s`` (simulated seconds) and ``graph_agrees`` (fraction of the episode's
    steps whose observed next state is the graph's prediction). The robot observes the
    human's *inferred* action; rewards and correct/passive/wrong use the observed next
    state and the simulated human's true action. A simulation fault truncates the episode.
    """
    n_b, n_e = schedule.start.shape
    if agent.n_runs != n_b or len(runs) != n_b:
        raise ValueError(f"agent has {agent.n_runs} runs, schedule {n_b}, runs {len(runs)}")
    human_rngs = [np.random.default_rng([int(seed), int(r), 1]) for r in runs]
    noise_rngs = [np.random.default_rng([int(seed), int(r), 3]) for r in runs]
    layout_rngs = [np.random.default_rng([int(seed), int(r), 4]) for r in runs]
    sim = PandaSim(graph)
    privileged = bool(getattr(agent, "privileged", False))
    keys = ("reward", "correct", "passive", "wrong", "steps", *EXTRAS)
    out = {k: np.zeros((n_b, n_e)) for k in keys}
    truncated = np.zeros((n_b, n_e), dtype=bool)
    for e in range(n_e):
        agent.begin_episode(schedule.start[:, e].copy())
        traces: list[Trace] = []
        intentions = np.zeros(n_b, dtype=np.int64)
        for i in range(n_b):
            active = np.zeros(n_b, dtype=bool)
            active[i] = True
            start, goal = int(schedule.start[i, e]), int(schedule.goal[i, e])
            turn = bool(schedule.turn_back[i, e])
            turn_state = int(human.turn_state[start, goal])
            scenario = (wheel_scenario(sample_wheel_layout(layout_rngs[i]))
                        if graph.name == "wheel" else None)
            states: list[int] = []
            robot_acts: list[int] = []
            human_seen: list[int] = []
            try:
                s = sim.reset(start, scenario, noise_rngs[i])
            except IKFailure:
                s, truncated[i, e] = graph.support_state(start, 0), True
            states.append(s)
            lifted, done, last_h = False, truncated[i, e], WAIT
            agrees = 0
            while not done and len(robot_acts) < max_steps:
                if turn and s == turn_state:
                    goal, turn = start, False
                obs = {"state": np.full(n_b, s), "start": schedule.start[:, e],
                       "last_human_action": np.full(n_b, last_h),
                       "action_mask": np.repeat(graph.valid[s][None].astype(np.int8), n_b, 0)}
                if privileged:
                    obs["intention"] = np.full(n_b, goal)
                a_r = int(agent.act(obs, active)[i])
                u = human_rngs[i].random(2)
                a_h = int(human.act_from_uniforms(np.array(s), np.array(start), np.array(goal),
                                                  np.array(u[0]), np.array(u[1])))
                res = sim.step(s, a_r, a_h)
                s_next, last_h = res.state, res.human_action
                out["reward"][i, e] += physical_reward(graph, s, a_r, a_h, s_next, r0)
                correct = robot_correct(graph, s, a_r, a_h, s_next)
                out["correct"][i, e] += correct
                out["passive"][i, e] += a_r == WAIT
                out["wrong"][i, e] += a_r != WAIT and not correct
                out["linear_impulse"][i, e] += res.linear_impulse
                out["angular_impulse"][i, e] += res.angular_impulse
                out["duration_s"][i, e] += res.duration
                agrees += res.graph_agrees
                agent.observe(np.full(n_b, s), np.full(n_b, a_r), np.full(n_b, last_h),
                              np.full(n_b, s_next), active)
                robot_acts.append(a_r)
                human_seen.append(last_h)
                states.append(s_next)
                s = s_next
                lifted |= bool(graph.left_start(s, start))
                done = bool(graph.episode_over(s, start, lifted))
                if res.fault is not None and not done:
                    truncated[i, e] = done = True
            if not done:
                truncated[i, e] = True
            n_steps = max(len(robot_acts), 1)
            out["steps"][i, e] = len(robot_acts)
            out["graph_agrees"][i, e] = agrees / n_steps
            for k in ("correct", "passive", "wrong"):
                out[k][i, e] /= n_steps
            end = int(graph.support[s])
            intentions[i] = -1 if truncated[i, e] or end < 0 else end  # -1: not revealed
            traces.append(Trace(np.array(states), np.array(robot_acts, dtype=np.int64),
                                np.array(human_seen, dtype=np.int64)))
        agent.end_episode(traces, intentions)
        if after_episode is not None:
            after_episode(e, agent)
    return EpisodeMetrics(out["reward"], out["correct"], out["passive"], out["wrong"],
                          out["steps"], truncated, extras={k: out[k] for k in EXTRAS})
