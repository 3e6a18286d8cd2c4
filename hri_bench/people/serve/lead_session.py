"""A participant's physical session: a person leads the simulated arm's hand at 25 Hz.

The continuous env's parallel form (``hri_envs/*PandaContinuous-v1``) runs in a process of
the session's own (:mod:`~hri_bench.people.serve.lead_worker`, started through
:mod:`~hri_bench.people.serve.lead_process`) with the robot (any physical robot,
:mod:`hri_bench.core.physical_robots`). The page and the session meet as in a graph
session (:class:`~hri_bench.people.serve.session.Session`, whose channel, stop, idle time
and ending this class keeps): the session publishes views, the page answers them.

* A ``lead`` view is a frame of the scene: the drawn bodies' poses, the hand's pose, the
  force the hand puts on the handle, the camera, the robot's belief when shown. The page
  answers it with a ``hand`` message (:mod:`~hri_bench.people.serve.hand`): the target it
  leads the hand to. The session steps the env once with it (the human seat's action is made
  of the target: :func:`~hri_bench.people.serve.lead_worker.human_action`), and publishes the
  next frame. At most 25 steps a second run (a token bucket: a page that sends early waits,
  one that falls behind makes simulated time wait): the simulation advances in lockstep
  with the page, one step per input.
* After an episode an ``outcome`` view (where the object came to rest, the time, the
  human's effort), answered with ``continue``; at the end ``done`` (or ``ended``).

Each finished episode is written (:mod:`hri_bench.data.physical`'s columns) by the server's
writer thread while the page shows the outcome.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from hri_bench.data.datasets import Dataset, SessionWriter, create_dataset, new_participant_id
from hri_bench.data.physical import STEP_S
from hri_bench.people.serve.design import Assignment, ServeConfig
from hri_bench.people.serve.lead_process import LeadProcess, SparePool
from hri_bench.people.serve.scenes import STORE
from hri_bench.people.serve.session import Session, SessionManager, writer_pool
from hri_envs import __version__

__all__ = ["LeadSession", "LeadSessionManager", "episode_seeds"]

#: Steps that may run back to back after a pause (the token bucket's depth).
BURST = 2
#: The longest a session's process may take to build the env and the robot [s].
INIT_TIMEOUT_S = 180.0


def episode_seeds(seed: int, index: int, episodes: int) -> list[int]:
    """The env's reset seed of each episode of participant ``index`` (start, goal and layout
    are the design's and the env's draws from it; the sensor's noise too).
    """
    seq = np.random.SeedSequence([int(seed), int(index), 29])
    return [int(v) for v in seq.generate_state(episodes, np.uint32)]


def robot_seed(seed: int, index: int) -> int:
    """The robot's seed for participant ``index``."""
    return int(np.random.SeedSequence([int(seed), int(index), 5]).generate_state(1)[0])


class LeadSession(Session):
    """One participant of a physical task (see the module docstring).

    Args:
        config: The server's settings (``physical``).
        design: The participant's counterbalanced design.
        writer: Where the session is recorded.
        on_end: Called once the session has ended and is recorded.
        process: The session's process (started, not yet told anything).
        human: The human seat's body and arm (a :class:`HumanParams` mapping; people: the
            default).
    """

    _STEP_ANSWER = "your hand's target"

    def __init__(self, config: ServeConfig, design: Assignment, writer: SessionWriter,
                 on_end: Callable[[Session], None] | None, process: LeadProcess,
                 human: Mapping[str, Any]) -> None:
        super().__init__(config, design, writer, on_end)
        self.worker.close()  # the graph robot's call thread: this session's robot is elsewhere
        self.process = process
        self.worker = process  # type: ignore[assignment]  # stop() and close(), as Session's
        self.human = dict(human)
        self.seeds = episode_seeds(config.seed, design.index, config.episodes)
        self._bucket = (float(BURST), time.monotonic())
        self._view_base: dict[str, Any] = {}
        self._hand: dict[str, Any] | None = None

    # ----------------------------------------------------------------- the page's side
    def handle(self, msg: Mapping[str, Any]) -> None:
        """Apply a validated ``hand`` or ``continue`` message.

        Raises:
            MessageError: It does not answer the current view; nothing changes.
        """
        arrived = time.time()
        with self._lock:
            kind, _, _ = self._expected(msg)
            self._answered()
            self._actions.put((kind, 0))
            self._hand = {**msg, "t_input": arrived} if kind == "hand" else None

    # ----------------------------------------------------------------- the thread's side
    def _pace(self) -> None:
        """Wait until a step may run (at most 25 a second, :data:`BURST` after a pause)."""
        tokens, then = self._bucket
        now = time.monotonic()
        tokens = min(float(BURST), tokens + (now - then) / STEP_S)
        if tokens < 1.0:
            time.sleep((1.0 - tokens) * STEP_S)
            now, tokens = time.monotonic(), 1.0
        self._bucket = (tokens - 1.0, now)

    def _lead_view(self, frame: Mapping[str, Any], step: int) -> dict[str, Any]:
        view = {"type": "lead", **self._header(), **self._view_base, "step": step,
                **{k: frame[k] for k in ("poses", "hand", "handle", "force", "time_s")}}
        belief = frame.get("belief")
        if self.config.show_belief and belief is not None:
            view["belief"] = {n: b for n, b in zip(self.graph.support_names, belief,
                                                   strict=True)}
        return view

    def _episode_run(self, episode: int) -> tuple[dict[str, Any], list[dict[str, Any]]]:
        """One episode, step by step; (its last frame, the server's side of each step)."""
        cfg, proc = self.config, self.process
        start, goal = self.design.pairs[episode]
        frame, arrays = proc.request("begin_episode()", {
            "op": "reset", "seed": self.seeds[episode], "start": int(start),
            "goal": int(goal)}, timeout_s=cfg.agent_timeout_s)
        if "scene_json" in arrays:
            STORE.add_text(frame["scene"], arrays["scene_json"].tobytes())
        self._view_base = {"scene": frame["scene"], "camera": frame["camera"],
                           "time_limit_s": frame["time_limit_s"]}
        rows: list[dict[str, Any]] = []
        self._publish(self._lead_view(frame, 0), ("hand", frozenset()))
        while True:
            self._wait()
            msg = self._hand
            assert msg is not None
            if rows and msg["latency_ms"] is not None:  # it measured the last step's frame
                rows[-1]["client_latency_ms"] = float(msg["latency_ms"])
            self._pace()
            frame, _ = proc.request("act()", {"op": "step", "stiffness": msg["stiffness"]},
                                    {"target": np.asarray(msg["target"], dtype=np.float64)},
                                    timeout_s=cfg.agent_timeout_s)
            rows.append({"input": msg["input"], "t_input": msg["t_input"],
                         "t_frame": time.time(), "client_latency_ms": None})
            if frame["done"]:
                return frame, rows
            self._publish(self._lead_view(frame, len(rows)), ("hand", frozenset()))

    def _play(self) -> None:
        """The session's episodes, each outcome shown; returns when all are played."""
        cfg, proc = self.config, self.process
        proc.request("making the agent", {
            "op": "init", "scenario": cfg.scenario, "agent": cfg.agent,
            "seed": robot_seed(cfg.seed, self.design.index), "human": self.human,
            "max_time_s": cfg.max_time_s},
            timeout_s=max(cfg.agent_timeout_s, INIT_TIMEOUT_S))
        names = self.graph.support_names
        for episode in range(cfg.episodes):
            self._episode = episode
            frame, rows = self._episode_run(episode)
            summary, columns = proc.request("end_episode()", {"op": "end"},
                                            timeout_s=cfg.agent_timeout_s)
            goal = self.design.pairs[episode][1]
            figures = frame.get("figures", {})
            placed = int(frame["placed"])
            outcome = {"episode": episode + 1, "goal_name": names[goal],
                       "reached_name": names[placed] if placed >= 0 else None,
                       "success": bool(frame["reached"]), "outcome": frame["outcome"],
                       "truncated": bool(frame["truncated"]), "steps": len(rows),
                       "time_s": frame["time_s"],
                       "effort": None if figures.get("effort") is None
                       else round(float(figures["effort"]), 1),
                       "reward": round(float(np.sum(columns["reward"])), 3)}
            self.outcomes.append(outcome)
            self._written = writer_pool().submit(self._write,
                                             self._columns(episode, columns, rows, summary))
            last = episode + 1 == cfg.episodes
            self._publish({"type": "outcome", **self._header(), **outcome, "last": last,
                           **self._view_base, **{k: frame[k] for k in ("poses", "hand")}},
                          None if last else ("continue", frozenset()))
            if last:
                return
            self._wait()

    def _write(self, columns: Mapping[str, list[Any]]) -> None:
        self.writer.write_episode(columns)

    def _columns(self, episode: int, arrays: Mapping[str, np.ndarray],
                 rows: list[dict[str, Any]], summary: Mapping[str, Any]) -> dict[str, list[Any]]:
        """An episode's steps in :data:`~hri_bench.data.physical.PHYSICAL_COLUMNS`."""
        n = len(rows)
        start, goal = self.design.pairs[episode]
        belief = np.asarray(arrays["belief"])
        cols: dict[str, list[Any]] = {
            "participant": [self.participant] * n,
            "session_index": [self.design.index] * n,
            "synthetic": [self.writer.dataset.synthetic] * n,
            "episode": [episode] * n, "step": list(range(n)),
            "start": [int(start)] * n, "assigned_intention": [int(goal)] * n,
            "final_observation": [[]] * (n - 1) + [np.asarray(
                arrays["final_observation"]).tolist()],
            "belief": [None if np.isnan(b).any() else b.tolist() for b in belief],
            "placed": [-1] * (n - 1) + [int(summary["placed"])],
            "outcome": [None] * (n - 1) + [str(summary["outcome"])],
            "layout": [list(summary["layout"])] * n}
        for name in ("time_s", "robot_observation", "human_observation", "robot_action",
                     "human_action", "hand_target", "stiffness", "hand_pose", "hand_force",
                     "hand_torque", "reward", "terminated", "truncated", "step_s"):
            cols[name] = np.asarray(arrays[name]).tolist()
        for name in ("input", "t_input", "t_frame", "client_latency_ms"):
            cols[name] = [r[name] for r in rows]
        return cols


class LeadSessionManager(SessionManager):
    """The server's physical sessions (:class:`LeadSession`), a process started ahead for
    the next one.
    """

    def __init__(self, config: ServeConfig) -> None:
        self.spares = SparePool()
        try:
            super().__init__(config)
        except BaseException:
            self.spares.close()
            raise

    def _open_dataset(self) -> Dataset:
        cfg = self.config
        kind = "scripted humans through the page" if cfg.synthetic else "people"
        return create_dataset(cfg.dataset_id, cfg.graph, synthetic=cfg.synthetic,
                              root=cfg.data, physical=True,
                              description=f"{kind} leading the simulated arm (hri-bench "
                                          "serve, physical)")

    def _human(self, index: int) -> tuple[dict[str, Any], str]:
        """The human seat of participant ``index`` and its label."""
        cfg = self.config
        if cfg.population is None:
            return {}, "person"
        from hri_envs.physics.carry.human.population import (  # noqa: PLC0415
            params_dict,
            physical_population,
        )

        pop = physical_population(cfg.population, cfg.graph)
        member = pop.member_index(cfg.seed, index)
        return params_dict(pop.members[member]), pop.labels[member]

    def _new_session(self, index: int, design: Assignment) -> Session:
        cfg = self.config
        human, label = self._human(index)
        participant = (f"s{index + 1:04d}" if cfg.synthetic else new_participant_id())
        writer = SessionWriter(self.dataset, participant, {
            "source": "scripted-web" if cfg.synthetic else "web", "human": label,
            "human_params": human, "session_index": index, "scenario": cfg.scenario,
            "physical": True, "env_version": 1, "seed": cfg.seed, "run": index,
            "episodes_planned": cfg.episodes, "episode_seeds": episode_seeds(
                cfg.seed, index, cfg.episodes),
            "robot_seed": robot_seed(cfg.seed, index), "max_time_s": cfg.max_time_s,
            "schedule": [[int(a), int(b), False] for a, b in design.pairs],
            "preference": design.preference, "serve_settings": cfg.settings(),
            "agent": cfg.agent, "hri_envs_version": __version__})
        return LeadSession(cfg, design, writer, self._retire, self.spares.take(), human)

    def close(self, timeout: float = 5.0) -> None:
        """Stop every session, then the spare process."""
        try:
            super().close(timeout)
        finally:
            self.spares.close()
