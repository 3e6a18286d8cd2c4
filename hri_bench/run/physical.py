"""Runs of robot agents with physical humans on the continuous envs (the physical suite's loop).

A *run* is a few episodes of one robot agent with one physical human (a member of a
population, :mod:`hri_envs.physics.carry.human.population`) on a ``*PandaContinuous-v1`` env; the
agent is made once per run and may learn across its episodes. Every draw of run ``r`` of a track
comes from ``(seed, track, r)``: episode ``e`` resets the env with the seed
:func:`episode_seed` (start, goal and the wheel's layout are the env's draws from it), so
every agent meets the same episodes (paired comparisons) and a run simulated alone is the
run of the whole suite (``validate --replay``). The agent's own random stream is a keyed
hash of the same (:func:`agent_stream`): without the suite seed it cannot tell which run,
and so which human, it faces.

:func:`simulate_unit` runs a batch of runs of one agent and returns, per figure, a (runs,
episodes) array (:data:`FIGURES`).
"""

from __future__ import annotations

import hashlib
import hmac
import math
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent, run_physical_episode
from hri_envs.errors import ConfigError
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import NamedScenario, spec_of

__all__ = ["FIGURES", "OUTCOMES", "PhysicalUnit", "agent_stream", "episode_seed",
           "simulate_unit"]

#: The per-episode figures a run records (``info["episode"]`` of the v1 envs), and
#: ``placed_goal`` (1 when the object came to rest on the human's goal) and ``outcome`` (an
#: index into :data:`OUTCOMES`).
FIGURES: tuple[str, ...] = ("return", "placed_goal", "outcome", "effort",
                            "effort_per_progress", "peak_force", "rms_force", "rms_jerk",
                            "time_s", "time_to_place_s", "stall_s", "disagreement")
#: How an episode ended (``info["episode"]["outcome"]``).
OUTCOMES: tuple[str, ...] = ("placed", "wrong_support", "timeout", "dropped", "slipped",
                             "too_weak", "unstable", "ik_failure")


@dataclass(frozen=True)
class PhysicalUnit(NamedScenario):
    """Some runs of one agent on one track.

    The scenario's name is resolved once, by the unit (:attr:`graph`, :attr:`spec`); the
    runs are given the graph.

    Attributes:
        track: The track's name (seeds the episodes).
        scenario: "hanger" or "wheel" (the name: a unit's key hashes it).
        agent: The agent's name (:func:`make`).
        population: The population the runs' humans come from.
        members: Each run's human, an index into the population's members.
        runs: The runs' indices in the track.
        episodes: Episodes per run.
        seed: The suite seed.
        drive: The human arm's drive.
    """

    track: str
    scenario: str
    agent: str
    population: str
    members: tuple[int, ...]
    runs: tuple[int, ...]
    episodes: int
    seed: int
    drive: str = "torque"


def episode_seed(seed: int, track: str, run: int, episode: int) -> int:
    """The env's reset seed of an episode (start, goal, layout, sensor noise)."""
    seq = np.random.SeedSequence([int(seed) & 0xFFFFFFFF, zlib.crc32(track.encode()),
                                  int(run), int(episode), 23])
    return int(seq.generate_state(1, np.uint32)[0])


def agent_stream(seed: int, track: str, run: int) -> np.random.Generator:
    """The agent's own random stream for a run: HMAC-SHA256 keyed by the suite seed over the
    track and run, so the stream tells nothing of which run it is without the seed.
    """
    digest = hmac.new(str(int(seed)).encode(), f"{track}/{int(run)}".encode(),
                      hashlib.sha256).digest()
    return np.random.default_rng(int.from_bytes(digest[:16], "little"))


_ENVS: dict[tuple[str, str], Any] = {}


def _env(graph: TaskGraph, drive: str) -> Any:
    """One v1 env per (scenario, drive) and process (building a scene takes a while)."""
    key = (graph.name, drive)
    if key not in _ENVS:
        import gymnasium as gym  # noqa: PLC0415

        from hri_envs.registration import continuous_id  # noqa: PLC0415

        v0 = spec_of(graph).continuous_id
        if v0 is None:
            raise ConfigError(f"scenario {graph.name!r} has no continuous env",
                              field="scenario")
        _ENVS[key] = gym.make(continuous_id(v0, 1), drive=drive)
    return _ENVS[key]


def _figures(metrics: Mapping[str, Any], reward: float) -> dict[str, float]:
    out = {k: float(metrics.get(k, math.nan)) for k in FIGURES
           if k not in ("return", "placed_goal", "outcome")}
    out["return"] = float(reward)
    name = str(metrics.get("outcome", "timeout"))
    out["placed_goal"] = float(name == "placed")
    out["outcome"] = float(OUTCOMES.index(name) if name in OUTCOMES else len(OUTCOMES))
    return out


def simulate_unit(unit: PhysicalUnit, make: Callable[[str, TaskGraph, np.random.Generator],
                                                     PhysicalAgent],
                  humans: Sequence[Any]) -> dict[str, np.ndarray]:
    """The unit's runs: per figure of :data:`FIGURES` a (runs, episodes) array.

    Args:
        unit: The runs.
        make: ``make(agent, graph, stream)``: a fresh agent for a run on the scenario's
            task graph.
        humans: The population's members (``HumanParams``), indexed by ``unit.members``.
    """
    graph = unit.graph
    env = _env(graph, unit.drive)
    out = {k: np.full((len(unit.runs), unit.episodes), np.nan) for k in FIGURES}
    for i, (run, member) in enumerate(zip(unit.runs, unit.members, strict=True)):
        agent = make(unit.agent, graph, agent_stream(unit.seed, unit.track, run))
        for e in range(unit.episodes):
            ep = run_physical_episode(env, agent, seed=episode_seed(unit.seed, unit.track,
                                                                    run, e),
                                      options={"human": humans[member]})
            for k, v in _figures(ep.outcome.metrics, ep.reward).items():
                out[k][i, e] = v
    return out
