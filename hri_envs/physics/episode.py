"""The physics backend inside the environments: an :class:`Episode` whose transitions are
simulated on the Panda instead of looked up in the graph.

Start, intention, turning back, termination and the step counter follow the shared episode
rules (:mod:`hri_envs.envs.episode`). The transition is :meth:`PandaSim.step`; the robot's
reward uses the observed next state (:func:`physical_reward`) and the simulated human's
true action; the robot observes the *inferred* human action. A simulation fault (unstable
physics, IK failure, time-out) is reported in ``fault``; the envs then truncate the episode.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hri_envs.envs.episode import Episode, EpisodeRules, Transition
from hri_envs.physics.ik import IKFailure
from hri_envs.physics.observer import physical_reward
from hri_envs.physics.rendering import SceneRenderer, write_video
from hri_envs.physics.sim import PandaSim, StepResult
from hri_envs.task.geometry import Scenario
from hri_envs.task.graph import WAIT

__all__ = ["PhysicsEpisode"]


class PhysicsEpisode(Episode):
    """One running episode on the simulated Panda.

    Args:
        rules: The scenario's episode rules.
        turn_state: Where a turning-back human turns (see :class:`Episode`).
        video_path: If set, each episode is recorded and written there when it ends (a
            ``{episode}`` field in the path is filled with the episode count); ``.gif``
            needs nothing more, other suffixes imageio-ffmpeg.
        video_fps: Frames per simulated second in the video.

    Attributes:
        sim: The simulation.
        observed_human: The human's last action as the robot inferred it.
        result: The last step's :class:`StepResult` (None after a reset).
        fault: Why the simulation cannot go on, or None.
    """

    def __init__(self, rules: EpisodeRules, turn_state: np.ndarray | None,
                 video_path: str | None = None, video_fps: float = 10.0) -> None:
        self.sim = PandaSim(rules.graph)
        self.observed_human = WAIT
        self.result: StepResult | None = None
        self.fault: str | None = None
        self.totals = np.zeros(4)  # linear impulse, angular impulse, duration, agreeing steps
        self.video_path, self.video_fps = video_path, video_fps
        self.frames: list[np.ndarray] = []
        self.episode_count = 0
        self._renderer: SceneRenderer | None = None
        super().__init__(rules, turn_state)

    def place(self, scenario: Scenario, rng: np.random.Generator) -> None:
        """Set the physics to the episode's start (after :meth:`draw`)."""
        self.flush_video()
        self.observed_human = WAIT
        self.result, self.fault = None, None
        self.totals[:] = 0.0
        try:
            self.sim.reset(self.start, scenario, np.random.default_rng(int(rng.integers(2**63))))
        except IKFailure as exc:
            self.fault = f"ik_failure: {exc}"
        self.episode_count += 1
        if self.video_path is not None:
            self.sim.frame_every = max(1, round(1.0 / (self.video_fps * self.sim.dt)))
            self.sim.on_frame = lambda: self.frames.append(self.render())
            self.frames.append(self.render())

    def advance(self, a_r: int, a_h: int) -> Transition:
        """Simulate the joint action from the current state."""
        r, g = self.rules, self.rules.graph
        s = self.state
        if self.fault is None:
            res = self.sim.step(s, a_r, a_h)
            self.result = res
            self.fault = res.fault
            s_next = res.state
            self.observed_human = res.human_action
            self.totals += (res.linear_impulse, res.angular_impulse, res.duration,
                            res.graph_agrees)
        else:  # nothing can move any more; the env truncates
            s_next = s
            self.observed_human = WAIT
        reward = physical_reward(g, s, a_r, a_h, s_next, r.r0)
        return Transition(reward, bool(g.aborted[s, a_r, a_h]), *self._commit(s_next, a_r, a_h))

    def step_info(self) -> dict[str, Any]:
        """Per-step physics figures for ``info`` (paper Fig. 6 impulses, agreement, ...)."""
        res = self.result
        info: dict[str, Any] = {
            "linear_impulse": 0.0 if res is None else res.linear_impulse,
            "angular_impulse": 0.0 if res is None else res.angular_impulse,
            "duration_s": 0.0 if res is None else res.duration,
            "graph_agrees": True if res is None else res.graph_agrees,
            "settled": True if res is None else res.settled,
            "human_action_inferred": self.observed_human,
            "episode_linear_impulse": float(self.totals[0]),
            "episode_angular_impulse": float(self.totals[1]),
            "episode_duration_s": float(self.totals[2]),
            "episode_graph_agrees": float(self.totals[3]) / max(self.steps, 1),
        }
        if self.fault is not None:
            info["truncation_reason"] = self.fault
        return info

    def render(self) -> np.ndarray:
        """An RGB picture of the simulation."""
        if self._renderer is None:
            self._renderer = SceneRenderer(self.sim.model, self.sim.seats.pos)
        self._renderer.aim(self.sim.seats.pos)
        return self._renderer.render(self.sim.data)

    def flush_video(self) -> None:
        """Write the recorded episode, if any."""
        if self.video_path is not None and len(self.frames) > 1:
            path = self.video_path.format(episode=self.episode_count)
            write_video(self.frames, path, self.video_fps)
        self.frames = []

    def close(self) -> None:
        """Write a pending video and release the renderer."""
        self.flush_video()
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
