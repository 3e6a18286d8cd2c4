"""Load benchmark of ``hri-bench serve``: N participants at once, each a websocket client.

Starts ``hri-bench serve`` as its own process on a free port of 127.0.0.1 (a temporary
data folder, the Learner as every participant's robot), then runs N clients in one asyncio
loop. Each joins, says hello and plays its session as a scripted person would (the
preferred action of the hanger's most frequent preference), waiting ``--think-ms`` (±50 %)
before each key press, and measures the time from sending an action to receiving the next
view (the next picture: a frame, or the episode's outcome), and from ``continue`` to the
next episode's first frame. All traffic stays on this machine and every loop is bounded
(episodes, steps, a deadline).

    .venv/bin/python benchmarks/serve_load.py --sessions 20 --episodes 8 --think-ms 300

Prints p50/p95/p99/max in milliseconds and the load average; ``--json`` adds one JSON line.
The time is what a client sees over the loopback, without the browser's own drawing.

``--physical`` serves the physical task instead (``hri-bench serve --physical``: each
session's env and robot in a process of its own) and each client leads the hand as the
page does, at 25 Hz in lockstep (:func:`hri_bench.people.synthetic.lead`: the reference
human's hand target, 40 ms after the last input or at once if that has passed); the time
measured is from sending an input to receiving the frame it produced, over every input and
over the inputs sent while all N clients were leading at once (the steady state, once the
last has started and before the first ends); ``--stagger S`` lets the clients join S
seconds apart. It also prints the CPU time the server and its session processes used per
step (episode starts and the processes' start included), which says how many cores N
sessions at 25 Hz need whatever else the machine runs:

    .venv/bin/python benchmarks/serve_load.py --physical --sessions 10 --episodes 4
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import resource
import subprocess
import tempfile
import time
from typing import Any

import numpy as np

from hri_bench.people.serve.launch import start_serve, stop_serve
from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios import scenario_graph


def start_server(data: str, episodes: int, sessions: int, scenario: str,
                 extra: tuple[str, ...] = ()) -> tuple[subprocess.Popen[str], str]:
    proc, url, lines = start_serve(
        [scenario, "--port", "0", "--data", data, "--episodes", str(episodes),
         "--max-sessions", str(sessions), "--max-steps", "60", *extra], timeout=120)
    if url is None:
        raise SystemExit("the server did not start:\n" + "".join(lines))
    return proc, url


T0 = time.perf_counter()


async def participant(url: str, think_ms: float, scenario: str, rng: random.Random,
                      steps: list[float], starts: list[float], errors: list[str],
                      deadline: float) -> None:
    import websockets

    from hri_bench.people.synthetic import join

    human = preference_human(scenario_graph(scenario), None)
    token = await asyncio.to_thread(join, url)
    ws_url = url.replace("http://", "ws://") + "ws"
    async with websockets.connect(ws_url, max_size=2**22) as ws:
        await ws.send(json.dumps({"type": "hello", "session": token}))
        sent_at, sent_kind = None, None
        while time.monotonic() < deadline:
            m = json.loads(await asyncio.wait_for(ws.recv(), 60))
            now = time.perf_counter()
            if m["type"] == "wait":
                continue
            if m["type"] == "error":
                errors.append(m["error"])
                continue
            if sent_at is not None:
                (steps if sent_kind == "action" else starts).append(1000 * (now - sent_at))
                if os.environ.get("SERVE_LOAD_DEBUG") and 1000 * (now - sent_at) > 200:
                    print(f"slow {1000 * (now - sent_at):.0f} ms at {now - T0:.1f} s -> "
                          f"{m['type']} ep {m.get('episode')} step {m.get('step')}")
                sent_at = None
            if m["type"] in ("done", "ended"):
                if m["type"] == "ended":
                    errors.append(f"ended: {m['reason']}")
                return
            if m["type"] == "outcome" and m["last"]:
                continue
            await asyncio.sleep(think_ms * rng.uniform(0.5, 1.5) / 1000)
            if m["type"] == "frame":
                a = int(human.preferred_action(np.array(m["state"]), np.array(m["start"]),
                                               np.array(m["goal"])))
                msg = {"type": "action", "seq": m["seq"], "action": a, "rt_ms": None}
            else:
                msg = {"type": "continue", "seq": m["seq"]}
            sent_at, sent_kind = time.perf_counter(), msg["type"]
            await ws.send(json.dumps(msg))
        errors.append("deadline")


async def run(url: str, n: int, think_ms: float, scenario: str, seconds: float
              ) -> tuple[list[float], list[float], list[str]]:
    steps: list[float] = []
    starts: list[float] = []
    errors: list[str] = []
    deadline = time.monotonic() + seconds
    await asyncio.gather(*(participant(url, think_ms, scenario, random.Random(i), steps, starts,
                                       errors, deadline) for i in range(n)))
    return steps, starts, errors


async def leaders(url: str, n: int, scenario: str, seconds: float, stagger: float) -> Any:
    """N clients leading the physical task's hand at once (``--physical``), the i-th joining
    ``i * stagger`` seconds after the first; one :class:`LeadStats` per client.
    """
    from hri_bench.people.synthetic import LeadStats, ScriptedLeader, lead
    from hri_envs.physics.carry.human.intention import HumanParams

    stats = [LeadStats() for _ in range(n)]
    deadline = time.monotonic() + seconds
    graph = scenario_graph(scenario)  # the command line's name, resolved once

    async def one(i: int) -> None:
        await asyncio.sleep(i * stagger)
        await lead(url, lambda _: ScriptedLeader(graph, HumanParams()), stats[i],
                   deadline=deadline)

    await asyncio.gather(*(one(i) for i in range(n)))
    return stats


def steady(stats: Any) -> np.ndarray:
    """The latencies measured while every client was leading: from the last client's first
    measured step to the first client's last one (empty when they never overlapped).
    """
    ats = [np.asarray(s.latency_at) for s in stats if s.latency_at]
    if len(ats) < len(stats):
        return np.zeros(0)
    start, end = max(a[0] for a in ats), min(a[-1] for a in ats)
    return np.concatenate([np.asarray(s.latency_ms)[(a >= start) & (a <= end)]
                           for s, a in zip(stats, ats, strict=True)])


def physical(args: argparse.Namespace) -> None:
    """``--physical``: the input-to-frame latency of N sessions leading the arm."""
    extra = ("--physical", *(("--agent", args.agent) if args.agent else ()))
    with tempfile.TemporaryDirectory() as data:
        proc, url = start_server(data, args.episodes, args.sessions, args.scenario, extra)
        load_before = os.getloadavg()
        t0 = time.perf_counter()
        try:
            per = asyncio.run(leaders(url, args.sessions, args.scenario, args.seconds,
                                      args.stagger))
        finally:
            stop_serve(proc, 60)
        wall = time.perf_counter() - t0
        load_after = os.getloadavg()
        # the server's and its session processes' CPU (reaped by it, then by us), and ours
        served = resource.getrusage(resource.RUSAGE_CHILDREN)
        ours = resource.getrusage(resource.RUSAGE_SELF)
        from hri_bench.data.datasets import open_dataset

        steps = open_dataset(f"{args.scenario}-physical-people-v0", data).steps()
        step_s = steps.column("step_s").to_numpy() * 1000 if steps.num_rows else np.zeros(1)
    every = [x for s in per for x in s.latency_ms]
    first = [x for s in per for x in s.first_ms]
    errors = [x for s in per for x in s.errors]
    lat = np.asarray(every) if every else np.full(1, np.nan)
    both = steady(per)
    q = np.percentile(lat, [50, 95, 99, 100])
    qq = np.percentile(both, [50, 95, 99, 100]) if both.size else np.full(4, np.nan)
    rate = len(every) / wall / max(1, args.sessions)
    print(f"{args.sessions} physical sessions x {args.episodes} {args.scenario} episodes "
          f"(joining {args.stagger:g} s apart): {len(every)} inputs in {wall:.1f} s "
          f"({rate:.1f} steps/s per session over the whole run; 25 is real time)")
    print(f"  input -> its frame, every input: p50 {q[0]:.1f} ms, p95 {q[1]:.1f} ms, "
          f"p99 {q[2]:.1f} ms, max {q[3]:.1f} ms")
    print(f"  input -> its frame, while all {args.sessions} lead ({both.size} inputs): "
          f"p50 {qq[0]:.1f} ms, p95 {qq[1]:.1f} ms, p99 {qq[2]:.1f} ms, max {qq[3]:.1f} ms")
    print(f"  the server's step p50 {np.percentile(step_s, 50):.1f} ms, "
          f"p95 {np.percentile(step_s, 95):.1f} ms")
    qs = np.percentile(first, [50, 95]) if first else [np.nan] * 2
    print(f"  hello/continue -> an episode's first frame: p50 {qs[0]:.0f} ms, p95 {qs[1]:.0f} ms")
    cpu_server = served.ru_utime + served.ru_stime
    cpu_clients = ours.ru_utime + ours.ru_stime
    per_step = 1000 * cpu_server / max(1, len(every))
    print(f"  CPU: the server and its sessions {cpu_server:.0f} s ({per_step:.1f} ms a step, "
          f"episode starts included: {args.sessions} sessions at 25 Hz need "
          f"{per_step * 25 * args.sessions / 1000:.2f} cores), these clients "
          f"{cpu_clients:.0f} s")
    print(f"  load average before {load_before[0]:.2f}, after {load_after[0]:.2f}; "
          f"{os.cpu_count()} cores; errors: {len(errors)} {errors[:3]}")
    if args.json:
        print(json.dumps({"physical": True, "sessions": args.sessions, "inputs": len(every),
                          "stagger_s": args.stagger, "p50_ms": q[0], "p95_ms": q[1],
                          "p99_ms": q[2], "max_ms": q[3], "steady_inputs": int(both.size),
                          "steady_p50_ms": qq[0], "steady_p95_ms": qq[1],
                          "steady_p99_ms": qq[2], "steps_per_s": rate,
                          "load_before": load_before, "load_after": load_after,
                          "errors": errors[:5], "wall_s": wall,
                          "cpu_server_s": cpu_server, "cpu_clients_s": cpu_clients}))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sessions", type=int, default=20, help="participants at once (20)")
    p.add_argument("--episodes", type=int, default=8, help="episodes per session (8)")
    p.add_argument("--think-ms", type=float, default=300.0,
                   help="mean wait before each key press, ms (300; 0: as fast as possible)")
    p.add_argument("--scenario", choices=("hanger", "wheel"), default="hanger",
                   help="the scenario the participants play (default hanger)")
    p.add_argument("--seconds", type=float, default=600.0, help="deadline (600 s)")
    p.add_argument("--json", action="store_true", help="end with one JSON line")
    p.add_argument("--physical", action="store_true",
                   help="the physical task: clients lead the hand at 25 Hz")
    p.add_argument("--agent", default=None, help="the robot (default: serve's)")
    p.add_argument("--stagger", type=float, default=0.0,
                   help="--physical: seconds between two clients joining (0: all at once)")
    args = p.parse_args()
    if args.physical:
        physical(args)
        return
    with tempfile.TemporaryDirectory() as data:
        proc, url = start_server(data, args.episodes, args.sessions, args.scenario)
        load_before = os.getloadavg()
        t0 = time.perf_counter()
        try:
            steps, starts, errors = asyncio.run(run(url, args.sessions, args.think_ms,
                                                    args.scenario, args.seconds))
        finally:
            stop_serve(proc, 30)
        wall = time.perf_counter() - t0
        load_after = os.getloadavg()
    q = np.percentile(steps, [50, 95, 99, 100]) if steps else [float("nan")] * 4
    qs = np.percentile(starts, [50, 95]) if starts else [float("nan")] * 2
    print(f"{args.sessions} sessions x {args.episodes} {args.scenario} episodes, think "
          f"{args.think_ms:.0f} ms: {len(steps)} key presses in {wall:.1f} s")
    print(f"  key press -> next picture: p50 {q[0]:.1f} ms, p95 {q[1]:.1f} ms, "
          f"p99 {q[2]:.1f} ms, max {q[3]:.1f} ms")
    print(f"  next episode (continue -> first frame, the robot has learned): p50 "
          f"{qs[0]:.1f} ms, p95 {qs[1]:.1f} ms")
    print(f"  load average before {load_before[0]:.2f}, after {load_after[0]:.2f}; "
          f"{os.cpu_count()} cores; errors: {len(errors)}")
    if args.json:
        print(json.dumps({"sessions": args.sessions, "episodes": args.episodes,
                          "think_ms": args.think_ms, "presses": len(steps),
                          "p50_ms": q[0], "p95_ms": q[1], "p99_ms": q[2], "max_ms": q[3],
                          "continue_p50_ms": qs[0], "continue_p95_ms": qs[1],
                          "load_before": load_before, "load_after": load_after,
                          "errors": errors[:5], "wall_s": wall}))


if __name__ == "__main__":
    main()
