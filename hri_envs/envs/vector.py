"""N robot-vs-scripted-human episodes stepped at once with array operations."""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hri_envs.checks import check_whole
from hri_envs.envs.config import (
    check_autoreset_mode,
    check_env_settings,
    check_seed,
    scenario_graph,
)
from hri_envs.envs.spaces import robot_observation_space
from hri_envs.envs.vector_inputs import (
    check_robot_actions,
    check_vector_backend,
    reset_supports,
    turn_back_option,
    vector_reset_options,
)
from hri_envs.errors import ConfigError, ResetNeeded
from hri_envs.humans.protocol import BatchHuman, checked_actions
from hri_envs.humans.seat import HumanLike, seat_human
from hri_envs.humans.tables import TableHumans
from hri_envs.task.actions import WAIT
from hri_envs.task.episode import (
    EpisodeRules,
    StepTable,
    draw_other_support,
    draw_start_intention,
    revise_intention,
)
from hri_envs.task.greedy_table import GreedyStepTable

__all__ = ["RobotVectorEnv"]

#: The most envs one vector env holds (its arrays are (num_envs,) and (num_envs, A)).
MAX_NUM_ENVS = 1_000_000
_INT64 = np.dtype(np.int64)


class RobotVectorEnv(VectorEnv[dict[str, np.ndarray], np.ndarray, np.ndarray]):
    """``num_envs`` copies of :class:`~hri_envs.envs.robot.RobotEnv`, batched in numpy.

    ## Description

    The robot-vs-scripted-human task of :class:`~hri_envs.envs.robot.RobotEnv`, for N
    episodes at once. Every step is one flat index per env into a
    :class:`~hri_envs.task.episode.StepTable`, derived from the same
    :class:`~hri_envs.task.episode.EpisodeRules` the single env uses (next state, reward,
    end and next context in one look-up each), with no Python loop over episodes; a
    deterministic human that is never passive acts by one look-up too. It runs on the
    graph only: a backend that simulates (``backend="mujoco"`` or ``"mjwarp"``) is refused;
    vectorise the Panda envs with their own vector entry point
    (:class:`~hri_envs.physics.panda.warp.vector.PandaVectorEnv`, ``gymnasium.make_vec(
    "hri_envs/HangerPanda-v0", num_envs=N, vectorization_mode="vector_entry_point")``, the
    ``mjwarp`` extra) or with Gymnasium's ``vectorization_mode="async"``. Made by
    ``gymnasium.make_vec("hri_envs/Hanger-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``.

    ## Action Space

    ``MultiDiscrete([A] * N)``: one robot action per episode, numbered as in the single
    env. :meth:`action_masks` returns the (N, A) bool mask of valid actions.

    ## Observation Space

    The single env's ``Dict``, batched: ``"state"``, ``"start"``, ``"last_human_action"``
    (N,) int64 and ``"action_mask"`` (N, A) int8. ι is not observed.

    ## Rewards

    (N,) float64, the robot cooperation reward R_R; 0 in the step that autoresets an env.
    The rules, the free grasp/let-go and the ``reward="no-free-toggle"`` variant are the
    single env's (:class:`~hri_envs.envs.robot.RobotEnv`, "Rewards").

    ## Starting State

    As the single env. ``reset(options=...)`` takes ``"start"``, ``"intention"`` (a
    support index or name, or an (N,) array of them) and ``"turn_back"`` (bool or (N,)
    bools) for the episodes it starts; autoresets draw at random. The wheel's stand
    layout is not drawn: it only affects rendering, and this env does not render.

    ## Episode End

    As the single env. Autoreset is Gymnasium's next-step mode by default
    (``metadata["autoreset_mode"] = AutoresetMode.NEXT_STEP``): the step after an episode
    ends ignores that env's action and returns the first observation of a new episode with
    reward 0 and ``terminated = truncated = False``. With
    ``autoreset_mode=AutoresetMode.SAME_STEP`` (what stable-baselines3 expects) the step
    that ends an episode already returns the next episode's first observation, and the
    final one is in ``infos["final_obs"]`` (an object array of per-env dicts, masked by
    ``infos["_final_obs"]``). Infos are ``"aborted"`` and ``"invalid_action"``, (N,) bool,
    with Gymnasium's ``"_aborted"`` and ``"_invalid_action"`` masks.

    ## Arguments

    - ``num_envs``: number of episodes N stepped together;
    - ``scenario``, ``r0``, ``max_cycles``, ``backend``, ``reward``: as for
      :class:`~hri_envs.envs.robot.RobotEnv`;
    - ``human``: a :class:`~hri_envs.humans.spec.HumanSpec` (a scripted human every env
      shares, or a population, split or family: each env draws a new member at every
      (auto)reset with the env's ``np_random``), or its shorthand keywords as for
      :class:`~hri_envs.envs.robot.RobotEnv` (``preference``, ``human_passive``,
      ``turn_back``, ``human_rationality``, ``population``, ``human_params``; a spec's
      ``body`` is refused: the env runs the graph); or a
      :class:`~hri_envs.humans.scripted.ScriptedHuman` shared by every env, or a
      :class:`~hri_envs.humans.protocol.BatchHuman` with ``num_envs`` rows (one human per
      env, which may keep state across steps and episodes: the env calls its
      ``begin_episode``, ``observe`` and ``end_episode`` for each env's episodes);
    - ``render_mode``: must be None;
    - ``autoreset_mode``: ``AutoresetMode.NEXT_STEP`` (default) or ``SAME_STEP`` (or their
      string values).

    ``reset(seed=...)`` takes one int (or None) for the whole batch; the scripted humans
    draw from a generator seeded from it. So a seed gives other episodes here than
    ``gymnasium.make_vec(..., vectorization_mode="sync")``, which seeds env *i* with
    ``seed + i`` (each mode reproduces itself exactly).

    ## Version History

    - v0: initial version.
    """

    metadata: dict[str, Any] = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        scenario: str = "hanger",
        *,
        human: HumanLike | None = None,
        r0: float | None = None,
        max_cycles: int = 100,
        render_mode: str | None = None,
        backend: str = "graph",
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        reward: str = "paper",
        **human_keywords: Any,
    ) -> None:
        mode = check_autoreset_mode(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": mode}
        self._same_step = mode == AutoresetMode.SAME_STEP
        self.num_envs = check_whole(num_envs, "num_envs", minimum=1, maximum=MAX_NUM_ENVS)
        self._shape = (self.num_envs,)
        (self.scenario_name, self.r0, self.max_cycles, self.render_mode,
         self.backend) = check_env_settings(scenario, r0, max_cycles, render_mode,
                                            self.metadata["render_modes"], backend)

        check_vector_backend(self.backend)
        self.graph = scenario_graph(scenario)
        self._human = seat_human(self.graph, human=human, n_runs=self.num_envs,
                                 env="the numpy vector env", **human_keywords)
        self.rules = EpisodeRules(self.graph, self.r0, reward)
        n_s, n_k, n_a = self.graph.n_states, self.graph.n_intentions, self.graph.n_actions
        self.single_observation_space = robot_observation_space(n_s, n_k, n_a)
        self.single_action_space = spaces.Discrete(n_a)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        n = self.num_envs
        self._steps = StepTable(self.rules)
        # The table stepped with: the step table, or a GreedyStepTable for a human who acts
        # by one look-up (see _adopt).
        self._table: StepTable | GreedyStepTable = self._steps
        self._n_supports, self._n_actions = n_k, n_a
        # Per env (N,): the current episode's state, start, ι, the flat index of its context
        # (self._table.key: state, start, lifted), ι's offset in a GreedyStepTable index
        # (ι A), the state where the human turns back (-1: not in this episode), the step
        # (of _t) that truncates it and the human's last action. Once handed out in an
        # observation, the arrays of state and last action are replaced, never written.
        self._state = np.zeros(n, dtype=np.int64)
        self._start = np.zeros(n, dtype=np.int64)
        self._intention = np.ones(n, dtype=np.int64) % n_k
        self._key = np.zeros(n, dtype=np.int64)
        self._goal_key = np.zeros(n, dtype=np.int64)
        self._turn_at = np.full(n, -1, dtype=np.int64)
        self._deadline = np.zeros(n, dtype=np.int64)
        self._last_human = np.zeros(n, dtype=np.int64)
        self._turning = False  # some env's human may still turn back
        self._t = 0  # steps since reset()
        self._due = 0  # no env reaches its deadline (of _t) before this step
        self._ended = np.zeros(0, dtype=np.int64)  # envs whose episode ended in the last step
        self._all = np.ones(n, dtype=bool)
        self._greedy: GreedyStepTable | None = None
        self._adopted: BatchHuman | None = None
        self._adopt(self._human)
        self._needs_reset = True

    # ----------------------------------------------------------------- helpers
    @property
    def human(self) -> BatchHuman:
        """The humans in the seats (a :class:`~hri_envs.humans.protocol.BatchHuman` with a row
        per env); assign a ``ScriptedHuman`` or a ``BatchHuman`` to replace them.
        """
        return self._human

    @human.setter
    def human(self, human: HumanLike) -> None:
        self._human = seat_human(self.graph, human=human, n_runs=self.num_envs)

    def action_masks(self) -> np.ndarray:
        """(N, A) bool, each env's valid actions in its current state."""
        return self.graph.valid.take(self._state, axis=0)

    @property
    def intention(self) -> np.ndarray:
        """(N,) int, the humans' current goals ι (hidden from the observations)."""
        return self._intention.copy()

    def _observations(self) -> dict[str, np.ndarray]:
        state = self._state
        return {
            "state": state.copy(),
            "start": self._start.copy(),
            "last_human_action": self._last_human.copy(),
            "action_mask": self.rules.action_mask.take(state, axis=0),
        }

    def _draw_turn(self, rows: np.ndarray | slice) -> np.ndarray | None:
        """Whether the new episodes of ``rows`` turn back (None: no human of them can)."""
        p: float | np.ndarray | None = self._shared_turn_back
        if p is None:  # each env's own human
            p = self._human.turn_back[rows]
            if not (p > 0.0).any():
                return None
            return self.np_random.random(p.size) < p
        if p <= 0.0:
            return None
        n = self.num_envs if isinstance(rows, slice) else rows.size
        return self.np_random.random(n) < p

    def _adopt(self, human: BatchHuman) -> None:
        """Act with ``human`` from now on (also when :attr:`human` was replaced).

        One scripted human shared by every env that neither samples nor waits at random
        acts by a fixed (start, ι, state) table of preferred actions (the draws of its
        generator would be unused), which is folded into the step table
        (:class:`~hri_envs.task.greedy_table.GreedyStepTable`). Any other human acts through
        the human protocol, and the plain step table is used.
        """
        self._adopted = human
        old = self._table
        self._greedy = None
        self._table = self._steps
        shared = human.shared if isinstance(human, TableHumans) else None
        # One model for every env: its turning-back probability, read once.
        self._shared_turn_back = None if shared is None else shared.turn_back
        if shared is not None and shared.deterministic and shared.passive == 0.0:
            n_k, n_s = self._n_supports, self.graph.n_states
            grid = np.indices((n_k, n_k, n_s))  # (start, goal, state)
            actions = np.asarray(shared.preferred_action(grid[2], grid[0], grid[1]),
                                 dtype=np.int64)
            self._greedy = self._table = GreedyStepTable(self._steps, actions)
            self._goal_key[:] = self._intention * self._greedy.goal_stride
        if self._table.stride != old.stride:  # the running contexts, in the new table's index
            self._key = self._key // old.stride * self._table.stride

    def _begin(self, rows: np.ndarray | slice, start: np.ndarray, intention: np.ndarray,
               turn: np.ndarray | None, waited: bool = False) -> None:
        """Start new episodes in ``rows``: the rules' start context, a step limit counted from
        now, the human waited; ``turn`` says whether each one's human turns back (None: none).
        ``waited``: the last action recorded for these rows is already a wait.
        """
        table = self._table
        self._start[rows] = start
        self._intention[rows] = intention
        self._state[rows] = table.state0.take(start)
        self._key[rows] = table.key0.take(start)
        self._deadline[rows] = self._t + self.max_cycles
        if not waited:
            self._last_human[rows] = WAIT
        if self._greedy is not None:
            self._goal_key[rows] = intention * self._greedy.goal_stride
        if turn is not None and (self._turning or turn.any()):
            self._turning = True
            where = self._human.turn_state
            if where is None:
                where = np.full((self._n_supports,) * 2, -1)
            turn_at = (where[start, intention] if where.ndim == 2
                       else where[np.arange(self.num_envs)[rows], start, intention])
            self._turn_at[rows] = np.where(turn, turn_at, -1)
        elif self._turning:
            self._turn_at[rows] = -1
        self._human.begin_episode(start, intention, None if isinstance(rows, slice) else rows)

    # ----------------------------------------------------------------- API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start N new episodes; see the class docstring for ``options``."""
        options = vector_reset_options(options)
        super().reset(seed=check_seed(seed, "this batched env"))
        human = self._human
        if human is not self._adopted:  # replaced since the last step
            self._adopt(human)
        rng = self.np_random
        human.draw(rng)  # a population's new members, drawn first
        human.seed(np.random.default_rng(int(rng.integers(2**63))))
        n, n_k = self.num_envs, self.graph.n_intentions
        scenario = self.graph.scenario
        start = (reset_supports(options["start"], "start", scenario, n)
                 if "start" in options else None)
        intention = (reset_supports(options["intention"], "intention", scenario, n)
                     if "intention" in options else None)
        if start is None:
            if intention is None:
                start, intention = draw_start_intention(rng, n_k, n)
            else:
                start = draw_other_support(rng, n_k, intention, size=n)
        elif intention is None:
            intention = draw_other_support(rng, n_k, start, size=n)
        if np.any(start == intention):
            raise ConfigError("the intention must differ from the start support in every env",
                              field="intention")
        turn: np.ndarray | None
        if "turn_back" in options:
            turn = turn_back_option(options["turn_back"], n)
        else:
            turn = self._draw_turn(slice(None))
        self._turning = False
        self._turn_at[:] = -1
        self._t = 0
        # Fresh arrays: the last step's observation may hold the old ones (see __init__).
        self._state = np.empty(n, dtype=np.int64)
        self._last_human = np.empty(n, dtype=np.int64)
        self._due = self.max_cycles
        self._begin(slice(None), start, intention, turn)
        self._ended = self._ended[:0]
        self._needs_reset = False
        return self._observations(), {}

    def step(
        self, actions: Any
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every env with the robots' actions (N,); the scripted humans act too.

        One flat index per env into the :class:`~hri_envs.task.episode.StepTable` (or, for a
        human who acts by a table, the :class:`~hri_envs.task.greedy_table.GreedyStepTable`)
        gives the next state, the reward, the end and the next context; only the envs that
        start a new episode (and, with turning back, those whose human turns) are touched
        one by one.
        """
        if self._needs_reset:
            raise ResetNeeded("call reset() before step()")
        a_r = actions  # the usual int64 (N,) array needs only the range check
        if (type(a_r) is not np.ndarray or a_r.dtype is not _INT64 or a_r.shape != self._shape
                or a_r.view(np.uint64).max() >= self._n_actions):
            a_r = check_robot_actions(a_r, self.num_envs, self._n_actions)
        self._t = t = self._t + 1
        human = self._human
        if human is not self._adopted:
            self._adopt(human)
        table = self._table
        # Envs whose episode has ended sit in the table's "over" context.
        if self._greedy is not None:
            j = self._key + self._goal_key
            j += a_r
            a_h = self._greedy.human_action.take(j)
            fresh_human = True  # a_h is this step's own array
        else:
            state = self._state
            playing = self._key != table.over  # not waiting for a next-step autoreset
            a_h = checked_actions(human.act({
                "state": state, "start": self._start, "intention": self._intention,
                "last_human_action": self._last_human,
                "action_mask": self.rules.action_mask.take(state, axis=0), "robot_action": a_r},
                playing), self.num_envs, self._n_actions, "the humans")
            j = a_r * self._n_actions
            j += self._key
            j += a_h
            fresh_human = False
        self._state = s_next = table.next_state.take(j)
        self._key = table.next_key.take(j)
        self._last_human = a_h
        reward = table.reward.take(j)
        terminated = table.terminated.take(j)
        aborted = table.aborted.take(j)
        invalid = table.robot_invalid.take(j)
        if self._turning:
            self._turn_back(s_next)
        if self._greedy is None:
            self._observe(state, a_r, a_h, s_next, playing, terminated)
        infos: dict[str, Any] = {"aborted": aborted, "_aborted": self._all,
                                 "invalid_action": invalid, "_invalid_action": self._all}
        if self._same_step:
            truncated = self._end_same_step(t, terminated, infos)
            return self._observations(), reward, terminated, truncated, infos
        # Next-step autoreset: the envs that ended in the previous step stepped in the "over"
        # context (reward 0, nothing ended, aborted or invalid) and start afresh now.
        # In that context a GreedyStepTable's human waits, and a step that ends an episode
        # leads to it; the step table needs both done here.
        which = self._ended
        if which.size:
            self._restart(which, waited=fresh_human)
        if t < self._due:  # no deadline falls in this step
            truncated = np.zeros(self.num_envs, dtype=bool)
            self._ended = ended = terminated.nonzero()[0]
            if ended.size and not fresh_human:
                self._key[ended] = table.over
                human.end_episode(ended)
        else:
            truncated = self._truncated(t, terminated)
            self._ended = ended = (terminated | truncated).nonzero()[0]
            if ended.size:
                self._key[ended] = table.over
                if not fresh_human:
                    human.end_episode(ended)
        # The state and (from the table) the human's action are this step's own arrays and
        # are never written again (see __init__), so they are handed out without a copy.
        last = self._last_human
        obs: dict[str, np.ndarray] = {
            "state": s_next, "start": self._start.copy(),
            "last_human_action": last if fresh_human else last.copy(),
            "action_mask": self.rules.action_mask.take(s_next, axis=0)}
        return obs, reward, terminated, truncated, infos

    def _turn_back(self, s_next: np.ndarray) -> None:
        """ι becomes the start support in the envs whose human enters its turning state."""
        back = (s_next == self._turn_at).nonzero()[0]
        if back.size:
            self._intention[back] = start = self._start[back]
            self._turn_at[back] = -1
            if self._greedy is not None:
                self._goal_key[back] = start * self._greedy.goal_stride

    def _observe(self, state: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
                 s_next: np.ndarray, playing: np.ndarray, terminated: np.ndarray) -> None:
        """Show the humans (who do not act by a table) the step; take their revised
        intentions in the envs still playing.
        """
        human = self._human
        human.observe(state, a_r, a_h, s_next, playing)
        revised = human.revised_intentions()  # humans who changed their minds
        if revised is not None:  # in place: (N,) int64, as the turning back
            self._intention[:] = revise_intention(
                self._intention, np.where(playing & ~terminated, revised, -1))

    def _end_same_step(self, t: int, terminated: np.ndarray, infos: dict[str, Any]
                       ) -> np.ndarray:
        """Same-step autoreset: the envs that end restart at once, their last observation in
        ``infos["final_obs"]``; returns ``truncated``.
        """
        truncated = self._truncated(t, terminated)
        ended = terminated | truncated
        if ended.any():
            which = ended.nonzero()[0]
            self._human.end_episode(which)
            final = self._observations()
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in which:
                final_obs[i] = {k: v[i] for k, v in final.items()}
            infos["final_obs"], infos["_final_obs"] = final_obs, ended
            self._restart(which)
        return truncated

    def _truncated(self, t: int, terminated: np.ndarray) -> np.ndarray:
        """(N,) bool: the envs that reach the step limit in step ``t`` without terminating."""
        if t < self._due:  # no deadline falls in this step
            return np.zeros(self.num_envs, dtype=bool)
        deadline = self._deadline
        truncated = deadline == t
        np.greater(truncated, terminated, out=truncated)  # truncated and not terminated
        # Envs at their deadline start again with a later one; the others keep theirs.
        self._due = int(deadline[deadline > t].min(initial=t + self.max_cycles))
        return truncated

    def _restart(self, which: np.ndarray, waited: bool = False) -> None:
        """New random episodes in the envs ``which`` (autoreset); ``waited`` as for _begin."""
        self._human.draw(self.np_random, which)  # a population's new members
        start, intention = draw_start_intention(self.np_random, self._n_supports,
                                                np.array(which.size))
        self._begin(which, start, intention, self._draw_turn(which), waited)

    def close_extras(self, **kwargs: Any) -> None:
        """Nothing to release."""
