"""The physics backend inside the environments: an :class:`Episode` whose transitions are
simulated on the Panda instead of looked up in the graph.

Start, intention, turning back, termination, the reward and the step counter are the
shared episode rules (:mod:`hri_envs.task.episode`, applied by
:class:`~hri_envs.envs.episode.Episode`); this class only overrides the backend hooks. The
transition is :meth:`PandaSim.step`; the reward is judged on the observed next state and
the simulated human's true action; the robot observes the *inferred* human action. A
fault is reported in :attr:`fault`; the envs then truncate the episode. A physical failure
(:data:`~hri_envs.physics.panda.steps.PHYSICAL_FAULTS`: the object dropped, a grasp failed, it was
pulled out of the grip or ended off every state) earns that step the graph's penalty r⁻.
"""

from __future__ import annotations

import time
from typing import Any, ClassVar

import numpy as np

from hri_envs.envs.episode import Episode
from hri_envs.envs.window import check_display
from hri_envs.errors import DisplayUnavailableError
from hri_envs.physics.panda.options import prepare_video_path
from hri_envs.physics.panda.sim import PHYSICAL_FAULTS, PandaSim, StepResult
from hri_envs.physics.scene.camera import check_camera
from hri_envs.physics.scene.ik import IKFailure
from hri_envs.physics.scene.rendering import SceneRenderer, write_video
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import EpisodeRules
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import episode_geometry

__all__ = ["STEP_FIGURES", "STEP_MEANS", "PhysicsEpisode", "step_figures"]


#: The physical figures of a step, summed over an episode (``step_means``: averaged per
#: step instead); the physics' ``info`` and the benchmark's extras (PhysicsBatch) share them.
STEP_FIGURES: tuple[str, ...] = ("linear_impulse", "angular_impulse", "linear_impulse_true",
                                 "angular_impulse_true", "duration_s", "graph_agrees",
                                 "inference_accuracy", "hold_accuracy", "physical_fault")
STEP_MEANS: tuple[str, ...] = ("graph_agrees", "inference_accuracy", "hold_accuracy")


def step_figures(res: StepResult, human_true: int) -> dict[str, float]:
    """One step's figures, keyed as :data:`STEP_FIGURES`.

    Impulses [N s, N m s] are the human's wrench integrated over the step, as the wrist
    sensor sees it and (``_true``) as it was; ``graph_agrees``, ``inference_accuracy``,
    ``hold_accuracy`` and ``physical_fault`` are 0/1: the observed next state is the graph's
    prediction, the inferred human action is ``human_true``, the handle's touch sensor told
    the robot rightly whether the human holds, the step ended in a physical failure.
    """
    return {"linear_impulse": res.linear_impulse, "angular_impulse": res.angular_impulse,
            "linear_impulse_true": res.linear_impulse_true,
            "angular_impulse_true": res.angular_impulse_true, "duration_s": res.duration,
            "graph_agrees": float(res.graph_agrees),
            "inference_accuracy": float(res.human_action == human_true),
            "hold_accuracy": float(res.human_holds_sensed == res.human_holds),
            "physical_fault": float(res.fault_kind in PHYSICAL_FAULTS)}


class PhysicsEpisode(Episode):
    """One running episode on the simulated Panda (the ``"mujoco"`` backend).

    Args:
        rules: The scenario's episode rules.
        turn_state: Where a turning-back human turns (see :class:`Episode`).
        video_path: If set, each episode is recorded and written there when it ends (a
            ``{episode}`` field in the path is filled with the episode count); ``.gif``,
            or a video suffix of imageio-ffmpeg (:data:`~hri_envs.physics.panda.options.
            VIDEO_SUFFIXES`). Its folder is created and checked for writing here, before
            anything is simulated.
        video_fps: Frames per simulated second in the video (rounded to a whole number of
            control periods, and written at that rate so that the video plays in real time).
        camera: The pictures' camera (a view name or a mapping of the free camera's
            numbers, :func:`~hri_envs.physics.scene.camera.check_camera`; fitted to each episode's
            start); the supports are labelled by name.
        **options: The other ``physics`` options (``preset``, ``randomize`` and the
            parameters of :mod:`hri_envs.physics.panda.options`), validated by the env.

    Attributes:
        sim: The simulation.
        result: The last step's :class:`StepResult` (None after a reset).
        totals: The episode's :func:`step_figures`, summed.
    """

    name: ClassVar[str] = "mujoco"

    def __init__(self, rules: EpisodeRules, turn_state: np.ndarray | None,
                 video_path: str | None = None, video_fps: float = 10.0,
                 camera: Any = None, **options: Any) -> None:
        if video_path is not None:  # before anything is simulated
            video_path = prepare_video_path(video_path)
        self.sim = self.make_sim(rules.graph, options)
        self._observed_human = WAIT
        self.result: StepResult | None = None
        self._fault: str | None = None
        self.totals = dict.fromkeys(STEP_FIGURES, 0.0)
        self.video_path, self.video_fps = video_path, video_fps
        self._frame_fps = video_fps  # the rate frames are recorded at (set per episode)
        self.frames: list[np.ndarray] = []
        self.episode_count = 0
        self._renderer: SceneRenderer | None = None
        self.camera, self._aimed = check_camera(camera, field="physics"), False
        self._viewer: Any = None
        super().__init__(rules, turn_state)

    @classmethod
    def make_sim(cls, graph: TaskGraph, options: dict[str, Any]) -> Any:
        """The simulation of one episode (here MuJoCo's C library, :class:`PandaSim`; another
        backend returns an object with its ``reset``, ``step``, ``model``, ``data``, ``seats``,
        ``dt_control``, ``control_every``, ``frame_every`` and ``on_frame``).
        """
        return PandaSim(graph, options=options)

    @property
    def observed_human(self) -> int:
        """The human's last action as the robot inferred it from the motion."""
        return self._observed_human

    @property
    def fault(self) -> str | None:
        """Why the simulation cannot go on, or None."""
        return self._fault

    def place(self, layout: tuple[tuple[float, float], ...] | None,
              rng: np.random.Generator) -> None:
        """Set the physics to the episode's start (after :meth:`draw`)."""
        self.flush_video()
        self._observed_human = WAIT
        self.result, self._fault = None, None
        self.totals = dict.fromkeys(STEP_FIGURES, 0.0)
        scenario = episode_geometry(self.rules.graph, layout)
        try:
            self.sim.reset(self.start, scenario, np.random.default_rng(int(rng.integers(2**63))))
        except IKFailure as exc:
            self._fault = f"ik_failure: {exc}"
        self.episode_count += 1
        self._aimed = False
        if self.video_path is not None:
            # A frame every whole number of control periods, written at the rate that
            # gives (video_fps rounded to it: 10 fps → one frame per 96 ms, 10.4 fps).
            periods = max(1, round(1.0 / (self.video_fps * self.sim.dt_control)))
            self.sim.frame_every = periods * self.sim.control_every
            self._frame_fps = 1.0 / (periods * self.sim.dt_control)
            self.sim.on_frame = lambda: self.frames.append(self.render(layout))
            self.frames.append(self.render(layout))

    def transition(self, a_r: int, a_h: int) -> int:
        """Simulate the joint action from the current state; the observed next state."""
        if self._fault is not None:  # nothing can move any more; the env truncates
            self._observed_human = WAIT
            return self.state
        res = self.sim.step(self.state, a_r, a_h)
        self.result, self._fault = res, res.fault
        self._observed_human = res.human_action
        for key, value in step_figures(res, a_h).items():
            self.totals[key] += value
        return res.state

    @property
    def failed(self) -> bool:
        """The last step ended in a physical failure (it earns r⁻, see ``step_reward``)."""
        return self.result is not None and self.result.fault_kind in PHYSICAL_FAULTS

    def step_info(self) -> dict[str, Any]:
        """Per-step physics figures for ``info`` (paper Fig. 6 impulses, agreement, ...)."""
        res, tot = self.result, self.totals
        info: dict[str, Any] = {
            "linear_impulse": 0.0 if res is None else res.linear_impulse,
            "angular_impulse": 0.0 if res is None else res.angular_impulse,
            "linear_impulse_true": 0.0 if res is None else res.linear_impulse_true,
            "angular_impulse_true": 0.0 if res is None else res.angular_impulse_true,
            "duration_s": 0.0 if res is None else res.duration,
            "graph_agrees": True if res is None else res.graph_agrees,
            "settled": True if res is None else res.settled,
            "human_action_inferred": self._observed_human,
            "human_action_true": self.last_human if res is not None else WAIT,
            "human_holds_sensed": False if res is None else res.human_holds_sensed,
            "human_holds_true": False if res is None else res.human_holds,
            "fault": None if res is None else res.fault_kind,
            **{f"episode_{key}": (value / max(self.steps, 1) if key in STEP_MEANS else value)
               for key, value in tot.items()},
        }
        if self._fault is not None:
            info["truncation_reason"] = self._fault
        return info

    def render(self, layout: tuple[tuple[float, float], ...] | None = None) -> np.ndarray:
        """An RGB picture of the simulation (the supports are where the physics has them,
        labelled; the camera fitted to the episode's start, :class:`SceneRenderer`).
        """
        if self._renderer is None:
            self._renderer = SceneRenderer(self.sim.model, self.sim.seats.pos,
                                           camera=self.camera,
                                           names=self.rules.graph.support_names)
        if not self._aimed:  # the camera is fitted to the episode's start
            self._renderer.aim(self.sim.data, self.sim.seats.pos)
            self._aimed = True
        return self._renderer.render(self.sim.data)

    def flush_video(self) -> None:
        """Write the recorded episode, if any."""
        if self.video_path is not None and len(self.frames) > 1:
            path = self.video_path.format(episode=self.episode_count)
            write_video(self.frames, path, self._frame_fps)
        self.frames = []

    def show(self, layout: tuple[tuple[float, float], ...] | None, title: str,
             fps: float) -> None:
        """``render_mode="human"``: MuJoCo's passive viewer on the simulation (opened on first
        use; ``layout`` and ``fps`` are the simulation's own, ``title`` is MuJoCo's).
        """
        if self._viewer is None:
            check_display()
            try:
                import mujoco.viewer

                self._viewer = mujoco.viewer.launch_passive(
                    self.sim.model, self.sim.data, show_left_ui=False, show_right_ui=False)
            except Exception as exc:  # GLFW/OpenGL set-up errors have no common class
                raise DisplayUnavailableError(
                    f"render_mode='human' could not open MuJoCo's viewer ({exc}); use "
                    f"render_mode='rgb_array' instead", field="render_mode") from exc
        if self._viewer.is_running():
            self._viewer.sync()

    def close(self) -> None:
        """Write a pending video and release the renderer and the viewer."""
        self.flush_video()
        if self._viewer is not None:
            self._viewer.close()
            for _ in range(100):  # the viewer's thread ends asynchronously; wait up to 2 s
                if not self._viewer.is_running():
                    break
                time.sleep(0.02)
            self._viewer = None
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
