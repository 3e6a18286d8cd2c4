"""One running episode with scalar state: the graph backend, and the base of every backend.

The single-episode envs (:class:`~hri_envs.envs.parallel.CooperationParallelEnv`,
:class:`~hri_envs.envs.robot.RobotEnv`) hold one :class:`Episode` and never ask which
backend it is: a backend overrides :meth:`Episode.transition` (where the joint action takes
the object) and, where it has something to add, the do-nothing hooks :meth:`~Episode.place`,
:meth:`~Episode.step_info`, :attr:`~Episode.observed_human`, :attr:`~Episode.fault`,
:meth:`~Episode.render` and :meth:`~Episode.close`. The rules themselves (start state,
lifting, turning back, end, reward) are those of :mod:`hri_envs.task.episode`; backends are
looked up by name in :mod:`hri_envs.envs.backends`.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import numpy as np

from hri_envs.envs.render import render_rgb
from hri_envs.envs.window import FrameWindow
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import (
    EpisodeRules,
    draw_other_support,
    draw_start_intention,
    start_state,
)
from hri_envs.task.scenarios import episode_geometry

__all__ = ["Episode", "EpisodeRules", "Transition", "draw_other_support",
           "draw_start_intention"]


class Transition(NamedTuple):
    """The outcome of one joint step of an :class:`Episode`."""

    reward: float
    aborted: bool
    terminated: bool
    robot_invalid: bool
    human_invalid: bool


class Episode:
    """One running episode on the abstract transition graph (the ``"graph"`` backend).

    Args:
        rules: The scenario's :class:`~hri_envs.task.episode.EpisodeRules`.
        turn_state: (K, K) int, where a turning-back human switches ι to the start support
            (-1 = never), see :attr:`hri_envs.humans.scripted.ScriptedHuman.turn_state`; None
            for a human who never turns back.

    Attributes:
        state, previous: The current and the previous abstract state.
        start, intention: The start support and the human's current goal ι.
        turn_back: The human is still going to turn back in this episode.
        lifted: The object has left the start support.
        steps: Steps taken.
        last_human, last_robot: The agents' last actions (wait after a reset).
    """

    #: The name the backend is registered under.
    name: ClassVar[str] = "graph"

    def __init__(self, rules: EpisodeRules, turn_state: np.ndarray | None) -> None:
        self.rules = rules
        if turn_state is None:
            turn_state = np.full((rules.n_supports,) * 2, -1)
        self._turn: list[list[int]] = np.asarray(turn_state, dtype=np.int64).tolist()
        self._window: FrameWindow | None = None
        self._dims = (rules.n_states, rules.n_actions)
        # start_state of each support, as ints (begin is on the reset path of every env).
        self._state0: list[int] = start_state(rules.graph, np.arange(rules.n_supports)).tolist()
        # On the graph itself (neither transition nor failed overridden) a step's outcome
        # depends on (start, lifted, state, a_R, a_H) only: each is judged once, on first
        # use, and looked up afterwards (see advance).
        cls = type(self)
        self._memo: list[tuple[Transition, bool, int] | None] | None = None
        if cls.transition is Episode.transition and cls.failed is Episode.failed:
            self._memo = [None] * (rules.n_supports * 2 * rules.n_states * rules.n_actions ** 2)
        self.begin(0, 1 % rules.n_supports, False)

    def set_turn_state(self, turn_state: np.ndarray) -> None:
        """Change where a turning-back human turns (a new human drawn at reset)."""
        self._turn = np.asarray(turn_state, dtype=np.int64).tolist()

    # ----------------------------------------------------------------- the rules
    def begin(self, start: int, intention: int, turn_back: bool) -> None:
        """Start a new episode on support ``start`` with μ = 0."""
        self.start, self.intention, self.turn_back = start, intention, turn_back
        self.state = self.previous = self._state0[start]
        self.lifted = False
        self.steps = 0
        self.last_human = self.last_robot = WAIT

    def draw(
        self,
        rng: np.random.Generator,
        start: int | None = None,
        intention: int | None = None,
        turn_back: bool | None = None,
        turn_back_p: float = 0.0,
    ) -> None:
        """Start a new episode, drawing what is not given from ``rng``.

        Args:
            rng: The env's generator.
            start: The start support (default: uniform).
            intention: ι (default: uniform among the supports other than the start).
            turn_back: Whether the human turns back (default: drawn with ``turn_back_p``).
            turn_back_p: Probability of turning back when ``turn_back`` is None.
        """
        n_k = self.rules.n_supports
        if start is None:
            if intention is None:
                s, i = draw_start_intention(rng, n_k)
                start, intention = int(s), int(i)
            else:
                start = int(draw_other_support(rng, n_k, intention))
        elif intention is None:
            intention = int(draw_other_support(rng, n_k, start))
        if turn_back is None:
            turn_back = bool(turn_back_p > 0.0 and rng.random() < turn_back_p)
        self.begin(start, intention, turn_back)

    def advance(self, a_r: int, a_h: int) -> Transition:
        """Apply the joint action (already checked to lie in the action space)."""
        memo = self._memo
        if memo is None:  # a backend that simulates: judge the outcome it reports
            s_next = self.transition(a_r, a_h)
            t, lifted = self._judge(a_r, a_h, s_next, self.failed)
        else:  # the graph: look the step up, judging it the first time it is taken
            n_s, n_a = self._dims
            j = (((self.start * 2 + self.lifted) * n_s + self.state) * n_a + a_r) * n_a + a_h
            hit = memo[j]
            if hit is None:
                s_next = self.transition(a_r, a_h)
                hit = memo[j] = (*self._judge(a_r, a_h, s_next, False), s_next)
            t, lifted, s_next = hit
        self.previous, self.state, self.lifted = self.state, s_next, lifted
        self.steps += 1
        self.last_human, self.last_robot = a_h, a_r
        if self.turn_back and s_next == self._turn[self.start][self.intention]:
            self.intention, self.turn_back = self.start, False
        return t

    def _judge(self, a_r: int, a_h: int, s_next: int, failed: bool) -> tuple[Transition, bool]:
        """The rules' verdict on the joint action taking :attr:`state` to ``s_next`` (with a
        physical failure or not), and the lifted flag after the step.
        """
        r = self.rules
        s = self.state
        i = (s * r.n_actions + a_r) * r.n_actions + a_h
        if s_next == r.next_list[i] and not failed:  # the graph's prediction: look it up
            reward = r.reward_list[i]
            if r.rule.charge is not None:
                reward = float(r.adjust(reward, s, a_r, self.start, self.lifted, a_h, s_next))
        else:  # the backend's outcome differs from the graph's prediction
            reward = float(r.judge(s, a_r, a_h, s_next, self.start, self.lifted, failed))
        lifted = self.lifted or r.left_list[s_next * r.n_supports + self.start]
        return Transition(reward, r.aborted_list[i],
                          r.ends_list[(s_next * r.n_supports + self.start) * 2 + lifted],
                          not r.valid_list[s * r.n_actions + a_r],
                          not r.valid_list[s * r.n_actions + a_h]), lifted

    # ----------------------------------------------------------------- backend hooks
    def transition(self, a_r: int, a_h: int) -> int:
        """The state the joint action leads to from :attr:`state` (here: the graph's)."""
        r = self.rules
        return r.next_list[(self.state * r.n_actions + a_r) * r.n_actions + a_h]

    def place(self, layout: tuple[tuple[float, float], ...] | None,
              rng: np.random.Generator) -> None:
        """Set the backend to the episode's start (after :meth:`draw`) with the supports at
        ``layout`` (None: the nominal geometry); nothing to do on the graph.
        """

    @property
    def observed_human(self) -> int:
        """The human's last action as the robot observes it (here: the true one)."""
        return self.last_human

    @property
    def failed(self) -> bool:
        """The last step was a physical failure, punished with r⁻; never, here."""
        return False

    @property
    def fault(self) -> str | None:
        """Why the episode cannot go on (the envs then truncate it); never, here."""
        return None

    def step_info(self) -> dict[str, Any]:
        """Backend figures for the step's ``info`` (none here)."""
        return {}

    def render(self, layout: tuple[tuple[float, float], ...] | None) -> np.ndarray:
        """An RGB picture of the current state, the supports at ``layout``."""
        graph = self.rules.graph
        return render_rgb(episode_geometry(graph, layout), graph, self.state)

    def show(self, layout: tuple[tuple[float, float], ...] | None, title: str,
             fps: float) -> None:
        """``render_mode="human"``: show :meth:`render` in a window (opened on first use).

        Args:
            layout: The supports' layout, as for :meth:`render`.
            title: The window's title.
            fps: Frames per second of the window.
        """
        if self._window is None:
            self._window = FrameWindow(title, fps)
        self._window.show(self.render(layout))

    def close(self) -> None:
        """Release what the backend holds (the window of ``render_mode="human"``)."""
        if self._window is not None:
            self._window.close()
            self._window = None
