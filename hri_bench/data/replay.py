"""``hri-bench replay``: a recorded session, step by step, through the env's own rules.

Each recorded episode is played again in the registered Gymnasium env of its scenario
(``hri_envs/Hanger-v0``, ``hri_envs/Wheel-v0``) from its start, layout and settings: the
robot's recorded actions go to ``env.step``, the human's come from :class:`ReplayHuman` in
the env's human seat. Every step is checked against the recording (the state before it,
the human's action the env took, the next state, the robot's reward, the human's goal
reward, ``aborted``, the episode's end) and prints a line (state, both actions, the reward
the env gives beside the recorded one, the robot's belief, the response time, what
differs) and, when asked, writes the env's picture as a PNG. :func:`replay` returns, per
episode, the recorded and the replayed rewards and the differences, so a dataset can be
checked against the env (the browser test does).
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
from hri_bench.data.datasets import UNFINISHED, Dataset
from hri_envs.errors import ConfigError, HriEnvsError
from hri_envs.humans.protocol import Human
from hri_envs.task import episode as rules

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
        replayed: (T',) the env's rewards for the same actions (T' < T when the env ended
            the episode, or refused a step, before the recording did).
        terminated, truncated: Recorded and replayed episode end, as (recorded, replayed).
        differences: One line per step where the env disagrees with the recording (its
            state before or after the step, the human's action it took, the robot's reward,
            the human's goal reward, ``aborted``, the episode's end).
    """

    participant: str
    episode: int
    recorded: np.ndarray
    replayed: np.ndarray
    terminated: tuple[bool, bool]
    truncated: tuple[bool, bool]
    differences: tuple[str, ...] = ()

    @property
    def agrees(self) -> bool:
        """The env gives the recorded states, actions, rewards and episode end in every step."""
        return (not self.differences and len(self.recorded) == len(self.replayed)
                and bool(np.array_equal(self.recorded, self.replayed))
                and self.terminated[0] == self.terminated[1]
                and self.truncated[0] == self.truncated[1])


def _picture(env: Any) -> np.ndarray:
    """The env's ``rgb_array`` picture."""
    rgb = env.render()
    assert isinstance(rgb, np.ndarray)
    return rgb


def _settings(session: dict[str, Any], path: Path) -> dict[str, Any]:
    """The env's settings from a ``session.json`` (``r0``, ``reward_rule``, ``max_steps``)."""
    r0, rule, steps = session.get("r0"), session.get("reward_rule"), session.get("max_steps")
    if (isinstance(r0, bool) or not isinstance(r0, int | float) or not isinstance(rule, str)
            or isinstance(steps, bool) or not isinstance(steps, int)):
        raise ConfigError(f"{path}: r0 (a number), reward_rule (a name) and max_steps (a whole "
                          f"number) are needed to replay; got {r0!r}, {rule!r}, {steps!r}",
                          field="dataset")
    return {"r0": float(r0), "reward": rule, "max_cycles": steps}


def _compare(step: dict[str, Any], obs: Any, reward: float, ended: tuple[bool, bool],
             info: dict[str, Any], graph: Any) -> list[str]:
    """What the env's step (its observation, reward, end and info) says against the
    recorded ``step``.
    """
    out = []
    pairs = (("next state", int(obs["state"]), step["next_state"]),
             ("human action", int(obs["last_human_action"]), step["human_action"]),
             ("robot reward", float(reward), step["robot_reward"]),
             ("aborted", bool(info.get("aborted")), step["aborted"]),
             ("terminated", ended[0], step["terminated"]),
             ("truncated", ended[1], step["truncated"]))
    for what, env_value, recorded in pairs:
        if env_value != recorded:
            out.append(f"{what} {env_value} (recorded {recorded})")
    goal = float(rules.goal_reward(graph, int(obs["state"]), step["intention"],
                                   bool(info.get("aborted")), ended[0]))
    if goal != step["human_reward"]:
        out.append(f"human reward {goal:+.0f} (recorded {step['human_reward']:+.0f})")
    return out


def replay(dataset: Dataset, participants: Sequence[str] | None = None, *,
           write: Callable[[str], None] | None = None, frames: str | Path | None = None,
           pause: Callable[[], None] | None = None) -> list[EpisodeReplay]:
    """Replay the episodes of ``participants`` (default all, unfinished sessions too) in
    the env, checking every step against the recording: the state before it, the human's
    action the env took, the next state, the robot's reward, the human's goal reward,
    ``aborted`` and the episode's end (:attr:`EpisodeReplay.differences`).

    Args:
        dataset: The recorded dataset.
        participants: Whose sessions (ids); None: every session.
        write: Told one log line per step and per episode (None: quiet).
        frames: A folder for the pictures, ``<participant>/ep01-step001.png`` (step 0 is
            the start); None: none are drawn.
        pause: Called after each step (e.g. to wait for Enter).

    Raises:
        ConfigError: A participant the dataset does not have, or a damaged dataset
            (:meth:`Dataset.steps`, a ``session.json`` without the env's settings; with
            every session asked for, a session's episodes without its ``session.json``, as
            :meth:`Dataset.steps` refuses them).
    """
    if not participants:
        dataset.check_orphans()
    known = dataset.participants()
    unknown = sorted(set(participants or ()) - set(known))
    if unknown:
        raise ConfigError(f"no participant {', '.join(unknown)} in {dataset.dataset_id}; its "
                          f"participants: {', '.join(known) or 'none'}", field="participant")
    meta = {m["participant"]: m for m in dataset.sessions()}
    table = dataset.steps(list(participants) if participants else known)
    rows = table.to_pylist()
    out: list[EpisodeReplay] = []
    i = 0
    while i < len(rows):
        who, ep = rows[i]["participant"], rows[i]["episode"]
        j = i
        while j < len(rows) and rows[j]["participant"] == who and rows[j]["episode"] == ep:
            j += 1
        out.append(_episode(dataset, meta[who], rows[i:j], write or (lambda _: None),
                            frames, pause))
        i = j
    return out


def _episode(dataset: Dataset, session: dict[str, Any], steps: list[dict[str, Any]],
             say: Callable[[str], None], frames: str | Path | None,
             pause: Callable[[], None] | None) -> EpisodeReplay:
    """Replay one episode's recorded ``steps`` (see :func:`replay`)."""
    graph = dataset.graph
    names = graph.support_names
    who, ep = steps[0]["participant"], steps[0]["episode"]
    flat = steps[0]["layout"]
    options: dict[str, Any] = {"start": steps[0]["start"], "intention": steps[0]["intention"],
                               "turn_back": False}
    if flat:
        options["layout"] = tuple((flat[k], flat[k + 1]) for k in range(0, len(flat), 2))
    where = dataset.path / "sessions" / who / "session.json"
    try:
        env = gym.make(str(dataset.spec.gym_id),
                       human=ReplayHuman([s["human_action"] for s in steps]),
                       render_mode="rgb_array", **_settings(session, where))
        obs, _ = env.reset(seed=0, options=options)
    except ConfigError as exc:
        raise ConfigError(f"{where}: the env refuses the session's settings or episode "
                          f"{ep + 1}'s start ({exc})", field="dataset") from None
    status = "" if session["status"] not in UNFINISHED else f" (session {session['status']})"
    say(f"{who} episode {ep + 1}: from {names[steps[0]['start']]}, goal "
        f"{names[steps[0]['assigned_intention']]}{status}")
    folder = None
    if frames is not None:
        folder = Path(frames) / who
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"ep{ep + 1:02d}-step000.png").write_bytes(png(_picture(env)))
    replayed: list[float] = []
    differences: list[str] = []
    terminated = truncated = False
    for t, step in enumerate(steps):
        s = step["state"]
        if int(obs["state"]) != s or terminated or truncated:
            ended = "has ended the episode" if terminated or truncated else (
                f"is in state {int(obs['state'])}")
            differences.append(f"step {t + 1}: the env {ended}, the recording goes on from "
                               f"state {s}")
            say(f"  step {t + 1}: DIFFERS: {differences[-1].split(': ', 1)[1]}; replay of "
                "this episode stopped")
            break
        try:
            obs, reward, terminated, truncated, info = env.step(step["robot_action"])
        except HriEnvsError as exc:
            differences.append(f"step {t + 1}: the env refuses it ({exc})")
            say(f"  step {t + 1}: DIFFERS: the env refuses it ({exc})")
            break
        replayed.append(float(reward))
        wrong = _compare(step, obs, float(reward), (bool(terminated), bool(truncated)), info,
                         graph)
        if wrong:
            differences.append(f"step {t + 1}: " + ", ".join(wrong))
        belief = step["belief"]
        thinks = "" if belief is None else " | belief " + ", ".join(
            f"{n} {b:.0%}" for n, b in zip(names, belief, strict=True))
        rt = step["client_response_ms"]
        took = f" | {rt / 1000:.2f} s" if rt is not None else ""
        say(f"  step {t + 1}: {graph.state_names[s]} | human: "
            f"{graph.agent_action_label(s, step['human_action'], robot=False)} | robot: "
            f"{graph.agent_action_label(s, step['robot_action'], robot=True)} | reward "
            f"{reward:+.2f} (recorded {step['robot_reward']:+.2f}){thinks}{took}"
            + (f"  DIFFERS: {', '.join(wrong)}" if wrong else ""))
        if folder is not None:
            (folder / f"ep{ep + 1:02d}-step{t + 1:03d}.png").write_bytes(png(_picture(env)))
        if pause is not None:
            pause()
    env.close()
    result = EpisodeReplay(who, ep, np.array([s["robot_reward"] for s in steps]),
                           np.array(replayed), (bool(steps[-1]["terminated"]), bool(terminated)),
                           (bool(steps[-1]["truncated"]), bool(truncated)), tuple(differences))
    end = names[graph.support[int(obs["state"])]] if terminated else "nowhere"
    say(f"  episode over: rests on {end}; reward {sum(replayed):+.2f}"
        + ("" if result.agrees else "  (DIFFERS from the recording)"))
    return result
