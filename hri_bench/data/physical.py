"""The physical episode schema: a person (or a scripted human) leading the simulated arm.

A session of ``hri-bench serve --physical`` is recorded like a graph task's (the same
folders, ``dataset.json``, ``session.json``, one Parquet file per finished episode, the
same anonymous ids, consent by its text's hash: :mod:`hri_bench.data.datasets`) with one
row per 25 Hz step of the continuous env's parallel form (``hri_envs/*PandaContinuous-v1``,
:mod:`hri_envs.physics.carry.parallel`) in the columns :data:`PHYSICAL_COLUMNS`,
schema ``hri-envs/physical-episodes/1``. A row holds what both seats saw and did in the
step: the robot's and the human's observations before it, both actions, the participant's
target for their hand and the impedance scale they asked for, the hand's pose before the
step and the wrench it put on the handle at its end, the reward, the robot's belief where
it has one, and when the input arrived and the frame went out.

:func:`check_physical_steps` checks an episode file's values (the columns' kinds and nulls
are :func:`hri_bench.data.checks.read_episode`'s), :func:`robot_episodes` gives the robot's
Gymnasium view (the Minari export).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.data.checks import (
    check_ends,
    check_numbers,
    check_session,
    list_column,
    refusal,
)
from hri_envs.task.graph import TaskGraph

__all__ = ["ACTION_SIZE", "INPUTS", "PHYSICAL_COLUMNS", "PHYSICAL_SCHEMA", "STEP_S",
           "check_physical_steps", "hand_pose", "human_action", "observation_size",
           "robot_episode_arrays"]

#: The physical episode schema's version.
PHYSICAL_SCHEMA = "hri-envs/physical-episodes/1"
#: The env's step [s] (25 Hz) and action size.
STEP_S = 0.04
ACTION_SIZE = 7

#: One row per 25 Hz step (name, Arrow type, meaning); docs/people.md, "Physical sessions".
PHYSICAL_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("participant", "string", "anonymous participant id (random; nothing personal)"),
    ("session_index", "int32", "the participant's row of the counterbalanced design (join order)"),
    ("synthetic", "bool", "true for scripted humans (never human data)"),
    ("episode", "int32", "episode of the session, from 0"),
    ("step", "int32", "step of the episode, from 0"),
    ("start", "int8", "the episode's start support"),
    ("assigned_intention", "int8", "the goal the participant was given (their observation's "
     "one-hot)"),
    ("time_s", "float64", "simulated time [s] at the step's start (0.04 s steps)"),
    ("robot_observation", "list<float32>", "the robot's observation before the step (the "
     "env's: object, grip, joints, wrist wrench, start, supports, time)"),
    ("human_observation", "list<float32>", "the human seat's observation before the step: "
     "the robot's with the goal's one-hot appended"),
    ("final_observation", "list<float32>", "the robot's observation after the step on the "
     "episode's last step (empty before)"),
    ("robot_action", "list<float32>", "the robot's action (7, in [-1, 1])"),
    ("human_action", "list<float32>", "the human seat's action (7, in [-1, 1]): the hand's "
     "grip-frame target relative to the hand, the impedance scale"),
    ("hand_target", "list<float64>", "the participant's target for their hand's grip frame: "
     "x, y, z [m], qw, qx, qy, qz (world)"),
    ("stiffness", "float64", "the impedance scale the participant asked for (0-1)"),
    ("hand_pose", "list<float64>", "the hand's grip frame before the step: x, y, z, qw, qx, "
     "qy, qz"),
    ("hand_force", "list<float64>", "the force [N] the hand puts on the handle at the "
     "step's end (world)"),
    ("hand_torque", "list<float64>", "the torque [N m] the hand puts on the handle at the "
     "step's end (world, about the handle)"),
    ("reward", "float64", "the env's reward of the step (both seats get it)"),
    ("terminated", "bool", "this step ended the episode (placed, dropped, slipped, too weak)"),
    ("truncated", "bool", "the episode stopped after this step without ending (time limit)"),
    ("belief", "list<float64>", "the robot's belief over the supports as the goal when it "
     "acted; null if the robot exposes none"),
    ("input", "string", "what the participant moved the target with since the last step: "
     "mouse, touch, keys, buttons, none, or scripted"),
    ("t_input", "float64", "Unix time [s] the participant's input for the step arrived"),
    ("t_frame", "float64", "Unix time [s] the step's resulting frame was ready to send"),
    ("step_s", "float64", "the server's time [s] to simulate the step"),
    ("client_latency_ms", "float64", "input sent to resulting frame received [ms], measured "
     "in the browser; null where not measured"),
    ("placed", "int8", "the support the object came to rest on (the last step), else -1"),
    ("outcome", "string", "how the episode ended (last step: placed, wrong_support, timeout, "
     "dropped, slipped, too_weak, unstable, ik_failure); null before"),
    ("layout", "list<float64>", "the supports' layout (wheel stands x, y [m]); empty: nominal"),
)
#: Columns that may hold nulls.
NULLABLE: frozenset[str] = frozenset({"belief", "client_latency_ms", "outcome"})
#: List columns of a fixed length (the observations' depend on the scenario).
_FIXED = {"robot_action": ACTION_SIZE, "human_action": ACTION_SIZE, "hand_target": 7,
          "hand_pose": 7, "hand_force": 3, "hand_torque": 3}
#: How an episode may end (``info["episode"]["outcome"]`` of the v1 envs).
OUTCOMES: tuple[str, ...] = ("placed", "wrong_support", "timeout", "dropped", "slipped",
                             "too_weak", "unstable", "ik_failure")
#: Input kinds the page reports.
INPUTS: tuple[str, ...] = ("mouse", "touch", "keys", "buttons", "none", "scripted")


def human_action(hand_pos: np.ndarray, hand_quat: np.ndarray, target: np.ndarray,
                 stiffness: float, max_step_m: float, max_step_rad: float) -> np.ndarray:
    """The human seat's action (7, float32) that leads the hand's grip frame from
    (``hand_pos``, ``hand_quat``) towards ``target`` (x, y, z, qw, qx, qy, qz): the offset
    and the rotation vector in units of the action's scale, each shortened as a whole to at
    most 1 per component (the hand moves at most ``max_step_m`` and ``max_step_rad`` per
    step, in the target's direction), and the impedance scale ``2 stiffness - 1``
    (:meth:`hri_envs.physics.carry.sim.CarrySim.human_command` turns it into the hand's
    reference).
    """
    # Here, not at the top: the dataset checks (and so the CLI) must not import the physics
    # (MuJoCo, mink and, through qpsolvers, JAX, which makes a study spawn its workers).
    from hri_envs.physics.scene.kinematics import rotation_error  # noqa: PLC0415

    target = np.asarray(target, dtype=np.float64)
    move = (target[:3] - hand_pos) / max_step_m
    quat = target[3:] / np.linalg.norm(target[3:])
    turn = rotation_error(quat, hand_quat) / max_step_rad
    move = move / max(1.0, float(np.abs(move).max()))
    turn = turn / max(1.0, float(np.abs(turn).max()))
    return np.concatenate([move, turn, [2.0 * float(stiffness) - 1.0]]).astype(np.float32)


def hand_pose(sim: Any) -> tuple[np.ndarray, np.ndarray]:
    """The human's hand's grip frame in a continuous env's simulation now: (position,
    quaternion w, x, y, z).
    """
    import mujoco  # noqa: PLC0415

    data, site = sim.data, sim.arm.grip_site
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[site])
    return data.site_xpos[site].copy(), quat


def observation_size(graph: TaskGraph) -> int:
    """The robot's observation size of the continuous env of ``graph``'s scenario (hanger
    53, wheel 59: 13 + 7 + 2 joints + 6 + 4 K + 1; the joints its physical design's robot
    has, :func:`~hri_envs.physics.scene.build.robot_joints`).
    """
    from hri_envs.physics.scene.build import robot_joints  # noqa: PLC0415
    from hri_envs.physics.scene.design import design_for  # noqa: PLC0415

    joints = len(robot_joints(design_for(graph)))
    return 13 + 7 + 2 * joints + 6 + 4 * graph.n_intentions + 1


def _matrix(table: Any, name: str, width: int, path: Path) -> np.ndarray:
    """A list column of ``width`` finite values per row as an (N, width) array."""
    lengths, values = list_column(table.column(name))
    if (lengths != width).any():
        t = int(np.flatnonzero(lengths != width)[0])
        raise refusal(path, f"step {t}: {name} has {lengths[t]} values, not {width}")
    out = values.astype(np.float64).reshape(-1, width)
    bad = ~np.isfinite(out).all(axis=1)
    if bad.any():
        raise refusal(path, f"step {int(np.flatnonzero(bad)[0])}: {name} holds a value that "
                            "is not a finite number")
    return out


def check_physical_steps(table: Any, path: Path, graph: TaskGraph, *, participant: str,
                         synthetic: bool) -> None:
    """Raise a :class:`~hri_envs.errors.ConfigError` naming ``path`` and the step unless the
    table (one episode file, read by :func:`~hri_bench.data.checks.read_episode`) is one
    episode of ``participant``'s physical session on ``graph``'s scenario: steps 0, 1, ... of one
    episode, 0.04 s apart from 0; the start and the goal within the supports and the same
    in every step, and the observations' one-hots theirs; lists of the right sizes and
    finite; actions in [-1, 1]; the end (terminated or truncated) at the last step only,
    with its outcome and placed support; finite rewards and times; beliefs that are
    probabilities; one layout.
    """
    n = table.num_rows
    if n == 0:
        raise refusal(path, "holds no step (an episode file has one row per step)")
    skip = {name for name, kind, _ in PHYSICAL_COLUMNS if kind.startswith("list")}
    col = {name: table.column(name).to_numpy(zero_copy_only=False)
           for name in table.schema.names if name not in skip}
    check_session(col, path, participant, synthetic)
    k = graph.n_intentions
    for name in ("start", "assigned_intention"):
        x = col[name].astype(np.int64)
        if ((x < 0) | (x >= k)).any() or (x != x[0]).any():
            raise refusal(path, f"{name} must be one support in [0, {k}) for the episode, "
                                f"got {sorted(set(x.tolist()))[:5]}")
    start, goal = int(col["start"][0]), int(col["assigned_intention"][0])
    if start == goal:
        raise refusal(path, f"the goal {goal} is the start support")
    times = col["time_s"].astype(float)
    if not np.allclose(times, STEP_S * np.arange(n), atol=1e-6):
        t = int(np.flatnonzero(~np.isclose(times, STEP_S * np.arange(n), atol=1e-6))[0])
        raise refusal(path, f"step {t}: time_s {times[t]} is not {STEP_S * t:.2f} (steps of "
                            f"{STEP_S} s from 0)")
    n_obs = observation_size(graph)
    robot = _matrix(table, "robot_observation", n_obs, path)
    human = _matrix(table, "human_observation", n_obs + k, path)
    onehot = np.eye(k)
    if (human[:, :n_obs] != robot).any() or (human[:, n_obs:] != onehot[goal]).any():
        t = int(np.flatnonzero((human[:, :n_obs] != robot).any(1)
                               | (human[:, n_obs:] != onehot[goal]).any(1))[0])
        raise refusal(path, f"step {t}: human_observation is not the robot's with the "
                            f"goal {goal}'s one-hot appended")
    lengths, _ = list_column(table.column("final_observation"))
    if (lengths[:-1] != 0).any() or lengths[-1] != n_obs:
        raise refusal(path, f"final_observation must be empty before the last step and hold "
                            f"{n_obs} values at it")
    first_start = n_obs - 4 * k - 1  # the start's one-hot, then the seats, then the time
    if (robot[:, first_start:first_start + k] != onehot[start]).any():
        raise refusal(path, f"robot_observation's start one-hot is not support {start}'s")
    for name, width in _FIXED.items():
        x = _matrix(table, name, width, path)
        if name.endswith("_action") and (np.abs(x) > 1.0 + 1e-6).any():
            t = int(np.flatnonzero((np.abs(x) > 1.0 + 1e-6).any(1))[0])
            raise refusal(path, f"step {t}: {name} leaves [-1, 1]")
    _check_end(col, path, n, k)
    check_numbers(col, ("reward", "stiffness", "t_input", "t_frame", "step_s"), path)
    if ((col["stiffness"] < 0) | (col["stiffness"] > 1)).any():
        raise refusal(path, "stiffness must be in [0, 1]")
    bad = ~np.isin(col["input"], INPUTS)
    if bad.any():
        raise refusal(path, f"step {int(np.flatnonzero(bad)[0])}: input must be one of "
                            f"{', '.join(INPUTS)}")
    ms = col["client_latency_ms"].astype(float)
    if (np.isinf(ms) | (ms < 0)).any():
        raise refusal(path, "client_latency_ms must be null or a time >= 0")
    _check_belief_layout(table, path, k)


def _check_end(col: dict[str, np.ndarray], path: Path, n: int, k: int) -> None:
    """The episode ends at its last step only, with its outcome and placed support."""
    check_ends(col, path, n)
    outcome = col["outcome"]
    if any(o is not None for o in outcome[:-1]) or outcome[-1] not in OUTCOMES:
        raise refusal(path, f"outcome must be null before the last step and one of "
                            f"{', '.join(OUTCOMES)} at it, got {outcome[-1]!r}")
    placed = col["placed"].astype(np.int64)
    if (placed[:-1] != -1).any() or not -1 <= placed[-1] < k:
        raise refusal(path, "placed must be -1 before the last step and a support or -1 at "
                            "it")


def _check_belief_layout(table: Any, path: Path, k: int) -> None:
    lengths, beliefs = list_column(table.column("belief"))
    if ((lengths != k) & (lengths != -1)).any():
        t = int(np.flatnonzero((lengths != k) & (lengths != -1))[0])
        raise refusal(path, f"step {t}: belief has {lengths[t]} entries, not {k} or null")
    if (~np.isfinite(beliefs) | (beliefs < 0) | (beliefs > 1)).any():
        raise refusal(path, "belief holds a value that is not a probability")
    lengths, layout = list_column(table.column("layout"))
    if (lengths % 2).any() or (lengths != lengths[0]).any() or not np.isfinite(layout).all():
        raise refusal(path, "layout must be one list of finite (x, y) pairs for the episode")
    if lengths[0] and (layout.reshape(len(lengths), -1) != layout[:lengths[0]]).any():
        raise refusal(path, "layout differs between steps (one episode has one layout)")


def robot_episode_arrays(table: Any) -> Iterator[dict[str, Any]]:
    """The episodes of a physical steps table (sorted as :meth:`Dataset.steps` sorts) in
    the robot's Gymnasium view: ``observations`` (T+1, N) float32 (before each step, then
    the last step's ``final_observation``), ``actions`` (T, 7), ``rewards``,
    ``terminations``, ``truncations``, ``infos`` (``reached_intention``), ``participant``
    and ``episode``.
    """
    if table.num_rows == 0:
        return
    names = ("participant", "episode", "reward", "terminated", "truncated", "placed",
             "assigned_intention")
    col = {n: table.column(n).to_numpy(zero_copy_only=False) for n in names}
    obs = np.stack(table.column("robot_observation").to_numpy(zero_copy_only=False)
                   ).astype(np.float32)
    act = np.stack(table.column("robot_action").to_numpy(zero_copy_only=False)
                   ).astype(np.float32)
    final = table.column("final_observation").to_numpy(zero_copy_only=False)
    key = np.array([f"{p}/{e}" for p, e in zip(col["participant"], col["episode"],
                                               strict=True)])
    cuts = np.flatnonzero(key[1:] != key[:-1]) + 1
    for rows in np.split(np.arange(table.num_rows), cuts):
        n = len(rows)
        reached = np.zeros(n + 1, dtype=bool)
        reached[-1] = bool(col["placed"][rows[-1]] == col["assigned_intention"][rows[-1]])
        last = np.asarray(final[rows[-1]], dtype=np.float32)[None]
        yield {"observations": np.concatenate([obs[rows], last]),
               "actions": act[rows], "rewards": col["reward"][rows].astype(np.float64),
               "terminations": col["terminated"][rows].astype(bool),
               "truncations": col["truncated"][rows].astype(bool),
               "infos": {"reached_intention": reached},
               "participant": str(col["participant"][rows[0]]),
               "episode": int(col["episode"][rows[0]])}
