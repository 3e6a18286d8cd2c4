"""One seat of the two-agent env played by a fixed partner: a single-agent Gymnasium env.

:class:`PartnerEnv` wraps the PettingZoo :class:`~hri_envs.envs.parallel.CooperationParallelEnv`
(any backend, observation format or human reward) and lets a fixed partner play the other
agent, so that a single-agent learner (SB3, your own) can train either seat:

- ``learner="robot"``: the partner is a human of the human protocol (a
  :class:`~hri_envs.humans.scripted.ScriptedHuman`, a :class:`~hri_envs.humans.protocol.Human`
  or a one-row :class:`~hri_envs.humans.protocol.BatchHuman`, which act on the true state
  and ι, as in the Gymnasium robot env) or any policy;
- ``learner="human"``: the partner is a robot policy, for a *learning human*; pair it with
  ``human_reward="goal"`` so that the human is paid for reaching its own goal.

A policy is a callable ``policy(observation, rng) -> action`` that receives the partner's
own observation (in the wrapped env's format) and the wrapper's generator. Three come with
the library: :func:`following_robot` (a robot that mirrors the human's grasp and lets the
human lead: the default partner of a learning human), :func:`waiting_policy` and
:func:`random_valid_policy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from hri_envs.envs.formats import ClassicLayout
from hri_envs.envs.parallel import AGENTS, CooperationParallelEnv
from hri_envs.envs.spaces import check_action
from hri_envs.errors import ConfigError, ResetNeeded
from hri_envs.humans.protocol import BatchHuman, checked_actions
from hri_envs.humans.seat import HumanLike, seat_human
from hri_envs.task.actions import HUMAN_BIT, ROBOT_BIT, TOGGLE, WAIT
from hri_envs.task.episode import revise_intention
from hri_envs.task.graph import TaskGraph

__all__ = ["PartnerEnv", "Policy", "following_robot", "random_valid_policy", "waiting_policy"]

_ONE = np.ones(1, dtype=bool)
_ONE.setflags(write=False)

#: ``policy(observation, rng) -> action`` of the partner agent.
Policy = Callable[[Any, np.random.Generator], int]


def waiting_policy(observation: Any, rng: np.random.Generator) -> int:
    """Always wait (a passive partner); the arguments are ignored."""
    return WAIT


def random_valid_policy(observation: Any, rng: np.random.Generator) -> int:
    """A uniformly drawn action among the valid ones (``observation["action_mask"]``; the
    "dict" and "classic" formats).
    """
    return int(rng.choice(np.flatnonzero(observation["action_mask"])))


def following_robot(graph: TaskGraph) -> Policy:
    """A scripted robot that follows the human's lead.

    It toggles its grasp whenever its own grasp differs from the human's (it takes hold
    when the human does and lets go when the human does), and otherwise waits, so that
    a held object moves by the human's actions. It reads the state from its observation in
    any format and never uses ι.

    Args:
        graph: The scenario's task graph.
    """
    layout = ClassicLayout(graph.n_states, graph.n_intentions, graph.n_actions)
    grasp = graph.grasp

    def follow(observation: Any, rng: np.random.Generator) -> int:
        if isinstance(observation, dict) and "state" in observation:
            state = int(observation["state"])
        else:
            vec = observation["observation"] if isinstance(observation, dict) else observation
            state = int(layout.decode(vec)["state"])  # type: ignore[arg-type]
        mu = int(grasp[state])
        return TOGGLE if bool(mu & HUMAN_BIT) != bool(mu & ROBOT_BIT) else WAIT

    return follow


class PartnerEnv(gym.Env[Any, np.int64]):
    """A single-agent view of the two-agent env: ``learner`` acts, a fixed partner answers.

    Args:
        env: The two-agent parallel env (e.g. ``hanger_v0.parallel_env(human_reward="goal")``).
        learner: The agent the caller controls, "robot" (default) or "human".
        partner: The other agent: a human (a ``ScriptedHuman``, ``Human`` or one-row
            ``BatchHuman``; only when the learner is the robot) or a :data:`Policy`.
            Default: the scenario's preference human for a learning robot,
            :func:`following_robot` for a learning human.

    The observation and action spaces are the learner's in ``env``; ``step`` returns the
    learner's observation, reward, termination, truncation and info. The partner draws from
    this env's ``np_random`` (seeded by ``reset(seed=...)``), so seeded episodes repeat.

    Raises:
        ConfigError: (naming ``env``, ``learner`` or ``partner``) An env that is not this
            library's two-agent env, an unknown learner, or a partner of another kind.
        ActionError: (from :meth:`step`) The learner's action, or the partner's (a policy
            returning 0.5 or ``True``, say), is not an integer of the action space.
    """

    def __init__(self, env: CooperationParallelEnv, learner: str = "robot",
                 partner: HumanLike | Policy | None = None) -> None:
        if not isinstance(learner, str) or learner not in AGENTS:
            raise ConfigError(f"unknown learner {learner!r}; allowed: "
                              f"{', '.join(map(repr, AGENTS))}", field="learner")
        agents = getattr(env, "possible_agents", None)
        if (not isinstance(agents, list | tuple) or list(agents) != list(AGENTS)
                or not isinstance(getattr(getattr(env, "unwrapped", None), "graph", None),
                                  TaskGraph)):
            raise ConfigError(f"PartnerEnv wraps a two-agent env of this library with agents "
                              f"{list(AGENTS)} (e.g. hanger_v0.parallel_env()), got {env!r}",
                              field="env")
        self.env, self.learner = env, learner
        self.partner_agent = "human" if learner == "robot" else "robot"
        self.graph = graph = env.unwrapped.graph
        self._human: BatchHuman | None = None
        self._policy: Policy | None = None
        if isinstance(partner, HumanLike) or (
                partner is None and learner == "robot"):
            if learner != "robot":
                raise ConfigError("a human partner can only play the human; for "
                                  "learner='human' give the robot a policy(observation, rng)",
                                  field="partner")
            self._human = seat_human(graph, human=partner)
            self._sync_turning()
        elif partner is None:
            self._policy = following_robot(graph)
        elif callable(partner):
            self._policy = partner
        else:
            raise ConfigError(f"partner must be a human (ScriptedHuman, Human, BatchHuman) or "
                              f"a callable policy(observation, rng) -> action, got {partner!r}",
                              field="partner")
        #: The partner: the human in the seat, or the policy.
        self.partner: BatchHuman | Policy = self._human or self._policy  # type: ignore[assignment]
        self.observation_space = env.observation_space(learner)
        self.action_space = env.action_space(learner)
        self.metadata = dict(env.metadata)
        self.render_mode = env.render_mode
        self._obs: dict[str, Any] = {}
        self._partner_rng = np.random.default_rng(0)
        self._seen: dict[str, np.ndarray] = {}

    def _sync_turning(self) -> None:
        """The env applies the episode rules: it turns back where and as often as the human
        in the seat does.
        """
        assert self._human is not None
        where = self._human.turn_state
        if where is not None:
            self.env.unwrapped._episode.set_turn_state(where if where.ndim == 2 else where[0])
        self.env.unwrapped.turn_back = float(self._human.turn_back[0])

    def _partner_action(self, action: Any) -> int:
        """The partner's action in this step (``action``: the learner's)."""
        if self._policy is not None:
            return check_action(self.partner_agent,
                                self._policy(self._obs[self.partner_agent], self._partner_rng),
                                int(self.env.action_space(self.partner_agent).n))
        assert self._human is not None
        state, start, intention, last_human = (int(v) for v in self.env.state()[:4])
        self._seen = {"state": np.array([state]), "start": np.array([start]),
                      "intention": np.array([intention]),
                      "last_human_action": np.array([last_human]),
                      "action_mask": self.graph.valid[state].astype(np.int8)[None],
                      "robot_action": np.array([int(action)])}
        return int(checked_actions(self._human.act(self._seen, _ONE), 1,
                                   self.graph.n_actions)[0])

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset the wrapped env (same ``options``); the learner's observation and info.

        A population in the seat draws the episode's human first, from this wrapper's own
        ``np_random`` (seeded by ``seed``), so the env's draws stay those of any other human.
        """
        super().reset(seed=seed)
        if self._human is not None:
            self._human.draw(self.np_random)
            self._sync_turning()
        self._obs, infos = self.env.reset(seed=seed, options=options)
        # The partner's own stream, drawn from the env's (as RobotEnv does for its human), so
        # its draws are not the very bits the env used for start, intention and turning back.
        self._partner_rng = np.random.default_rng(
            int(self.env.unwrapped.np_random.integers(2**63)))
        if self._human is not None:
            self._human.seed(self._partner_rng)
            state = self.env.state()
            self._human.begin_episode(state[1:2], state[2:3])
        return self._obs[self.learner], infos[self.learner]

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """The learner plays ``action``, the partner its own; one joint step."""
        if not self.env.agents:
            raise ResetNeeded()
        if self._human is not None:  # the human sees the robot's action: check it first
            action = check_action("robot", action, int(self.env.action_space("robot").n))
        partner = self._partner_action(action)
        actions = {self.learner: action, self.partner_agent: partner}
        self._obs, rewards, terms, truncs, infos = self.env.step(actions)
        me = self.learner
        if self._human is not None:
            self._human.observe(self._seen["state"], self._seen["robot_action"],
                                np.array([partner]), self.env.state()[:1], _ONE)
            revised = self._human.revised_intentions()  # a human who changed its mind
            if revised is not None and self.env.agents:
                episode = self.env.unwrapped._episode
                episode.intention = int(revise_intention(episode.intention, revised[0]))
            if not self.env.agents:
                self._human.end_episode()
        return self._obs[me], float(rewards[me]), bool(terms[me]), bool(truncs[me]), infos[me]

    def action_masks(self) -> np.ndarray:
        """(A,) bool, the learner's valid actions (sb3-contrib's convention)."""
        obs = self._obs[self.learner]
        if isinstance(obs, dict):
            return np.asarray(obs["action_mask"], dtype=bool)
        n_actions = int(self.env.action_space(self.learner).n)
        return np.asarray(obs[-n_actions:] > 0.5)  # the "flat" format

    def render(self) -> Any:
        """The wrapped env's :meth:`render`."""
        return self.env.render()

    def close(self) -> None:
        """Close the wrapped env."""
        self.env.close()
