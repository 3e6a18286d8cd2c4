"""The process a physical session's simulation and robot run in.

``python -m hri_bench.people.serve.lead_worker`` is started by
:mod:`hri_bench.people.serve.lead_process` for each physical session of ``hri-bench serve``
(and by replays and tools that drive the same path). It holds the continuous env's parallel
form (``hri_envs/*PandaContinuous-v1``, the human seat as an agent:
:mod:`hri_envs.physics.carry.parallel`) and the robot, and answers messages
(:mod:`hri_bench.run.wire`: JSON and raw arrays, never pickle) on its standard input and
output; the robot's own prints go to standard error:

* ``init``: make the env and the robot (``scenario``, ``agent``, ``seed``, ``human``);
* ``reset``: an episode (``seed``, ``start``, ``goal``); answered with its first frame
  (the drawn bodies' poses, the hand's pose, the camera; the scene's description when this
  process has not sent it yet);
* ``step``: one 25 Hz step with the participant's ``target`` for their hand's grip frame
  and ``stiffness`` (:func:`human_action` makes the human seat's action of them: exactly
  where a person's input goes in the env,
  :func:`hri_bench.data.physical.human_action`), the robot acting on the same observation;
  answered with the next frame. The robot's next action is computed right after the answer
  is sent, while the page draws and the participant moves;
* ``end``: the robot learns from the episode (the goal revealed where the object was
  placed); answered with the episode's recorded steps as arrays;
* ``close``.

A robot that raises is answered as ``{"ok": false, "error", "detail"}`` naming the call.
"""

from __future__ import annotations

import math
import sys
import time
import traceback
from collections.abc import Mapping
from typing import Any

import numpy as np

from agents.physical import PhysicalAgent, outcome_of
from hri_bench.core.physical_robots import make_robot
from hri_bench.data.physical import hand_pose, human_action
from hri_bench.people import scene3d
from hri_bench.run.agent_host import host_pipes
from hri_bench.run.wire import read_message, write_message
from hri_envs.physics.carry.human.intention import HumanParams

__all__ = ["Lead", "main"]

#: The aspect (width / height) of the page's view the camera is fitted for.
ASPECT = 1.5


class RobotFailed(Exception):
    """The robot raised in one of its calls."""

    def __init__(self, call: str, exc: BaseException) -> None:
        kind = type(exc).__name__
        super().__init__(f"the robot's program failed ({kind} in {call})")
        self.public = str(self)
        self.detail = f"the agent's {call} raised {kind}: {str(exc)[:300]}"


def _call(call: str, fn: Any, *args: Any) -> Any:
    try:
        return fn(*args)
    except Exception as exc:  # the robot's error, named to the session
        traceback.print_exc(file=sys.stderr)
        raise RobotFailed(call, exc) from None


class Lead:
    """One physical session's env and robot.

    Args:
        scenario: "hanger" or "wheel".
        agent: The robot's name (:mod:`hri_bench.core.physical_robots`).
        seed: The robot's seed.
        human: The human seat's body and arm (:class:`HumanParams` as a mapping).
        drive: The arm's drive.
        max_time_s: The time limit per episode (None: the env's).
    """

    def __init__(self, scenario: str, agent: str, seed: int, human: Mapping[str, Any],
                 drive: str = "torque", max_time_s: float | None = None) -> None:
        from hri_envs.physics.carry.parallel import CarryParallelEnv  # noqa: PLC0415

        self.scenario = scenario
        self.env = CarryParallelEnv(scenario, version=1, drive=drive, max_time_s=max_time_s)
        self.base = self.env.env
        self.sim: Any = self.base.sim  # CarrySim: the hand's site and wrench
        self.human = HumanParams.of(dict(human))
        self.robot: PhysicalAgent = _call("making the agent", make_robot, agent,
                                          self.base.graph, int(seed))
        self.sent: set[str] = set()
        self.cameras: dict[tuple[Any, ...], dict[str, Any]] = {}
        self.rows: list[dict[str, Any]] = []
        self.obs: dict[str, np.ndarray] = {}
        self.pending: tuple[np.ndarray, list[float] | None] | None = None
        self.error: RobotFailed | None = None
        self.task: Any = None
        self.final: np.ndarray = np.zeros(0, np.float32)
        self.outcome: dict[str, Any] = {}

    # ------------------------------------------------------------------ the frames
    def _hand(self) -> tuple[np.ndarray, np.ndarray]:
        return hand_pose(self.sim)

    def _frame(self) -> dict[str, Any]:
        """What the page draws now (poses, the hand, its force on the handle)."""
        pos, quat = self._hand()
        force, _ = self.sim.handle_wrench()
        handle = self.sim.data.site_xpos[self.sim.arm.handle_site]
        return {"poses": scene3d.body_poses(self.sim.data, self.bodies),
                "hand": [round(float(v), 5) for v in (*pos, *quat)],
                "handle": [round(float(v), 4) for v in handle],
                "force": [round(float(v), 2) for v in force]}

    def _scene(self) -> tuple[dict[str, Any], bytes | None]:
        """The scene's key, and its description if this process has not sent it."""
        model = self.sim.model
        self.bodies = scene3d.drawn_bodies(model)
        doc = scene3d.describe(model, labels=self.base.graph.support_names,
                               rotation_axis=scene3d.rotation_axis(
                                   self.base.graph.scenario.orientations))
        key = str(doc["key"])
        if key in self.sent:
            return {"scene": key}, None
        self.sent.add(key)
        import json  # noqa: PLC0415

        return {"scene": key}, json.dumps(doc, separators=(",", ":")).encode()

    # ------------------------------------------------------------------ the episode
    def reset(self, seed: int, start: int, goal: int) -> tuple[dict[str, Any], bytes | None]:
        """Start an episode; its first frame (and the scene's description when new)."""
        self.obs, _ = self.env.reset(seed=int(seed), options={
            "start": int(start), "intention": int(goal), "human": self.human})
        self.rows, self.final, self.outcome = [], np.zeros(0, np.float32), {}
        scene, text = self._scene()
        self.task = self.base.robot_task()
        _call("begin_episode()", self.robot.begin_episode, self.task)
        self.pending, self.error = None, None
        self.prepare()
        seats = self.sim.seat_positions()
        layout = [] if self.base.layout is None else [float(v) for xy in self.base.layout
                                                       for v in xy]
        frame = self._frame()
        return {**scene, **frame, "belief": self._belief(), "camera": self._camera(
                    scene["scene"], seats, frame["poses"]),
                "layout": layout, "time_s": 0.0,
                "time_limit_s": self.base.time_limit_s}, text

    def _camera(self, key: str, seats: np.ndarray, poses: list[float]) -> dict[str, Any]:
        """The page's camera for the episode's start (:func:`scene3d.camera`), reused for a
        start drawn alike (the same scene, seats and bodies' poses to the centimetre): the
        renderer's choice of azimuth draws a few dozen small pictures, most of a reset's time.
        """
        start = (key, *np.round(np.asarray(seats, dtype=float), 2).ravel().tolist(),
                 *np.round(np.asarray(poses, dtype=float), 2).tolist())
        if start not in self.cameras:
            self.cameras[start] = scene3d.camera(self.sim.model, self.sim.data, seats, ASPECT,
                                                 self._score())
        return self.cameras[start]

    def _score(self) -> Any:
        """The renderer's judge of a view (made once; None without offscreen GL)."""
        if not hasattr(self, "_view_score"):
            self._view_score = scene3d.view_score(self.sim.model, ASPECT)
        return self._view_score

    def _belief(self) -> list[float] | None:
        return None if self.pending is None else self.pending[1]

    def prepare(self) -> None:
        """The robot's action (and belief) for the current observation, computed ahead."""
        if self.pending is not None or self.error is not None or not self.env.agents:
            return
        try:
            action = np.asarray(_call("act()", self.robot.act, self.obs["robot"]),
                                dtype=np.float32)
            belief = _call("belief()", self.robot.belief)
        except RobotFailed as exc:
            self.error = exc
            return
        self.pending = (action, None if belief is None else
                        [round(float(b), 4) for b in np.asarray(belief).ravel()])

    def step(self, target: np.ndarray, stiffness: float) -> dict[str, Any]:
        """One step with the participant's hand target; the next frame."""
        began = time.perf_counter()
        self.prepare()
        if self.error is not None:
            raise self.error
        assert self.pending is not None
        a_r, belief = self.pending
        self.pending = None
        pos, quat = self._hand()
        a_h = human_action(pos, quat, target, stiffness, self.sim.max_step_m,
                           self.sim.max_step_rad)
        before = self.obs
        t = len(self.rows) * self.sim.dt_step
        self.obs, rewards, terms, truncs, infos = self.env.step({"robot": a_r, "human": a_h})
        force, torque = self.sim.handle_wrench()
        term, trunc = bool(terms["robot"]), bool(truncs["robot"])
        info = infos["robot"]
        row = {"time_s": round(t, 6), "robot_observation": before["robot"],
               "human_observation": before["human"], "robot_action": a_r, "human_action": a_h,
               "hand_target": np.asarray(target, dtype=np.float64),
               "stiffness": float(stiffness), "hand_pose": np.concatenate([pos, quat]),
               "hand_force": force.copy(), "hand_torque": torque.copy(),
               "reward": float(rewards["robot"]), "terminated": term, "truncated": trunc,
               "belief": belief}
        frame = {**self._frame(), "reward": row["reward"], "time_s": round(t + 0.04, 4),
                 "done": term or trunc}
        if term or trunc:
            self.final = np.asarray(self.obs["robot"], dtype=np.float32)
            ep = info.get("episode", {})
            self.outcome = {"placed": int(info.get("placed", -1)),
                            "outcome": str(ep.get("outcome", "timeout")),
                            "reached": bool(info.get("reached_intention", False)),
                            "fault": info.get("fault"), "figures": _plain(ep),
                            "truncated": trunc and not term}
            frame.update(self.outcome)
        row["step_s"] = time.perf_counter() - began
        self.rows.append(row)
        return frame

    def end(self) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The robot learns from the episode; its recorded steps as arrays."""
        info = {"placed": self.outcome.get("placed", -1), "fault": self.outcome.get("fault"),
                "episode": self.outcome.get("figures", {})}
        _call("end_episode()", self.robot.end_episode,
              outcome_of(self.task, info, bool(self.outcome.get("truncated", False))))
        rows = self.rows
        k = self.base.graph.n_intentions
        arrays = {name: np.stack([np.asarray(r[name]) for r in rows]) for name in
                  ("robot_observation", "human_observation", "robot_action", "human_action",
                   "hand_target", "hand_pose", "hand_force", "hand_torque")}
        arrays.update({name: np.array([r[name] for r in rows]) for name in
                       ("time_s", "stiffness", "reward", "terminated", "truncated",
                        "step_s")})
        arrays["belief"] = np.array([r["belief"] if r["belief"] is not None
                                     else [math.nan] * k for r in rows], dtype=np.float64)
        arrays["final_observation"] = self.final
        layout = [] if self.base.layout is None else [float(v) for xy in self.base.layout
                                                       for v in xy]
        return {"placed": int(self.outcome.get("placed", -1)),
                "outcome": self.outcome.get("outcome", "timeout"), "layout": layout}, arrays


def _plain(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """An episode's figures as JSON numbers and strings (NaN as None)."""
    out: dict[str, Any] = {}
    for k, v in metrics.items():
        if isinstance(v, bool | int | str) or v is None:
            out[k] = v
        elif isinstance(v, float | np.floating):
            out[k] = float(v) if math.isfinite(float(v)) else None
    return out


def _serve(inbox: Any, outbox: Any) -> None:
    lead: Lead | None = None
    while True:
        try:
            header, arrays = read_message(inbox)
        except EOFError:
            return
        op = header.get("op")
        try:
            if op == "close":
                write_message(outbox, {"ok": True})
                return
            if op == "init":
                lead = Lead(header["scenario"], header["agent"], int(header["seed"]),
                            header.get("human") or {}, header.get("drive", "torque"),
                            header.get("max_time_s"))
                write_message(outbox, {"ok": True})
                continue
            assert lead is not None, "init first"
            if op == "reset":
                frame, text = lead.reset(header["seed"], header["start"], header["goal"])
                scene = {} if text is None else {"scene_json": np.frombuffer(text, np.uint8)}
                write_message(outbox, {"ok": True, **frame}, scene)
            elif op == "step":
                frame = lead.step(arrays["target"], float(header["stiffness"]))
                write_message(outbox, {"ok": True, **frame})
                lead.prepare()  # the robot's next action, while the page draws
            elif op == "end":
                summary, columns = lead.end()
                write_message(outbox, {"ok": True, **summary}, columns)
            else:
                write_message(outbox, {"ok": False, "error": f"unknown op {op!r}",
                                       "detail": f"unknown op {op!r}"})
        except RobotFailed as exc:
            write_message(outbox, {"ok": False, "error": exc.public, "detail": exc.detail})
        except Exception as exc:  # the simulation's: the session fails, named
            traceback.print_exc(file=sys.stderr)
            write_message(outbox, {"ok": False, "error": f"the simulation failed "
                                   f"({type(exc).__name__})",
                                   "detail": f"{type(exc).__name__}: {str(exc)[:300]}"})


def main() -> None:
    """Serve the server's process until it closes the pipe or says ``close``."""
    inbox, outbox = host_pipes()  # the robot's prints go to standard error
    # imported now, so that a process started ahead of a session has them ready
    import hri_envs.physics.carry.parallel  # noqa: F401, PLC0415
    from hri_bench.core.physical_robots import robot_names  # noqa: PLC0415

    robot_names()
    _serve(inbox, outbox)


if __name__ == "__main__":
    main()
