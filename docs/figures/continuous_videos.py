"""Short GIFs of the continuous envs: one episode of each policy on each scenario.

    MUJOCO_GL=egl .venv/bin/python docs/figures/continuous_videos.py --policies upper,passive \
        --out docs/figures

runs one episode of the v1 ids (``--seed``: the same start, goal and wheel layout for every
policy) of each policy of ``--policies`` (names of :data:`POLICIES`) on each scenario of
``--scenarios`` with ``render_mode="rgb_array"`` (the env's overview camera, the supports
labelled, the human's goal marked for the viewer), keeps every ``--every``-th step's picture
(fewer if the episode is long: at most ``--max-frames``), writes a caption on each
(scenario, policy, simulated time, and at the end how the episode ended) and saves
``continuous_<scenario>_<policy>.gif`` in ``--out``, played ``--speed`` times faster than
real time. A policy is added to the table by one line.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from PIL import Image, ImageDraw, ImageFont

import hri_envs  # noqa: F401  (registers the ids)
from agents.physical import PhysicalAgent, outcome_of
from baselines.physical import PHYSICAL_AGENTS, make_physical_agent
from hri_envs.registration import continuous_id
from hri_envs.task.scenarios import scenario_spec

#: What the caption calls a robot of the registry (else its name).
LABELS = {"upper": "upper reference", "passive": "passive robot",
          "admittance": "fixed admittance", "variable-admittance": "variable admittance",
          "goal-blend": "goal inference, blend", "goal-qmdp": "goal inference, QMDP",
          "learner": "lifted Learner", "rl": "residual RL"}


def _builder(name: str) -> Callable[[str], PhysicalAgent]:
    return lambda scenario: make_physical_agent(name, scenario, 0)


#: Policy name -> (what the caption calls it, a builder given the scenario's name): every
#: robot of ``baselines.physical.PHYSICAL_AGENTS``.
POLICIES: dict[str, tuple[str, Callable[[str], PhysicalAgent]]] = {
    name: (LABELS.get(name, name), _builder(name)) for name in PHYSICAL_AGENTS}


def caption(frame: np.ndarray, text: str) -> np.ndarray:
    """``frame`` with ``text`` on a dark strip along its top."""
    picture = Image.fromarray(frame)
    draw = ImageDraw.Draw(picture)
    size = max(9, frame.shape[0] // 22)
    draw.rectangle((0, 0, frame.shape[1], size + 6), fill=(30, 30, 30))
    draw.text((4, 3), text, font=ImageFont.load_default(size=size), fill=(255, 255, 255))
    return np.asarray(picture)


def outcome(info: dict[str, Any], names: tuple[str, ...]) -> str:
    """How an episode ended, in words."""
    if info.get("fault"):
        return str(info["fault"]).replace("_", " ")
    placed = int(info.get("placed", -1))
    if placed < 0:
        return "time out"
    return f"placed on {names[placed]}" + (" (goal)" if info.get("reached_intention")
                                           else " (not the goal)")


def record(scenario: str, policy: str, seed: int, every: int, max_frames: int,
           max_steps: int | None, size: tuple[int, int]) -> tuple[list[np.ndarray], float]:
    """One episode's captioned frames and the frame rate that plays it in real time (the
    last frame held 1.5 s).
    """
    label, build = POLICIES[policy]
    env_id = continuous_id(str(scenario_spec(scenario).continuous_id), 1)
    env = gym.make(env_id, render_mode="rgb_array", render_goal=True, render_size=size)
    base = env.unwrapped
    obs, _ = env.reset(seed=seed)
    agent = build(scenario)
    if agent.privileged:  # a reference reads the simulation
        agent.attach(base)
    task = base.robot_task()
    agent.begin_episode(task)
    shots: list[tuple[float, np.ndarray]] = [(0.0, env.render())]
    info: dict[str, Any] = {}
    truncated = False
    while max_steps is None or base.steps < max_steps:
        obs, _, terminated, truncated, info = env.step(agent.act(obs))
        if base.steps % every == 0 or terminated or truncated:
            shots.append((base.steps * base.sim.dt_step, env.render()))
        if terminated or truncated:
            agent.end_episode(outcome_of(task, info, truncated and not terminated))
            break
    env.close()
    keep = max(1, math.ceil(len(shots) / max_frames))  # a long episode: fewer frames
    shots = shots[::keep] if shots[-1] is shots[::keep][-1] else [*shots[::keep], shots[-1]]
    names = base.graph.support_names
    end = outcome(info, names) if info else "stopped"
    frames = [caption(image, f"{scenario}, {label}: t = {t:4.1f} s") for t, image in shots]
    last = caption(shots[-1][1], f"{scenario}, {label}: {end}, {shots[-1][0]:.1f} s")
    fps = 1.0 / (every * keep * base.sim.dt_step)
    return [*frames[:-1], *[last] * max(1, round(1.5 * fps))], fps  # hold the end 1.5 s


def write_gif(frames: list[np.ndarray], path: Path, fps: float, colors: int = 128) -> None:
    """Frames as a looping GIF on one palette of ``colors`` (drawn from the first, middle and
    last frames), without dithering: a small file whose colours do not flicker.
    """
    pictures = [Image.fromarray(frame) for frame in frames]
    sample = np.concatenate([frames[0], frames[len(frames) // 2], frames[-1]], axis=0)
    palette = Image.fromarray(sample).quantize(colors, method=Image.Quantize.MEDIANCUT,
                                               dither=Image.Dither.NONE)
    indexed = [p.quantize(palette=palette, dither=Image.Dither.NONE) for p in pictures]
    indexed[0].save(path, save_all=True, append_images=indexed[1:], loop=0,
                    duration=round(1000.0 / fps))


def main() -> None:
    """Write one GIF per scenario and policy into --out."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--policies", default="upper,passive",
                   help=f"comma-separated, from {', '.join(POLICIES)} (default upper,passive)")
    p.add_argument("--scenarios", default="hanger,wheel", help="default hanger,wheel")
    p.add_argument("--seed", type=int, default=1,
                   help="the episode's seed (default 1: the wheel from B to A, which the "
                        "passive robot does not place in its 45 s)")
    p.add_argument("--every", type=int, default=2,
                   help="keep every n-th 40 ms step's picture (default 2)")
    p.add_argument("--max-frames", type=int, default=150,
                   help="at most this many frames per GIF (default 150)")
    p.add_argument("--speed", type=float, default=2.0,
                   help="play this many times faster than real time (default 2)")
    p.add_argument("--max-steps", type=int, default=None,
                   help="stop an episode after this many steps (default: when it ends)")
    p.add_argument("--size", default="400x300", help="width x height in pixels (400x300)")
    p.add_argument("--out", default="out/videos", help="the folder (default out/videos)")
    args = p.parse_args()
    unknown = sorted(set(args.policies.split(",")) - set(POLICIES))
    if unknown:
        p.error(f"unknown policies {', '.join(unknown)}; allowed: {', '.join(POLICIES)}")
    width, height = (int(v) for v in args.size.split("x"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for scenario in args.scenarios.split(","):
        for policy in args.policies.split(","):
            frames, fps = record(scenario, policy, args.seed, args.every, args.max_frames,
                                 args.max_steps, (width, height))
            path = out / f"continuous_{scenario}_{policy}.gif"
            write_gif(frames, path, fps * args.speed)
            print(f"wrote {path} ({len(frames)} frames, {path.stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
