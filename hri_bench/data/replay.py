"""``hri-bench replay``: a recorded session, step by step, through the env's own rules.

Each recorded episode is played again in the registered Gymnasium env of its scenario
(``hri_envs/Hanger-v0``, ``hri_envs/Wheel-v0``) from its start, layout and settings: the
robot's recorded actions go to ``env.step``, the human's come from :class:`ReplayHuman` in
the env's human seat. Every step prints a line (state, both actions, the reward the env
gives beside the recorded one, the robot's belief, the response time) and, when asked,
writes the env's picture as a PNG. :func:`replay` returns, per episode, the recorded and the
replayed rewards, so a dataset can be checked against the env (the browser test does).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import hri_envs  # noqa: F401  (registers the env ids)
from hri_bench.core.pictures import png
from hri_bench.data.datasets import Dataset
from hri_envs.errors import ConfigError
from hri_envs.humans.protocol import Human
from hri_envs.task.scenarios import scenario_graph, scenario_spec

__all__ = ["EpisodeReplay", "ReplayHuman", "replay"]


class ReplayHuman(Human):
    """A human that takes the recorded actions, one per step, in order."""

    name = "replay"

    def __init__(self, actions: Sequence[int]) -> None:
        self.actions = [int(a) for a in actions]
        self.t = 0

    def act(self, observation: Any) -> int:
        """The next recorded action."""
        action = self.actions[self.t]
        self.t += 1
        return action


@dataclass(frozen=True)
class EpisodeReplay:
    """One replayed episode.

    Attributes:
        participant, episode: Which.
        recorded: (T,) the recorded robot rewards.
        replayed: (T,) the env's rewards for the same actions.
        terminated, truncated: Recorded and replayed episode end, as (recorded, replayed).
    """

    participant: str
    episode: int
    recorded: np.ndarray
    replayed: np.ndarray
    terminated: tuple[bool, bool]
    truncated: tuple[bool, bool]

    @property
    def agrees(self) -> bool:
        """The env gives the recorded rewards and episode end."""
        return (len(self.recorded) == len(self.replayed)
                and bool(np.array_equal(self.recorded, self.replayed))
                and self.terminated[0] == self.terminated[1]
                and self.truncated[0] == self.truncated[1])


def _picture(env: Any) -> np.ndarray:
    """The env's ``rgb_array`` picture."""
    rgb = env.render()
    assert isinstance(rgb, np.ndarray)
    return rgb


def replay(dataset: Dataset, participants: Sequence[str] | None = None, *,
           write: Callable[[str], None] | None = None, frames: str | Path | None = None,
           pause: Callable[[], None] | None = None) -> list[EpisodeReplay]:
    """Replay the episodes of ``participants`` (default all) in the env.

    Args:
        dataset: The recorded dataset.
        participants: Whose sessions (ids); None: every session.
        write: Told one log line per step and per episode (None: quiet).
        frames: A folder for the pictures, ``<participant>/ep01-step001.png`` (step 0 is
            the start); None: none are drawn.
        pause: Called after each step (e.g. to wait for Enter).

    Raises:
        ConfigError: A participant the dataset does not have.
    """
    known = dataset.participants()
    unknown = sorted(set(participants or ()) - set(known))
    if unknown:
        raise ConfigError(f"no participant {', '.join(unknown)} in {dataset.dataset_id}; its "
                          f"participants: {', '.join(known) or 'none'}", field="participant")
    meta = {m["participant"]: m for m in dataset.sessions()}
    graph = scenario_graph(dataset.scenario)
    table = dataset.steps(participants)
    rows = table.to_pylist()
    out: list[EpisodeReplay] = []
    say = write or (lambda _: None)
    i = 0
    while i < len(rows):
        first = rows[i]
        who, ep = first["participant"], first["episode"]
        j = i
        while j < len(rows) and rows[j]["participant"] == who and rows[j]["episode"] == ep:
            j += 1
        steps = rows[i:j]
        i = j
        session = meta[who]
        flat = steps[0]["layout"]
        layout = (tuple((flat[k], flat[k + 1]) for k in range(0, len(flat), 2))
                  if flat else None)
        env = gym.make(str(scenario_spec(dataset.scenario).gym_id),
                       human=ReplayHuman([s["human_action"] for s in steps]),
                       r0=float(session["r0"]), reward=str(session["reward_rule"]),
                       max_cycles=int(session["max_steps"]), render_mode="rgb_array")
        options: dict[str, Any] = {"start": steps[0]["start"],
                                   "intention": steps[0]["intention"], "turn_back": False}
        if layout is not None:
            options["layout"] = layout
        obs, _ = env.reset(seed=0, options=options)
        names = graph.support_names
        say(f"{who} episode {ep + 1}: from {names[steps[0]['start']]}, goal "
            f"{names[steps[0]['assigned_intention']]}")
        folder = None
        if frames is not None:
            folder = Path(frames) / who
            folder.mkdir(parents=True, exist_ok=True)
            (folder / f"ep{ep + 1:02d}-step000.png").write_bytes(png(_picture(env)))
        replayed, terminated, truncated = [], False, False
        for t, step in enumerate(steps):
            if int(obs["state"]) != step["state"]:
                raise ConfigError(f"{who} episode {ep + 1} step {t + 1}: the env is in state "
                                  f"{int(obs['state'])}, the recording in {step['state']}",
                                  field="dataset")
            s = step["state"]
            obs, reward, terminated, truncated, _ = env.step(step["robot_action"])
            replayed.append(float(reward))
            belief = step["belief"]
            thinks = "" if belief is None else " | belief " + ", ".join(
                f"{n} {b:.0%}" for n, b in zip(names, belief, strict=True))
            rt = step["client_response_ms"]
            took = f" | {rt / 1000:.2f} s" if rt is not None else ""
            say(f"  step {t + 1}: {graph.state_names[s]} | human: "
                f"{graph.agent_action_label(s, step['human_action'], robot=False)} | robot: "
                f"{graph.agent_action_label(s, step['robot_action'], robot=True)} | reward "
                f"{reward:+.2f} (recorded {step['robot_reward']:+.2f}){thinks}{took}")
            if folder is not None:
                (folder / f"ep{ep + 1:02d}-step{t + 1:03d}.png").write_bytes(
                    png(_picture(env)))
            if pause is not None:
                pause()
        env.close()
        result = EpisodeReplay(who, ep, np.array([s["robot_reward"] for s in steps]),
                               np.array(replayed),
                               (bool(steps[-1]["terminated"]), bool(terminated)),
                               (bool(steps[-1]["truncated"]), bool(truncated)))
        end = names[graph.support[steps[-1]["next_state"]]] if terminated else "nowhere"
        say(f"  episode over: rests on {end}; reward {sum(replayed):+.2f}"
            + ("" if result.agrees else "  (DIFFERS from the recording)"))
        out.append(result)
    return out
