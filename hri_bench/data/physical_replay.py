"""A recorded physical session played again: the same inputs through the same env and robot.

Each session of a physical dataset is replayed in order (a robot that learns carries what it
learned from one episode to the next) in a fresh parallel env of its scenario
(``hri_envs/*PandaContinuous-v1``, the human seat as an agent), with its robot made again by
name and seed (``session.json``: ``agent``, ``robot_seed``) and each episode reset with its
recorded seed, start and goal (``episode_seeds``, ``schedule``) and the session's human
(``human_params``). Every step then takes the participant's recorded hand target and
stiffness and makes the human seat's action of them as the server did
(:func:`~hri_bench.data.physical.human_action`, from the replayed hand), while the robot
acts on the replayed observation; both actions, the observations, the reward, the hand's
pose and wrench, the belief and the episode's end are compared with the recording.
MuJoCo is deterministic on one machine and build, so a recording that the server made
replays exactly; :attr:`EpisodeReplay.differences` names each first difference.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hri_bench.core.physical_robots import make_robot
from hri_bench.data.datasets import Dataset
from hri_bench.data.physical import hand_pose, human_action
from hri_bench.data.replay import EpisodeReplay
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.intention import HumanParams

__all__ = ["replay_physical"]

#: Values compared with the recording: (name, recorded column, tolerance).
_COMPARED = (("robot observation", "robot_observation", 0.0),
             ("robot action", "robot_action", 0.0), ("human action", "human_action", 0.0),
             ("hand pose", "hand_pose", 1e-12), ("hand force", "hand_force", 1e-9))


def replay_physical(dataset: Dataset, participants: Sequence[str] | None = None, *,
                    write: Callable[[str], None] | None = None) -> list[EpisodeReplay]:
    """Replay the physical sessions of ``participants`` (default all) and compare every
    step with the recording (module docstring).

    Raises:
        ConfigError: Not a physical dataset, an unknown participant, or a ``session.json``
            without the replay's settings.
    """
    if not dataset.physical:
        raise ConfigError(f"{dataset.dataset_id} holds graph sessions; replay them with "
                          "hri_bench.data.replay.replay", field="dataset")
    known = dataset.participants()
    unknown = sorted(set(participants or ()) - set(known))
    if unknown:
        raise ConfigError(f"no participant {', '.join(unknown)} in {dataset.dataset_id}; its "
                          f"participants: {', '.join(known) or 'none'}", field="participant")
    say = write or (lambda _: None)
    meta = {m["participant"]: m for m in dataset.sessions()}
    out: list[EpisodeReplay] = []
    for who in participants or known:
        table = dataset.steps([who])
        out.extend(_session(dataset, meta[who], table, say))
    return out


def _settings(session: dict[str, Any]) -> dict[str, Any]:
    missing = [k for k in ("agent", "robot_seed", "episode_seeds", "schedule")
               if k not in session]
    if missing:
        raise ConfigError(f"session {session.get('participant')}: session.json has no "
                          f"{', '.join(missing)}; it cannot be replayed", field="dataset")
    return session


def _session(dataset: Dataset, session: dict[str, Any], table: Any,
             say: Callable[[str], None]) -> list[EpisodeReplay]:
    from hri_envs.physics.carry.parallel import CarryParallelEnv  # noqa: PLC0415

    meta = _settings(session)
    env = CarryParallelEnv(dataset.scenario, version=1, max_time_s=meta.get("max_time_s"))
    robot = make_robot(meta["agent"], dataset.graph, int(meta["robot_seed"]))
    human = HumanParams.of(dict(meta.get("human_params") or {}))
    rows = table.to_pylist()
    out = []
    try:
        for episode in sorted({r["episode"] for r in rows}):
            steps = [r for r in rows if r["episode"] == episode]
            out.append(_episode(env, robot, human, meta, episode, steps, say))
    finally:
        env.close()
    return out


def _differs(name: str, recorded: Any, replayed: Any, tolerance: float) -> str | None:
    a, b = np.asarray(recorded, dtype=np.float64), np.asarray(replayed, dtype=np.float64)
    if a.shape != b.shape or not np.allclose(a, b, rtol=0.0, atol=tolerance):
        worst = float(np.max(np.abs(a - b))) if a.shape == b.shape else float("nan")
        return f"{name} differs (largest difference {worst:.3g})"
    return None


def _episode(env: Any, robot: Any, human: HumanParams, meta: dict[str, Any], episode: int,
             steps: list[dict[str, Any]], say: Callable[[str], None]) -> EpisodeReplay:
    """One episode replayed from its recorded seed with the recorded hand targets."""
    from agents.physical import outcome_of  # noqa: PLC0415

    start, goal = (int(v) for v in meta["schedule"][episode][:2])
    obs, _ = env.reset(seed=int(meta["episode_seeds"][episode]),
                       options={"start": start, "intention": goal, "human": human})
    base = env.env
    task = base.robot_task()
    robot.begin_episode(task)
    differences: list[str] = []
    rewards: list[float] = []
    ended = (False, False)
    info: dict[str, Any] = {}
    for t, row in enumerate(steps):
        pos, quat = hand_pose(base.sim)
        a_r = np.asarray(robot.act(obs["robot"]), dtype=np.float32)
        a_h = human_action(pos, quat, np.asarray(row["hand_target"]), row["stiffness"],
                           base.sim.max_step_m, base.sim.max_step_rad)
        replayed = {"robot_observation": obs["robot"], "robot_action": a_r,
                    "human_action": a_h, "hand_pose": np.concatenate([pos, quat])}
        obs, reward, terms, truncs, infos = env.step({"robot": a_r, "human": a_h})
        replayed["hand_force"] = base.sim.handle_wrench()[0]
        rewards.append(float(reward["robot"]))
        found = [d for name, col, tol in _COMPARED
                 if (d := _differs(name, row[col], replayed[col], tol)) is not None]
        if reward["robot"] != row["reward"]:
            found.append(f"reward {reward['robot']:.6g} (recorded {row['reward']:.6g})")
        ended = (bool(terms["robot"]), bool(truncs["robot"]))
        if ended != (row["terminated"], row["truncated"]):
            found.append(f"the end (terminated, truncated) {ended} (recorded "
                         f"{(row['terminated'], row['truncated'])})")
        if found and not differences:
            differences.extend(f"episode {episode + 1} step {t}: {d}" for d in found)
        say(f"{meta['participant']} ep{episode + 1:02d} step {t:3d}: reward "
            f"{reward['robot']:+.4f} (recorded {row['reward']:+.4f})"
            + (f"  DIFFERS: {'; '.join(found)}" if found else ""))
        info = infos["robot"]
        if any(ended):
            break
    robot.end_episode(outcome_of(task, info, ended[1] and not ended[0]))
    last = steps[-1]
    return EpisodeReplay(str(meta["participant"]), episode,
                         np.array([r["reward"] for r in steps]), np.array(rewards),
                         (bool(last["terminated"]), ended[0]),
                         (bool(last["truncated"]), ended[1]), tuple(differences))
