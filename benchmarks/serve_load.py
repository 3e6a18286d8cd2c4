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
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

import numpy as np

from hri_envs.humans.scripted import preference_human
from hri_envs.task.scenarios import scenario_graph


def start_server(data: str, episodes: int, sessions: int, scenario: str) -> tuple[
        subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "hri_bench.cli", "serve", scenario, "--port", "0", "--data", data,
         "--episodes", str(episodes), "--max-sessions", str(sessions), "--max-steps", "60"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert proc.stdout is not None
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        found = re.search(r"serving on (http://127\.0\.0\.1:\d+/)", line)
        if found:
            return proc, found.group(1)
        if not line:
            break
    proc.kill()
    raise SystemExit("the server did not start")


T0 = time.perf_counter()


def join(url: str) -> str:
    """Join as the page does: its Origin, the token it carries, JSON."""
    with urllib.request.urlopen(url, timeout=30) as r:
        page = r.read().decode()
    token = re.search(r'<meta name="hri-bench-token" content="([^"]+)">', page)
    assert token is not None, "the page carries no token"
    req = urllib.request.Request(url + "api/sessions", data=b'{"consent": true}',
                                 headers={"Content-Type": "application/json",
                                          "Origin": url.rstrip("/"),
                                          "X-HRI-Bench-Token": token.group(1)},
                                 method="POST")
    with urllib.request.urlopen(req, timeout=30) as r:
        return str(json.loads(r.read())["session"])


async def participant(url: str, think_ms: float, scenario: str, rng: random.Random,
                      steps: list[float], starts: list[float], errors: list[str],
                      deadline: float) -> None:
    import websockets

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
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as data:
        proc, url = start_server(data, args.episodes, args.sessions, args.scenario)
        load_before = os.getloadavg()
        t0 = time.perf_counter()
        try:
            steps, starts, errors = asyncio.run(run(url, args.sessions, args.think_ms,
                                                    args.scenario, args.seconds))
        finally:
            proc.send_signal(signal.SIGINT)
            proc.wait(30)
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
