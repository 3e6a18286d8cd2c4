"""Recording a session: every step of both agents, written per episode to a dataset.

:class:`RecordingHumans` sits in the benchmark loop's human seat
(:func:`hri_bench.run.runner.run_episodes`) around the real human (a person at
``hri-bench serve``, or scripted humans) and writes what happens through
:class:`hri_bench.data.datasets.SessionWriter`: the observations both agents saw, both actions,
the rewards by the episode rules (:mod:`hri_envs.task.episode`), the intention, the robot's
belief where the agent has one (``agent.belief()``, :func:`agents.protocol.read_belief`),
timestamps and response times. People and scripted humans take the same path;
:func:`record_study` records scripted humans, labelled synthetic; a recording stopped by
Ctrl-C or SIGTERM marks its sessions ``interrupted``, one stopped by an error ``failed``,
and one killed outright leaves them ``running``, which readers take as ``interrupted``
once no recorder holds the dataset's lock (:meth:`Dataset.recording`).
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from agents.protocol import BatchAgent, read_belief
from hri_bench.data.datasets import Dataset, SessionWriter, create_dataset
from hri_bench.run.agents import agent_settings, make_agent
from hri_bench.run.runner import human_streams, make_schedule, run_episodes
from hri_bench.run.study import unit_humans
from hri_envs import __version__
from hri_envs.envs.backends import batch_backend
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import BatchHuman, Rows, all_rows
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.humans.tables import TableHumans
from hri_envs.task import episode as rules
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import Layout, ScenarioSpec

__all__ = ["RecordingHumans", "agent_identity", "record_study"]


def agent_identity(agent: str, scenario: ScenarioSpec, r0: float,
                   learner: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The robot agent's id, its configuration on the scenario ``scenario`` (its spec) and
    the package version, for a session's record.
    """
    return {"agent": agent,
            "agent_config": agent_settings(agent, scenario, r0, dict(learner or {})),
            "hri_envs_version": __version__}


class RecordingHumans(BatchHuman):
    """The human seat's recorder: passes every call on to ``inner`` and records the steps.

    Args:
        inner: The human who acts (a person, scripted humans), ``n_runs`` rows.
        writers: One :class:`SessionWriter` per row (a row is a participant's session).
        agent: The robot agent of the same loop; its ``belief()`` ((B, I) array) is recorded
            when it has one.
        r0: The waiting reward of the robot's cooperation reward.
        reward: The reward variant (:data:`hri_envs.task.episode.REWARD_RULES`).
        session_index: Each row's index in the counterbalanced design (default the row).
        layouts: Per row, the supports' layout of each episode (the wheel's stands), or
            None: nominal.
        clock: Unix time in seconds (``time.time``).
        defer_writes: Keep finished episodes until :meth:`flush` instead of writing them at
            once (a web session writes while the page shows the outcome, so that the last
            key press of an episode does not wait for the disk).

    The inner human may expose ``client_response_ms`` ((n_runs,) float, NaN when unknown),
    a response time it measured itself, read after each ``act``.
    """

    def __init__(self, inner: BatchHuman, writers: Sequence[SessionWriter], *,
                 agent: BatchAgent | None, r0: float, reward: str = "paper",
                 session_index: Sequence[int] | None = None,
                 layouts: Sequence[Sequence[Layout | None]] | None = None,
                 clock: Callable[[], float] = time.time, defer_writes: bool = False) -> None:
        super().__init__(inner.graph, inner.n_runs)
        if len(writers) != inner.n_runs:
            raise ValueError(f"give one writer per row ({inner.n_runs}), got {len(writers)}")
        self.inner, self.writers, self.agent = inner, list(writers), agent
        self.r0, self.reward_rule, self.clock = r0, reward, clock
        self.name = inner.name  # type: ignore[misc]
        self.session_index = list(range(self.n_runs) if session_index is None
                                  else session_index)
        self.layouts = layouts
        self.defer_writes = defer_writes
        self._finished: list[tuple[int, dict[str, list[Any]]]] = []
        self._flushing = threading.Lock()
        n = self.n_runs
        self.episode = np.full(n, -1, dtype=np.int64)
        self.start = np.zeros(n, dtype=np.int64)
        self.assigned = np.zeros(n, dtype=np.int64)
        self.lifted = np.zeros(n, dtype=bool)
        self._pending: list[dict[str, Any] | None] = [None] * n
        self._rows: list[list[dict[str, Any]]] = [[] for _ in range(n)]

    # ----------------------------------------------------------------- delegated
    def seed(self, rng: np.random.Generator | Sequence[np.random.Generator]) -> None:
        """Hand the generator(s) to the inner human."""
        super().seed(rng)
        self.inner.seed(rng)

    @property
    def turn_state(self) -> np.ndarray | None:
        """The inner human's."""
        return self.inner.turn_state

    @property
    def turn_back(self) -> np.ndarray:
        """The inner human's."""
        return self.inner.turn_back

    def draw(self, rng: np.random.Generator, rows: Rows = None) -> None:
        """The inner human's."""
        self.inner.draw(rng, rows)

    # ----------------------------------------------------------------- recorded
    def begin_episode(self, starts: np.ndarray, intentions: np.ndarray, rows: Rows = None
                      ) -> None:
        """Note each row's start and assigned goal; begin the inner human's episodes."""
        idx = all_rows(rows, self.n_runs)
        self.start[idx] = np.asarray(starts).reshape(-1)
        self.assigned[idx] = np.asarray(intentions).reshape(-1)
        self.lifted[idx] = False
        self.episode[idx] += 1
        for i in idx:
            self._rows[i] = []
            self._pending[i] = None
        self.inner.begin_episode(starts, intentions, rows)

    def act(self, observations: Mapping[str, np.ndarray], active: np.ndarray) -> np.ndarray:
        """The inner human's actions, with what it saw, when and how fast."""
        t_shown = self.clock()
        belief = None if self.agent is None else read_belief(self.agent)
        actions = self.inner.act(observations, active)
        t_action = self.clock()
        client = getattr(self.inner, "client_response_ms", None)
        arr = np.asarray(actions)
        for i in np.flatnonzero(active):
            ms = None if client is None else float(client[i])
            self._pending[i] = {
                "state": int(observations["state"][i]),
                "intention": int(observations["intention"][i]),
                "human_last_human_action": int(observations["last_human_action"][i]),
                "robot_action": int(observations["robot_action"][i]),
                "human_action": int(arr[i]) if arr.shape == (self.n_runs,) else -1,  # checked
                "belief": None if belief is None else belief[i].tolist(),
                "t_shown": t_shown, "t_action": t_action,
                "response_s": t_action - t_shown,
                "client_response_ms": None if ms is None or math.isnan(ms) else ms,
            }
        return actions

    def observe(self, states: np.ndarray, robot_actions: np.ndarray, human_actions: np.ndarray,
                next_states: np.ndarray, active: np.ndarray) -> None:
        """Judge each active row's step by the episode rules and keep it."""
        self.inner.observe(states, robot_actions, human_actions, next_states, active)
        g = self.graph
        for i in np.flatnonzero(active):
            step = self._pending[i]
            if step is None:
                continue
            s, a_r, a_h, s1 = (int(states[i]), int(robot_actions[i]), int(human_actions[i]),
                               int(next_states[i]))
            start, lifted = int(self.start[i]), bool(self.lifted[i])
            reward = float(rules.step_reward(g, s, a_r, a_h, s1, self.r0,
                                             reward=self.reward_rule, start=start,
                                             lifted=lifted))
            lifted_after = lifted or bool(rules.left_start(g, s1, start))
            terminated = bool(rules.episode_over(g, s1, start, lifted_after))
            aborted = bool(g.aborted[s, a_r, a_h])
            rows = self._rows[i]
            step.update(
                state=s, next_state=s1, robot_action=a_r, human_action=a_h,
                robot_last_human_action=(rows[-1]["human_action"] if rows else 0),
                robot_reward=reward, aborted=aborted, terminated=terminated,
                human_reward=float(rules.goal_reward(g, s1, step["intention"], aborted,
                                                     terminated)))
            self.lifted[i] = lifted_after
            rows.append(step)
            self._pending[i] = None

    def end_episode(self, rows: Rows = None) -> None:
        """Write each row's finished episode (or keep it for :meth:`flush`), then end the
        inner human's.
        """
        for i in all_rows(rows, self.n_runs):
            columns = self._columns(int(i))
            if columns is not None:
                self._finished.append((int(i), columns))
        if not self.defer_writes:
            self.flush()
        self.inner.end_episode(rows)

    def flush(self) -> None:
        """Write the finished episodes not yet written (safe to call from another thread
        while the loop goes on: one flush at a time, in episode order).
        """
        with self._flushing:
            while self._finished:
                i, columns = self._finished[0]
                self.writers[i].write_episode(columns)
                self._finished.pop(0)

    def _columns(self, i: int) -> dict[str, list[Any]] | None:
        """Row ``i``'s finished episode as columns (None: it took no step)."""
        steps = self._rows[i]
        if not steps:
            return None
        layout = None if self.layouts is None else self.layouts[i][int(self.episode[i])]
        flat = [] if layout is None else [float(v) for xy in layout for v in xy]
        last = len(steps) - 1
        g = self.graph
        columns: dict[str, list[Any]] = {k: [step[k] for step in steps] for k in steps[0]}
        n = len(steps)
        columns.update(
            participant=[self.writers[i].participant] * n,
            session_index=[int(self.session_index[i])] * n,
            synthetic=[self.writers[i].dataset.synthetic] * n,
            episode=[int(self.episode[i])] * n, step=list(range(n)),
            start=[int(self.start[i])] * n, assigned_intention=[int(self.assigned[i])] * n,
            action_mask=[g.valid[s].astype(np.int8).tolist() for s in columns["state"]],
            truncated=[False] * last + [not steps[-1]["terminated"]],
            layout=[flat] * n)
        self._rows[i] = []
        return columns


def record_study(cfg: Any, dataset_id: str, *, root: str | None = None,
                 description: str = "") -> Dataset:
    """Record a study's runs with scripted humans as sessions of a synthetic dataset.

    Each run of ``cfg`` (a :class:`~hri_bench.run.study.StudyConfig` with one agent, on the
    graph backend) becomes one session, participant ``s0001``, ``s0002``, ... (numbered on
    from the sessions already in the dataset), played in the benchmark's loop with the
    study's humans, schedule and seeds: the recorded rewards are the study's.

    Raises:
        ConfigError: More than one agent, another backend, a dataset that holds people's
            or another scenario's sessions, or one another recorder is recording into.
        KeyboardInterrupt: Stopped (the sessions are marked ``interrupted``; their finished
            episodes are kept).
    """
    if len(cfg.agents) != 1:
        raise ConfigError("record one agent at a time (a session has one robot)",
                          field="agents")
    if cfg.backend != "graph":
        raise ConfigError("sessions are recorded on the graph backend", field="backend")
    dataset = create_dataset(dataset_id, cfg.graph, synthetic=True, root=root,
                             description=description)
    graph: TaskGraph = cfg.graph
    runs = list(range(cfg.runs))
    pref = "" if cfg.population else ("all" if cfg.preference == "all"
                                      else cfg.preference_of_run()[0])
    human, labels = unit_humans(cfg, pref, runs)
    schedule = make_schedule(graph, cfg.schedule, runs, cfg.n_episodes, cfg.seed, human)
    agent = make_agent(cfg.agents[0], graph, human, runs, seed=cfg.seed, r0=cfg.waiting_reward,
                       learner=dict(cfg.learner), max_steps=cfg.max_steps, reward=cfg.reward)
    humans = TableHumans(human, len(runs)) if isinstance(human, ScriptedHuman) else human
    humans.seed(human_streams(cfg.seed, runs))
    identity = agent_identity(cfg.agents[0], cfg.spec, cfg.waiting_reward, dict(cfg.learner))
    with dataset.recording():  # one recorder at a time; a killed one's sessions: interrupted
        first = len(dataset.session_dirs())
        writers: list[SessionWriter] = []
        try:
            for r in runs:
                design = [[int(schedule.start[r, e]), int(schedule.goal[r, e]),
                           bool(schedule.turn_back[r, e])] for e in range(cfg.n_episodes)]
                writers.append(SessionWriter(dataset, f"s{first + r + 1:04d}", {
                    "source": "scripted", "human": labels[r], "session_index": first + r,
                    "scenario": cfg.scenario, "r0": cfg.waiting_reward,
                    "reward_rule": cfg.reward, "max_steps": cfg.max_steps, "seed": cfg.seed,
                    "run": r, "episodes_planned": cfg.n_episodes, "schedule": design,
                    "study_settings": cfg.settings(), **identity}))
            recorder = RecordingHumans(humans, writers, agent=agent, r0=cfg.waiting_reward,
                                       reward=cfg.reward,
                                       session_index=[first + r for r in runs])
            backend = batch_backend("graph")(graph, runs, cfg.seed)
            for _ in run_episodes(graph, agent, recorder, schedule, backend,
                                  r0=cfg.waiting_reward, max_steps=cfg.max_steps, run_ids=runs,
                                  reward=cfg.reward):
                pass
        except KeyboardInterrupt:  # Ctrl-C, or SIGTERM within stop_on_signals
            _close(writers, "interrupted")
            raise
        except BaseException:
            _close(writers, "failed")
            raise
        for w in writers:
            w.finish("complete")
    return dataset


def _close(writers: Sequence[SessionWriter], status: str) -> None:
    """Mark the sessions ``status`` as far as the disk lets (a full disk: they stay
    ``running``, which readers treat as unfinished too), keeping the error that stopped
    the recording the one raised.
    """
    for w in writers:
        with contextlib.suppress(OSError):
            w.finish(status)
