"""The continuous-control env's PettingZoo parallel form: the human seat as an agent.

``parallel_env(scenario="hanger", **kwargs)`` (also ``hri_envs.physics.carry.parallel.
parallel_env``) gives :class:`CarryParallelEnv`, agents ``"robot"`` and ``"human"``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.conversions import parallel_to_aec
from pettingzoo.utils.env import AECEnv, ParallelEnv

from hri_envs.errors import ActionError, ResetNeeded
from hri_envs.physics.carry.env import ACTION_SIZE, CarryEnv, check_box_action

__all__ = ["CarryParallelEnv", "entry_points", "parallel_env"]

AGENTS: tuple[str, str] = ("robot", "human")


class CarryParallelEnv(ParallelEnv[str, np.ndarray, np.ndarray]):
    """Both seats of the continuous carrying task as agents.

    ## Description

    :class:`~hri_envs.physics.carry.env.CarryEnv` with the human's reference taken from
    the ``"human"`` agent instead of the scripted route: the human seat's agent moves the
    whole arm's hand, which holds the handle by friction, with the arm's impedance, strength
    and grip (the scripted human's reference is not used). Both agents get the env's reward
    (a cooperative task).

    ## Action Space

    ``Box(-1, 1, (7,), float32)`` for both. The robot's is :class:`CarryEnv`'s; the human's
    is a target for their hand's grip frame relative to where it is (``a[0:3] x
    max_step_m``, rotation vector ``a[3:6] x max_step_rad``) and the scale of their arm's
    impedance ``(a[6] + 1) / 2``.

    ## Observation Space

    The robot observes :class:`CarryEnv`'s observation (never the intention); the human
    observes it with their goal appended, one-hot (K).

    ## Rewards, Starting State, Episode End

    As :class:`CarryEnv` (the human's progress is along their scripted route to the goal).

    ## Arguments

    ``scenario`` ("hanger", "wheel") and :class:`CarryEnv`'s keyword arguments.

    ## Version History

    - v1: :class:`CarryEnv`'s v1 (the placing reward, no intention in ``info`` during an
      episode; the human's observation still holds their goal).
    - v0: initial version.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "name": "carry_continuous_v0",
                                "is_parallelizable": True}

    def __init__(self, scenario: str = "hanger", **kwargs: Any) -> None:
        self.env = CarryEnv(scenario, **kwargs)
        self.metadata = {**self.metadata, "name": f"carry_continuous_v{self.env.version}"}
        self.render_mode = self.env.render_mode
        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        n, k = self.env.n_obs, self.env.graph.n_intentions
        self._obs = {"robot": spaces.Box(-np.inf, np.inf, (n,), np.float32),
                     "human": spaces.Box(-np.inf, np.inf, (n + k,), np.float32)}
        self._act = spaces.Box(-1.0, 1.0, (ACTION_SIZE,), np.float32)

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The agent's observation space (the same object every call)."""
        return self._obs[agent]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """Both agents act in ``Box(-1, 1, (7,))`` (the same object every call)."""
        if agent not in AGENTS:
            raise ActionError(f"unknown agent {agent!r}; agents: robot, human")
        return self._act

    def _observations(self, robot: np.ndarray) -> dict[str, np.ndarray]:
        goal = np.zeros(self.env.graph.n_intentions, dtype=np.float32)
        goal[self.env._intention] = 1.0  # the human knows their goal
        return {"robot": robot, "human": np.concatenate([robot, goal])}

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        """Start an episode (``options`` as :meth:`CarryEnv.reset`)."""
        obs, info = self.env.reset(seed=seed, options=options)
        self.agents = list(AGENTS)
        return self._observations(obs), {a: dict(info) for a in self.agents}

    def step(self, actions: dict[str, Any]) -> tuple[
            dict[str, np.ndarray], dict[str, float], dict[str, bool], dict[str, bool],
            dict[str, dict[str, Any]]]:
        """Both agents act for 40 ms."""
        if not self.agents:
            raise ResetNeeded()
        if not isinstance(actions, Mapping):
            raise ActionError(f"step() takes a dict of one action per agent ({{'robot': ..., "
                              f"'human': ...}}), got {type(actions).__name__}")
        missing = [a for a in AGENTS if a not in actions]
        if missing:
            raise ActionError(f"actions needed for {', '.join(missing)}; got "
                              f"{sorted(map(repr, actions))}")
        a_r = check_box_action("robot", actions["robot"])
        a_h = check_box_action("human", actions["human"])
        env = self.env
        if env._done:
            raise ResetNeeded()
        if env._fault is not None:
            obs, reward, term, trunc, info = env.step(a_r)
        else:
            res = env.sim.step(env.sim.command(a_r), env.sim.human_command(a_h))
            obs, reward, term, trunc, info = env._after(res)
        out = self._observations(obs)
        agents = list(self.agents)
        if term or trunc:
            self.agents = []
        return (out, dict.fromkeys(agents, reward), dict.fromkeys(agents, term),
                dict.fromkeys(agents, trunc), {a: dict(info) for a in agents})

    def render(self) -> np.ndarray | None:
        """As :meth:`CarryEnv.render`."""
        return self.env.render()

    def close(self) -> None:
        """Release the renderer."""
        self.env.close()

    def state(self) -> np.ndarray:
        """The human's observation (the full state, the intention included)."""
        return self._observations(self.env._observation())["human"]


def parallel_env(scenario: str = "hanger", **kwargs: Any) -> CarryParallelEnv:
    """The parallel env of ``scenario`` (keyword arguments: :class:`CarryEnv`'s)."""
    return CarryParallelEnv(scenario, **kwargs)


def entry_points(scenario: str, version: int = 0
                 ) -> tuple[Callable[..., AECEnv], Callable[..., CarryParallelEnv]]:
    """``(env, parallel_env)`` of ``scenario``'s continuous env of ``version``, as its
    versioned module exports them (``hri_envs.hanger_continuous_v0``, ``..._v1``): the
    parallel env and its AEC form (PettingZoo's ``parallel_to_aec``), keyword arguments
    :class:`CarryEnv`'s.
    """

    def parallel(**kwargs: Any) -> CarryParallelEnv:
        return CarryParallelEnv(scenario, **{"version": version, **kwargs})

    def aec(**kwargs: Any) -> AECEnv:
        return parallel_to_aec(parallel(**kwargs))

    parallel.__doc__ = f"The parallel env of the {scenario} (keyword arguments: CarryEnv's)."
    aec.__doc__ = f"The AEC form of the {scenario}'s parallel env."
    return aec, parallel
