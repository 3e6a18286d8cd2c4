"""The continuous envs' speed on the C backend beside raw ``mj_step`` of the same scene.

:func:`c_speed` runs a ``*PandaContinuous-v0`` env with the upper reference (whole episodes,
seeds 0, 1, ...) for a number of seconds of wall time, in turns of 0.25 s with raw
``mj_step`` of the physics states the env itself went through (every tenth step's state,
stepped one env step's worth with its controls held; only ``mj_step`` timed), so both meet
the same load of the machine; one thread (``threadpoolctl``). It also times the earlier
figure, one state run on. ``benchmarks/continuous_speed.py`` prints it all;
``hri-bench speed --physics`` reports the env / raw ratio per CPU second.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Iterator
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from threadpoolctl import threadpool_limits

import hri_envs  # noqa: F401
from baselines.continuous import UpperReference
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import as_graph, spec_of

__all__ = ["c_speed"]

_TURN_S = 0.25  # [s] of wall time the env and raw mj_step take turns


def _episodes(env: gym.Env, base: Any, policy: UpperReference, states: list[np.ndarray],
              snapshot: mujoco.MjData) -> Iterator[int]:
    """Whole episodes of the upper reference (seeds 0, 1, ...), one env step per ``next``;
    keeps the physics state at the start of every tenth step in ``states`` and the one of
    the 60th step in ``snapshot``.
    """
    model = base.sim.model
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    steps, seed = 0, 0
    while True:
        obs, _ = env.reset(seed=seed)
        seed += 1
        policy.attach(base)
        policy.begin_episode(base.robot_task())
        while True:
            if steps % 10 == 0:  # the env's own physics states, for the raw figure
                state = np.empty(mujoco.mj_stateSize(model, spec))
                mujoco.mj_getState(model, base.sim.data, state, spec)
                states.append(state)
            obs, _, term, trunc, _ = env.step(policy.act(obs))
            steps += 1
            if steps == 60:
                mujoco.mj_copyData(snapshot, model, base.sim.data)
            yield steps
            if term or trunc:
                break


def c_speed(scenario: TaskGraph | str, drive: str, seconds: float) -> dict[str, float]:
    """The C backend's env and raw ``mj_step`` (see the module) on ``scenario`` (its task
    graph, or a registered scenario's name, resolved here).
    """
    spec = spec_of(as_graph(scenario))
    with warnings.catch_warnings():  # v0 on purpose: the figures' basis since they began
        warnings.simplefilter("ignore", DeprecationWarning)
        env = gym.make(str(spec.continuous_id), drive=drive)
    base: Any = env.unwrapped
    policy = UpperReference()
    model = base.sim.model
    states: list[np.ndarray] = []
    snapshot = mujoco.MjData(model)
    per_step = round(base.sim.dt_step / model.opt.timestep)
    with threadpool_limits(1):
        t_first = time.perf_counter()  # the compiled kernels: loaded, or compiled once
        obs, _ = env.reset(seed=0)
        policy.attach(base)
        policy.begin_episode(base.robot_task())
        env.step(policy.act(obs))
        first = time.perf_counter() - t_first
        run = _episodes(env, base, policy, states, snapshot)
        steps, wall, cpu = 0, 0.0, 0.0
        replay = _Replay(model, per_step)
        while wall < seconds:  # the env and raw mj_step in turns of _TURN_S each
            t0, c0 = time.perf_counter(), time.process_time()
            while time.perf_counter() - t0 < _TURN_S:
                steps = next(run)
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
            replay.run(states, _TURN_S)
        n, t1, c1 = 0, time.perf_counter(), time.process_time()
        while time.perf_counter() - t1 < min(seconds, 10.0):
            mujoco.mj_step(model, snapshot, nstep=100)
            n += 100
        raw_wall, raw_cpu = time.perf_counter() - t1, time.process_time() - c1
    env.close()
    h, dt_step = model.opt.timestep, base.sim.dt_step
    return {"steps": steps, "wall": wall, "env_rtf": steps * dt_step / wall,
            "env_rtf_cpu": steps * dt_step / cpu, "world_steps_per_s": steps * per_step / wall,
            "replay_states": len(states), "replay_steps_per_s": replay.n / replay.wall,
            "replay_rtf": replay.n * h / replay.wall, "replay_rtf_cpu": replay.n * h / replay.cpu,
            "raw_steps_per_s": n / raw_wall, "raw_rtf": n * h / raw_wall,
            "raw_rtf_cpu": n * h / raw_cpu, "nv": model.nv, "nu": model.nu, "first_s": first}


class _Replay:
    """Raw ``mj_step`` of the env's states: ``nstep`` steps from each in turn (only
    ``mj_step`` timed), resuming where the last turn stopped.
    """

    def __init__(self, model: mujoco.MjModel, nstep: int) -> None:
        self.model, self.nstep = model, nstep
        self.data = mujoco.MjData(model)
        self.n, self.wall, self.cpu, self.next = 0, 0.0, 0.0, 0

    def run(self, states: list[np.ndarray], seconds: float) -> None:
        """Step the states for about ``seconds`` of wall time."""
        spec = mujoco.mjtState.mjSTATE_INTEGRATION
        t_end = time.perf_counter() + seconds
        while states and time.perf_counter() < t_end:
            mujoco.mj_setState(self.model, self.data, states[self.next % len(states)], spec)
            self.next += 1
            t0, c0 = time.perf_counter(), time.process_time()
            mujoco.mj_step(self.model, self.data, nstep=self.nstep)
            self.wall += time.perf_counter() - t0
            self.cpu += time.process_time() - c0
            self.n += self.nstep
