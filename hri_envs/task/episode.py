"""The rules of an episode, written once for every consumer (docs/task-model.md, "Episode").

Every environment (the single-episode envs, the batched vector env), the benchmark's
simulation loop, ``hri-bench play`` and the physics backend apply these functions; none of
them re-derives a rule. The functions take the task graph and numpy arrays (or ints) that
broadcast, so the same code serves one episode and thousands.

* Start: the object rests on the start support with μ = 0 (:func:`start_state`); the
  intention ι differs from the start (:func:`draw_start_intention`).
* Lifted: once the object has left the start support (:func:`left_start`), resting on the
  start again counts as arriving: the human turned back.
* Turning back: in an episode where the human turns back, on entering the state
  ``turn_state[start, ι]`` the intention becomes the start support (:func:`turn_back`).
* A change of mind: a human may report a new intention after any step (an inconsistent
  human, :meth:`hri_envs.humans.protocol.BatchHuman.revised_intentions`); it holds from the
  next step on (:func:`revise_intention`).
* End: the object rests with μ = 0 on a support other than the start, or on the start once
  lifted (:func:`episode_over`).
* Reward and decisions: :func:`step_reward` and :func:`classify` judge a step from the state
  the object actually reached, so a physics backend whose outcome differs from the graph's
  prediction is judged by the same rules. On the graph's own transitions they give
  :meth:`TaskGraph.reward` and :attr:`TaskGraph.robot_effective`, which are built from them.

:class:`EpisodeRules` caches the rules on the graph's own transitions as flat lookup tables
(for the hot loops of the envs); :class:`EpisodeBatch` keeps the bookkeeping of N running
episodes (state, start, intention, lifted, steps) for the benchmark; :class:`StepTable`
fuses the tables of :class:`EpisodeRules` into one look-up per step (the vector env).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.registry import Registry
from hri_envs.task.actions import ROBOT_BIT, TAKE_OFF, TOGGLE, WAIT

if TYPE_CHECKING:
    from hri_envs.task.graph import TaskGraph

__all__ = [
    "REWARD_RULES",
    "Decisions",
    "EpisodeBatch",
    "EpisodeRules",
    "StepTable",
    "arrived",
    "charge_unneeded_toggles",
    "classify",
    "draw_other_support",
    "draw_start_intention",
    "episode_over",
    "goal_reward",
    "left_start",
    "reached_intention",
    "register_reward_rule",
    "reward_rule",
    "RewardRule",
    "RewardStep",
    "revise_intention",
    "robot_correct",
    "start_state",
    "step_penalty",
    "step_reward",
    "turn_back",
    "unneeded_toggle",
    "verify_reward_rule",
]

IntArray = np.ndarray | int


# --------------------------------------------------------------------------- reward rules
class RewardStep(NamedTuple):
    """What a :class:`RewardRule` judges: one step (or a batch of them, arrays broadcast).

    Attributes:
        graph: The task graph.
        s, a_r, a_h, s_next: The state, both actions and the state the object reached.
        r0: The waiting reward.
        start: The episode's start support.
        lifted: Whether the object had left the start before the step.
        paper: The paper rule's reward of the step (:func:`step_reward` with "paper").
    """

    graph: Any
    s: Any
    a_r: Any
    a_h: Any
    s_next: Any
    r0: float
    start: Any
    lifted: Any
    paper: np.ndarray


@dataclass(frozen=True)
class RewardRule:
    """A reward rule: the paper's robot cooperation reward, possibly charged further.

    Every path that charges a step (the envs, the vector env's fused table, the JAX env's
    tables, the benchmark's loop, the exact references) applies the same object: it takes
    the paper rule's reward of a step and its context (:class:`RewardStep`) and returns the
    rule's. docs/extending.md, "A reward rule", walks through adding one.

    Attributes:
        name: Registry key (``--reward NAME``, ``reward=NAME``).
        description: One line for help texts and docs.
        charge: ``charge(step) -> reward`` (arrays broadcast, every value in [-1, 0]), or
            None: the paper rule as it is.
    """

    name: str
    description: str
    charge: Callable[[RewardStep], np.ndarray] | None = None

    def apply(self, step: RewardStep) -> np.ndarray:
        """The rule's reward of ``step`` (the paper's where it charges nothing)."""
        return step.paper if self.charge is None else np.asarray(self.charge(step), float)


#: The reward rules, by name (:func:`register_reward_rule`; a
#: :class:`~hri_envs.registry.Registry`).
REWARD_RULES: Registry[RewardRule] = Registry("reward", RewardRule, field="reward")


def register_reward_rule(rule: RewardRule, *, replace: bool = False) -> RewardRule:
    """Make ``rule`` known to the envs and ``hri-bench`` (``--reward``); returns it.

    Whether it charges a step within [-1, 0] and like the paper rule where nothing differs is
    :func:`hri_envs.conformance.check_reward_rule`'s to check.

    Args:
        rule: The rule.
        replace: Replace the rule registered under its name (otherwise refused).

    Raises:
        ConfigError: ``rule`` is not a :class:`RewardRule` or has an empty name, or its name
            is another rule's and ``replace`` is False.
    """
    if not isinstance(rule, RewardRule) or not (isinstance(rule.name, str) and rule.name):
        raise ConfigError(f"register_reward_rule takes a RewardRule with a name, got {rule!r}",
                          field="reward")
    _checked(rule)
    return REWARD_RULES.register(rule, replace=replace)


#: Rules that passed :func:`verify_reward_rule` on every registered scenario (or are being
#: checked: the check builds the envs' tables, which ask for the rule again).
_VERIFIED: dict[int, RewardRule] = {}


def _checked(rule: RewardRule) -> RewardRule:
    """``rule`` once :func:`verify_reward_rule` passed on the registered scenarios (once
    per rule object; the built-in rules are the package's own and not checked).
    """
    if rule.charge is None or _VERIFIED.get(id(rule)) is rule:
        return rule
    from hri_envs.task.scenarios import SCENARIOS, graph_of  # noqa: PLC0415  (they use us)

    _VERIFIED[id(rule)] = rule
    try:
        for spec in SCENARIOS.values():
            _verify(rule, graph_of(spec))
    except BaseException:
        del _VERIFIED[id(rule)]
        raise
    return rule


def verify_reward_rule(rule: RewardRule, graph: TaskGraph) -> None:
    """Check ``rule`` on every (state, robot action, human action, start, lifted) of
    ``graph``: rewards of the steps' shape, finite, in [-1, 0], the same on the
    envs' fused table (:class:`StepTable`) as by :func:`step_reward`.

    Raises:
        ConfigError: (``field="reward"``) Any of these does not hold, or the rule raised
            (its exception is named).
    """
    known = _VERIFIED.get(id(rule)) is rule
    _VERIFIED[id(rule)] = rule  # the tables built here ask for the rule again
    try:
        _verify(rule, graph)
    finally:
        if not known:
            del _VERIFIED[id(rule)]


def _verify(rule: RewardRule, graph: TaskGraph) -> None:
    n_s, n_a, n_k = graph.n_states, graph.n_actions, graph.n_intentions
    s = np.arange(n_s)[:, None, None, None, None]
    a_r = np.arange(n_a)[None, :, None, None, None]
    a_h = np.arange(n_a)[None, None, :, None, None]
    start = np.arange(n_k)[None, None, None, :, None]
    lifted = np.array([False, True])[None, None, None, None, :]
    s_next = graph.next_state[s, a_r, a_h]
    shape = (n_s, n_a, n_a, n_k, 2)
    where = f"reward rule {rule.name!r} on the {graph.name}"
    try:
        got = step_reward(graph, s, a_r, a_h, s_next, -0.3, reward=rule, start=start,
                          lifted=lifted)
    except Exception as exc:  # the rule's own code: name what it raised
        raise ConfigError(f"{where}: charge() raised {type(exc).__name__}: {exc} (it takes a "
                          "RewardStep whose arrays broadcast and returns rewards in [-1, 0])",
                          field="reward") from exc
    try:
        direct = np.broadcast_to(got, shape)
    except ValueError:
        raise ConfigError(f"{where}: charge() returned rewards of shape {got.shape}; they must "
                          f"broadcast with the step's arrays (here {shape})",
                          field="reward") from None
    if not np.all(np.isfinite(direct)) or direct.min() < -1.0 or direct.max() > 0.0:
        raise ConfigError(f"{where}: rewards must be finite and in [-1, 0], got "
                          f"[{direct.min()}, {direct.max()}]", field="reward")
    try:
        table = StepTable(EpisodeRules(graph, -0.3, rule))
        keys = table.key(np.arange(n_s)[:, None, None, None, None], start, lifted)
        fused = np.broadcast_to(table.reward[keys + (a_r * n_a + a_h)], shape)
    except Exception as exc:  # the rule on the envs' tables
        raise ConfigError(f"{where}: charge() raised {type(exc).__name__} on the envs' fused "
                          f"table: {exc}", field="reward") from exc
    if not np.array_equal(fused, direct):
        raise ConfigError(f"{where}: the envs' fused table and step_reward differ (the rule "
                          "must depend on the step and its context only)", field="reward")


def reward_rule(name: str | RewardRule) -> RewardRule:
    """The registered rule ``name``; a :class:`RewardRule` passes through once
    :func:`verify_reward_rule` passed on the registered scenarios.

    Raises:
        ConfigError: An unknown name (the message lists the registered rules), or a rule
            that fails the check (``field="reward"``).
    """
    if isinstance(name, RewardRule):
        return _checked(name)
    if not isinstance(name, str):
        raise ConfigError(f"unknown reward {name!r}; allowed: {', '.join(REWARD_RULES)}",
                          field="reward")
    return REWARD_RULES.get(name)


def __getattr__(name: str) -> Any:
    if name == "REWARDS":  # the registered rules' names, as they are now
        return tuple(REWARD_RULES)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# --------------------------------------------------------------------------- start and end
def start_state(graph: TaskGraph, start: IntArray) -> np.ndarray:
    """The state "resting on support ``start``, nobody holds it" (arrays broadcast)."""
    return np.asarray(graph.support_state(start, 0))


def draw_start_intention(
    rng: np.random.Generator, n_supports: int, size: int | np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Draw start supports and intentions ι ≠ start, uniformly (scalars when size is None).

    ``size`` may also be a 0-d int array: the same numbers, and numpy's generator reads its
    size a little faster than a Python int's (the vector env's autoresets).
    """
    start = rng.integers(n_supports, size=size)
    intention = (start + 1 + rng.integers(n_supports - 1, size=size)) % n_supports
    return start, intention


def draw_other_support(
    rng: np.random.Generator, n_supports: int, other: IntArray, size: int | None = None
) -> np.ndarray:
    """Draw a support uniformly among those different from ``other``."""
    return (np.asarray(other) + 1 + rng.integers(n_supports - 1, size=size)) % n_supports


def left_start(graph: TaskGraph, state: IntArray, start: IntArray) -> np.ndarray:
    """Whether the object is away from its start support (arrays broadcast).

    Accumulated over an episode this is the *lifted* flag: once lifted, resting on the
    start again counts as arriving (the human turned back).
    """
    return graph.support[state] != start


def episode_over(
    graph: TaskGraph, state: IntArray, start: IntArray, lifted: np.ndarray | bool
) -> np.ndarray:
    """The episode's end: resting with μ = 0 on a support other than the start, or on the
    start after the object was lifted. Arrays broadcast.
    """
    sup = graph.support[state]
    resting = (sup >= 0) & (graph.grasp[state] == 0)
    return resting & ((sup != start) | lifted)


def arrived(
    graph: TaskGraph, state: IntArray, start: IntArray, lifted: np.ndarray | bool
) -> np.ndarray:
    """Resting on a support that can end the episode (any grasp): a goal candidate."""
    sup = graph.support[state]
    return (sup >= 0) & ((sup != start) | lifted)


def turn_back(
    turn_state: np.ndarray,
    state: IntArray,
    start: IntArray,
    intention: IntArray,
    turning: np.ndarray | bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Apply turning back on entering ``state``: ``(new intention, still turning)``.

    Args:
        turn_state: (K, K) int, ``turn_state[start, ι]``, where a turning-back human switches
            ι to the start support (-1: never), see
            :attr:`hri_envs.humans.scripted.ScriptedHuman.turn_state`; or (N, K, K), one table
            per episode of a batch (a human per run).
        state: The state just entered.
        start: The episode's start support.
        intention: The current intention ι.
        turning: Whether the human is still going to turn back in this episode.
    """
    if turn_state.ndim == 3:
        where = turn_state[np.arange(turn_state.shape[0]), start, intention]
    else:
        where = turn_state[start, intention]
    back = turning & (state == where)
    return np.where(back, start, intention), turning & ~back


def revise_intention(intention: IntArray, revised: IntArray) -> np.ndarray:
    """ι after the human reported a change of mind: ``revised`` where it is >= 0 (a support),
    ``intention`` where it is -1 (no change). Arrays broadcast.
    """
    revised = np.asarray(revised)
    return np.where(revised >= 0, revised, intention)


# --------------------------------------------------------------------------- judging a step
def _motion(action: IntArray) -> np.ndarray:
    return np.asarray(action) >= TAKE_OFF


def step_penalty(
    graph: TaskGraph, s: IntArray, a_r: IntArray, a_h: IntArray, s_next: IntArray
) -> np.ndarray:
    """Steps punished with r⁻ = -1 (docs/task-model.md, "Reward"), arrays broadcast.

    A step is punished when it was aborted, when the human counteracted a robot motion with
    a different motion, or when the human waited and the object's state did not change (the
    robot left a passive partner alone). Grasping and letting go are never counteracted.
    """
    aborted = graph.aborted[s, a_r, a_h]
    counteracted = _motion(a_r) & _motion(a_h) & (np.asarray(a_r) != a_h)
    idle = (np.asarray(a_h) == WAIT) & (np.asarray(s_next) == s)
    return aborted | counteracted | idle


def unneeded_toggle(
    graph: TaskGraph, s: IntArray, a_r: IntArray, start: IntArray, lifted: np.ndarray | bool
) -> np.ndarray:
    """A robot grasp toggle that the object's next motion does not need (arrays broadcast).

    On a support that is not a goal candidate (:func:`arrived` is False: the object must still
    be taken off, which needs both hands) only *grasping* is needed; on a goal candidate
    (the object is to rest there) only *letting go* is needed. Every other robot toggle (a
    grasp at the goal, a let-go before take-off, any toggle in free space) is unneeded.
    """
    a_r = np.asarray(a_r)
    holds = (graph.grasp[s] & ROBOT_BIT) > 0
    on_support = graph.support[s] >= 0
    goal = arrived(graph, s, start, lifted)
    needed = on_support & np.where(goal, holds, ~holds)
    return (a_r == TOGGLE) & ~needed


def step_reward(
    graph: TaskGraph,
    s: IntArray,
    a_r: IntArray,
    a_h: IntArray,
    s_next: IntArray,
    r0: float,
    *,
    reward: str | RewardRule = "paper",
    start: IntArray | None = None,
    lifted: np.ndarray | bool = False,
    failed: np.ndarray | bool = False,
) -> np.ndarray:
    """The robot cooperation reward R_R(s, a_R, a_H, s') in {-1, r0, 0}, arrays broadcast.

    ``reward="paper"`` (v0): -1 for a :func:`step_penalty`, ``r0`` when the robot waited
    while the human acted, else 0. Grasping and letting go are never counteracted and cost
    nothing, so a robot can replace a wait by a pointless grasp-and-release (on the wheel,
    its graph's ``reward(-0.25)[5, 1, 1]`` and ``[6, 1, 0]`` are both 0).

    ``reward="no-free-toggle"``: as "paper", except that a robot toggle that is
    :func:`unneeded_toggle` (given the episode's ``start`` and ``lifted`` flag *before* the
    step) and not punished costs ``r0``, like waiting. Any other registered
    :class:`RewardRule` charges the paper rule's reward as it says.

    ``s_next`` is the state the object reached (the graph's prediction on the graph
    backend, the observed state on the physics backend). ``failed`` marks steps in which the
    backend reports a physical failure (the object dropped, pulled out of the grip, ...):
    they are punished with r⁻ like an aborted step.
    """
    rule = reward_rule(reward)
    penalty = step_penalty(graph, s, a_r, a_h, s_next) | failed
    passive = (np.asarray(a_r) == WAIT) & (np.asarray(a_h) != WAIT)
    out = np.where(penalty, -1.0, np.where(passive, r0, 0.0))
    if rule.charge is None:
        return out
    if start is None:
        raise ConfigError(f"reward {rule.name!r} needs the episode's start support",
                          field="start")
    return rule.apply(RewardStep(graph, s, a_r, a_h, s_next, r0, start, lifted, out))


def charge_unneeded_toggles(reward: np.ndarray | float, a_r: IntArray,
                            unneeded: np.ndarray | bool, r0: float) -> np.ndarray:
    """The "no-free-toggle" rule on rewards of the "paper" rule: an unneeded robot toggle
    (:func:`unneeded_toggle`) that was not punished (it scored 0) costs ``r0``.
    """
    costly = (np.asarray(a_r) == TOGGLE) & (np.asarray(reward) == 0.0) & unneeded
    return np.where(costly, r0, reward)


def robot_correct(
    graph: TaskGraph, s: IntArray, a_r: IntArray, a_h: IntArray, s_next: IntArray
) -> np.ndarray:
    """Whether the robot acted and got the effect it acted towards (paper Sect. 6.3).

    A grasp toggle is correct when the robot's grasp bit changed; a motion when ``s_next``
    is where the motion leads (after the human's own grasp toggle, if any). Waiting and
    aborted steps are never correct. Arrays broadcast.
    """
    a_r, a_h, s_next = np.asarray(a_r), np.asarray(a_h), np.asarray(s_next)
    acted = (a_r != WAIT) & ~graph.aborted[s, a_r, a_h]
    toggled = ((graph.grasp[s] ^ graph.grasp[s_next]) & ROBOT_BIT) > 0
    s1 = np.where(a_h == TOGGLE, graph.next_state[s, WAIT, a_h], s)
    reached = graph.next_state[s1, a_r, WAIT] == s_next
    return acted & np.where(a_r == TOGGLE, toggled, reached)


class Decisions(NamedTuple):
    """The robot's decision in a step, classified as in the paper's Sect. 6.3 (bool arrays)."""

    correct: np.ndarray
    passive: np.ndarray
    wrong: np.ndarray


def classify(
    graph: TaskGraph, s: IntArray, a_r: IntArray, a_h: IntArray, s_next: IntArray
) -> Decisions:
    """Correct (:func:`robot_correct`), passive (the robot waited) or wrong (otherwise)."""
    correct = robot_correct(graph, s, a_r, a_h, s_next)
    waited = np.asarray(a_r) == WAIT
    return Decisions(correct, waited, ~waited & ~correct)


# --------------------------------------------------------------------------- the human's goal
def reached_intention(graph: TaskGraph, state: IntArray, intention: IntArray) -> np.ndarray:
    """The object rests on the intended support ι (any grasp), arrays broadcast.

    At the end of an episode (:func:`episode_over`) this says whether the task succeeded.
    """
    return graph.support[state] == intention


def goal_reward(
    graph: TaskGraph,
    s_next: IntArray,
    intention: IntArray,
    aborted: np.ndarray | bool,
    terminated: np.ndarray | bool,
) -> np.ndarray:
    """The human's task reward (``human_reward="goal"``) in {-1, 0, +1}, arrays broadcast.

    r⁻ = -1 for an aborted step; +1 for the step that ends the episode with the object
    resting on ι (:func:`reached_intention`; after turning back, ι is the start); 0
    otherwise, also for an episode that ends on another support or is truncated.
    """
    done = np.asarray(terminated) & reached_intention(graph, s_next, intention)
    return np.where(aborted, -1.0, np.where(done, 1.0, 0.0))


# --------------------------------------------------------------------------- lookup tables
class EpisodeRules:
    """The rules on the graph's own transitions, as flat lookup tables for the hot loops.

    Args:
        graph: The task graph.
        r0: Robot reward for waiting while the human acts, in (-1, 0).
        reward: The reward variant, one of :data:`REWARD_RULES` (see :func:`step_reward`).

    Attributes:
        next_state: (S A A,) int64, ``next_state[(s A + a_R) A + a_H]``.
        reward: (S A A,) float64, :func:`step_reward` of the graph's transition.
        aborted: (S A A,) bool, the joint action was aborted.
        valid: (S A,) bool, ``valid[s A + a]``: the action is allowed in the state.
        action_mask: (S, A) int8, read-only rows of the observations' ``action_mask``.
        left: (S K,) bool, ``left[s K + start]``: :func:`left_start`.
        ends: (S K 2,) bool, ``ends[(s K + start) 2 + lifted]``: :func:`episode_over`.
    """

    def __init__(self, graph: TaskGraph, r0: float, reward: str | RewardRule = "paper"
                 ) -> None:
        self.rule = reward_rule(reward)
        self.graph = graph
        self.r0 = r0
        self.reward_rule = self.rule.name
        n_s, n_a, n_k = graph.n_states, graph.n_actions, graph.n_intentions
        self.n_states, self.n_actions, self.n_supports = n_s, n_a, n_k
        self.next_state = graph.next_state.astype(np.int64).reshape(-1)
        self.reward = graph.reward(r0).astype(np.float64).reshape(-1)
        self.aborted = graph.aborted.reshape(-1).copy()
        self.valid = graph.valid.reshape(-1).copy()
        self.action_mask = graph.valid.astype(np.int8)
        self.left = np.ascontiguousarray(
            left_start(graph, np.arange(n_s)[:, None], np.arange(n_k)[None, :])).reshape(-1)
        ends = episode_over(graph, np.arange(n_s)[:, None, None], np.arange(n_k)[None, :, None],
                            np.array([False, True])[None, None, :])  # (S, K, 2)
        self.ends = np.ascontiguousarray(ends).reshape(-1)  # (S K 2,)
        for table in (self.next_state, self.reward, self.aborted, self.valid,
                      self.action_mask, self.left, self.ends):
            table.setflags(write=False)
        # Python-list mirrors for the scalar path (list indexing beats numpy scalars).
        self.next_list: list[int] = self.next_state.tolist()
        self.reward_list: list[float] = self.reward.tolist()
        self.aborted_list: list[bool] = self.aborted.tolist()
        self.valid_list: list[bool] = self.valid.tolist()
        self.left_list: list[bool] = self.left.tolist()
        self.ends_list: list[bool] = self.ends.tolist()

    def adjust(self, reward: np.ndarray | float, s: IntArray, a_r: IntArray, start: IntArray,
               lifted: np.ndarray | bool, a_h: IntArray | None = None,
               s_next: IntArray | None = None) -> np.ndarray:
        """Apply the reward rule to rewards of the "paper" rule (arrays broadcast; ``a_h``
        and ``s_next`` default to the human waiting and the graph's next state).

        Under "no-free-toggle" a robot toggle that scored 0 and is unneeded in the context
        ``(s, start, lifted before the step)`` scores r0; under "paper" nothing changes.
        """
        if self.rule.charge is None:
            return np.asarray(reward)
        if a_h is None:
            a_h = WAIT
        if s_next is None:
            s_next = np.take(self.next_state, self.index(np.asarray(s), np.asarray(a_r),
                                                         np.asarray(a_h)))
        return self.rule.apply(RewardStep(self.graph, s, a_r, a_h, s_next, self.r0, start,
                                          lifted, np.asarray(reward, dtype=float)))

    def judge(self, s: IntArray, a_r: IntArray, a_h: IntArray, s_next: IntArray,
              start: IntArray, lifted: np.ndarray | bool,
              failed: np.ndarray | bool = False) -> np.ndarray:
        """The robot's reward of a step that reached ``s_next`` (the graph's prediction, or
        a simulator's outcome) under the rules' reward rule: :func:`step_reward`, arrays
        broadcast. Every loop that charges a step (the benchmark's, the envs' where the
        outcome is not the graph's) calls this, so none restates a rule.
        """
        return step_reward(self.graph, s, a_r, a_h, s_next, self.r0, reward=self.rule,
                           start=start, lifted=lifted, failed=failed)

    def index(self, s: IntArray, a_r: IntArray, a_h: IntArray) -> IntArray:
        """Flat index of ``(s, a_R, a_H)`` into the (S A A,) tables."""
        n_a = self.n_actions
        return (s * n_a + a_r) * n_a + a_h


class EpisodeBatch:
    """The bookkeeping of N running episodes, in arrays (the vector env, the benchmark).

    Args:
        rules: The scenario's :class:`EpisodeRules`.
        turn_state: (K, K) int, where a turning-back human switches ι to the start
            (see :func:`turn_back`), or (N, K, K) one table per row.
        n: Number of episodes N.

    Attributes (each (N,)):
        state, start, intention: int64, current state, start support and ι.
        turning: bool, the human is still going to turn back in this episode.
        lifted: bool, the object has left the start support.
        steps: int64, steps taken in the episode.
        last_human: int64, the human's last action as the robot sees it (wait at the start).
    """

    __slots__ = ("intention", "last_human", "lifted", "rules", "start", "state", "steps",
                 "turn_state", "turning")

    def __init__(self, rules: EpisodeRules, turn_state: np.ndarray, n: int) -> None:
        self.rules = rules
        self.turn_state = np.asarray(turn_state, dtype=np.int64)
        self.state = np.zeros(n, dtype=np.int64)
        self.start = np.zeros(n, dtype=np.int64)
        self.intention = np.ones(n, dtype=np.int64) % rules.n_supports
        self.turning = np.zeros(n, dtype=bool)
        self.lifted = np.zeros(n, dtype=bool)
        self.steps = np.zeros(n, dtype=np.int64)
        self.last_human = np.zeros(n, dtype=np.int64)

    def begin(self, which: np.ndarray | slice, start: IntArray, intention: IntArray,
              turning: np.ndarray | bool) -> None:
        """Start new episodes in the rows ``which`` (bool mask, index array or slice)."""
        self.start[which] = start
        self.intention[which] = intention
        self.turning[which] = turning
        self.state[which] = start_state(self.rules.graph, start)
        self.lifted[which] = False
        self.steps[which] = 0
        self.last_human[which] = WAIT

    def commit(self, s_next: np.ndarray, seen_human: np.ndarray,
               active: np.ndarray | None = None) -> np.ndarray:
        """Move the ``active`` episodes (default: all) to ``s_next`` after a joint step.

        Updates lifted, the step count and the human action seen, applies turning back on
        entering ``s_next``, and returns (N,) bool: the episode is over
        (:func:`episode_over`; False for inactive rows).
        """
        r = self.rules
        if active is not None:
            s_next = np.where(active, s_next, self.state)
            seen_human = np.where(active, seen_human, self.last_human)
            self.steps += active
        else:
            self.steps += 1
        context = s_next * r.n_supports + self.start
        lifted = self.lifted | np.take(r.left, context)
        over = np.take(r.ends, context * 2 + lifted)
        self.state, self.lifted, self.last_human = s_next, lifted, seen_human
        if self.turning.any():
            self.intention, self.turning = turn_back(self.turn_state, s_next, self.start,
                                                     self.intention, self.turning)
        return over if active is None else over & active

    def revise(self, revised: np.ndarray, active: np.ndarray | None = None) -> None:
        """Apply the humans' changes of mind (:func:`revise_intention`) in the ``active``
        rows (default: all); ``revised`` is (N,), -1 where a human kept its intention.
        """
        if active is not None:
            revised = np.where(active, revised, -1)
        self.intention = revise_intention(self.intention, revised)


# --------------------------------------------------------------------------- one fused table
class StepTable:
    """The rules of :class:`EpisodeRules` fused into one look-up per joint step (hot loops).

    Derived from :class:`EpisodeRules` (no rule is restated here): the step's context
    ``c = (start 2 + lifted) S + s`` (``lifted`` before the step) together with the joint
    action gives one flat index ``j = c A A + a_R A + a_H``, and every table below answers
    for that index what :class:`EpisodeBatch` and :meth:`EpisodeRules.adjust` would compute:
    the next state, the reward (under the rules' reward variant, which may depend on the
    start and the lifted flag), whether the step was aborted, whether either agent's action
    was invalid, whether the episode is over, and the next step's context, ready to index
    again. Turning back changes ι only, which no rule here depends on, so it stays outside.

    One more context, :attr:`over` (``c = 2 K S``), is an episode that has already ended:
    nothing happens in it (reward 0, never aborted, invalid or over again, state 0), so a
    batch can step rows that wait for a new episode with the others and get neutral values.

    Args:
        rules: The scenario's rules (graph, r0 and reward variant).

    Attributes:
        stride: A A, the step of the context in the flat index.
        over: ``c A A`` of the ended-episode context.
        key0: (K,) int64, ``c A A`` of each support's start context (resting, not lifted).
        state0: (K,) int64, the start state of each support (:func:`start_state`).
        next_key: (C A A,) int64 with C = 2 K S + 1, ``c' A A`` of the context after the step.
        next_state: (C A A,) int64, the state after the step.
        reward: (C A A,) float64, the robot's reward of the step.
        aborted: (C A A,) bool, the joint action was aborted.
        robot_invalid, human_invalid: (C A A,) bool, the agent's action is not valid.
        lifted: (C A A,) bool, the lifted flag after the step.
        terminated: (C A A,) bool, the step ends the episode (:func:`episode_over`).
    """

    def __init__(self, rules: EpisodeRules) -> None:
        n_s, n_a, n_k = rules.n_states, rules.n_actions, rules.n_supports
        self.rules = rules
        self.stride = n_a * n_a
        self.over = 2 * n_k * n_s * self.stride
        start = np.arange(n_k)[:, None, None, None, None]
        lifted = np.array([False, True])[None, :, None, None, None]
        s = np.arange(n_s)[None, None, :, None, None]
        a_r = np.arange(n_a)[None, None, None, :, None]
        a_h = np.arange(n_a)[None, None, None, None, :]
        shape = (n_k, 2, n_s, n_a, n_a)
        joint = np.broadcast_to(rules.index(s, a_r, a_h), shape)
        s_next = rules.next_state[joint]
        reward = np.broadcast_to(rules.adjust(rules.reward[joint], s, a_r, start, lifted,
                                              a_h, s_next), shape)
        lifted_next = lifted | rules.left[s_next * n_k + start]
        terminated = rules.ends[(s_next * n_k + start) * 2 + lifted_next]
        next_key = ((start * 2 + lifted_next) * n_s + s_next) * self.stride

        def flat(table: np.ndarray, dtype: type, ended: float | int | bool) -> np.ndarray:
            out: np.ndarray = np.full(self.over + self.stride, ended, dtype=dtype)
            out[:self.over] = np.broadcast_to(table, shape).reshape(-1)
            out.setflags(write=False)
            return out

        self.next_state = flat(s_next, np.int64, 0)
        self.next_key = flat(next_key, np.int64, self.over)
        self.reward = flat(reward, np.float64, 0.0)
        self.aborted = flat(rules.aborted[joint], np.bool_, False)
        self.robot_invalid = flat(~rules.valid[s * n_a + a_r], np.bool_, False)
        self.human_invalid = flat(~rules.valid[s * n_a + a_h], np.bool_, False)
        self.lifted = flat(lifted_next, np.bool_, False)
        self.terminated = flat(terminated, np.bool_, False)
        supports = np.arange(n_k)
        self.state0 = np.asarray(start_state(rules.graph, supports), dtype=np.int64)
        self.key0 = (supports * 2 * n_s + self.state0) * self.stride
        self.state0.setflags(write=False)
        self.key0.setflags(write=False)

    def key(self, state: IntArray, start: IntArray, lifted: np.ndarray | bool) -> np.ndarray:
        """``c A A``: the flat index of the context ``(state, start, lifted)``, arrays broadcast."""
        return ((np.asarray(start) * 2 + np.asarray(lifted, dtype=np.int64)) * self.rules.n_states
                + state) * self.stride


def _no_free_toggle(step: RewardStep) -> np.ndarray:
    return charge_unneeded_toggles(step.paper, step.a_r, unneeded_toggle(
        step.graph, step.s, step.a_r, step.start, step.lifted), step.r0)


#: The built-in rules: the paper's (v0, the default) and its variant that charges r0 for a
#: robot grasp toggle the next motion does not need (docs/task-model.md, "Reward").
PAPER = RewardRule("paper", "the paper's rule: grasping and letting go cost nothing")
NO_FREE_TOGGLE = RewardRule(
    "no-free-toggle", "as 'paper', but a robot grasp toggle that the next motion does not "
    "need costs r0, like waiting", _no_free_toggle)
for _rule in (PAPER, NO_FREE_TOGGLE):  # the package's own: not verified (no scenarios yet)
    REWARD_RULES.register(_rule)
_VERIFIED.update({id(PAPER): PAPER, id(NO_FREE_TOGGLE): NO_FREE_TOGGLE})
