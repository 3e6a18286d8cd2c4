"""Record how the continuous envs' episodes end, for tests/test_physics_continuous_reference.py.

The reference file ``continuous_reference.json`` was written by the continuous envs as they
were before their control periods were compiled (numba) for speed; the test replays a few of
its episodes with today's code and asks for the same ends: the same last step and outcome
(placed, fault, goal reached), the human's effort and the interaction measures within 1e-6
relative, the object's final position within 1e-6 m, the wrist's last reading within 1e-6
(relative, or N). ``--check`` replays every recorded
episode and prints the largest differences (the full equivalence check). Re-running without
``--check`` overwrites the reference with the *current* code's numbers, so only do that on
purpose.

Cases: both scenarios with the upper reference and the passive floor, seeds 0-19 (the
torque-driven arm); the human carrying alone (``robot_holds=False``, the passive robot),
seeds 0-2; the human seat as an agent (the parallel env, seeded random human actions, a
passive robot), seeds 0-2, 100 steps; the muscle-driven arm, seed 0, 40 steps; a smaller
human's body (female, 1.55 m, 55 kg: the hanger with the upper reference, the wheel with the
passive floor), seeds 0-1.

``--check --perturb 1e-15`` shows how far rounding alone moves each episode's end: the
object moved by 1e-15 m after the reset (a few units in the last place) moves the ends of
the passive wheel's time-outs (seeds 6 and 15) by more than 1e-6 relative, in the code that
recorded the reference as in today's.

Usage::

    python tests/data/make_continuous_reference.py [--check [--perturb M]] [--cases NAME,...]
        [OUT.json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import hri_envs  # noqa: F401
from baselines.continuous import PASSIVE_ACTION, UpperReference
from hri_envs.physics.carry.parallel import parallel_env
from hri_envs.task.scenarios import scenario_spec

DEFAULT = Path(__file__).parent / "continuous_reference.json"
SEEDS = range(20)
#: (name, scenario, policy, seeds, drive, step limit or None, robot holds)
CASES: tuple[tuple[str, str, str, range, str, int | None, bool], ...] = tuple(
    (f"{sc}-{pol}", sc, pol, SEEDS, "torque", None, True)
    for sc in ("hanger", "wheel") for pol in ("upper", "passive")) + tuple(
    (f"{sc}-alone", sc, "passive", range(3), "torque", None, False)
    for sc in ("hanger", "wheel")) + tuple(
    (f"{sc}-human-agent", sc, "human-agent", range(3), "torque", 100, True)
    for sc in ("hanger", "wheel")) + (
    ("wheel-muscle", "wheel", "upper", range(1), "muscle", 40, True),) + tuple(
    (f"{sc}-body", sc, pol, range(2), "torque", None, True)
    for sc, pol in (("hanger", "upper"), ("wheel", "passive")))
#: The humans of the cases whose name ends so (default: the scenario's default human).
HUMANS: dict[str, dict[str, Any]] = {
    "body": {"sex": "female", "stature_m": 1.55, "body_mass_kg": 55.0}}
#: The CarryStep fields summed over an episode, and the one whose maximum is kept.
SUMMED = ("effort", "linear_impulse", "angular_impulse", "disagreement", "force_sq", "jerk_sq")


def episode(env: Any, parallel: Any, policy: str, seed: int, limit: int | None,
            robot_holds: bool, perturb: float = 0.0) -> dict[str, Any]:
    """Run one episode; what it ended with. ``perturb`` [m] moves the object along x right
    after the reset (a probe of how sensitive the episode is to rounding).
    """
    base = env.unwrapped if parallel is None else parallel.env
    steps: list[Any] = []
    step = base.sim.step

    def recording(*args: Any, **kwargs: Any) -> Any:
        res = step(*args, **kwargs)
        steps.append(res)
        return res

    base.sim.step = recording
    options = {"robot_holds": robot_holds}
    rng = np.random.default_rng(seed)
    if parallel is None:
        obs, _ = env.reset(seed=seed, options=options)
    else:
        obs = parallel.reset(seed=seed, options=options)[0]["robot"]
    if perturb:
        sim = base.sim
        sim.data.qpos[sim.scene.object_qpos[0]] += perturb
        mujoco.mj_forward(sim.model, sim.data)
    upper = UpperReference()
    upper.attach(base)
    upper.begin_episode(base.robot_task())
    total, n = 0.0, 0
    while True:
        action = upper.act(obs) if policy == "upper" else PASSIVE_ACTION.copy()
        if parallel is None:
            obs, reward, term, trunc, info = env.step(action)
        else:
            human = np.clip(0.4 * rng.standard_normal(7) + [0, 0, 0, 0, 0, 0, 0.5], -1, 1)
            out, rewards, terms, truncs, infos = parallel.step({"robot": action,
                                                                "human": human})
            obs, reward, term, trunc, info = (out["robot"], rewards["robot"], terms["robot"],
                                              truncs["robot"], infos["robot"])
        total += reward
        n += 1
        if term or trunc or (limit is not None and n >= limit):
            break
    del base.sim.step
    pose = base.sim.object_pose()
    ends = {
        "steps": n, "terminated": bool(term), "truncated": bool(trunc),
        "fault": info.get("fault"), "fault_detail": info.get("fault_detail"),
        "placed": int(info["placed"]), "reached": bool(info["reached_intention"]),
        "episode_effort": float(info["episode_effort"]), "return": float(total),
        "peak_force": max(float(r.peak_force) for r in steps),
        "pos": pose.pos.tolist(), "quat": pose.quat.tolist(),
        "sensed": base.sim.sensed.tolist(), "obs": np.asarray(obs, float).tolist()}
    for key in SUMMED:
        ends[key] = float(sum(getattr(r, key) for r in steps))
    return ends


def run_case(name: str, seeds: range | list[int] | None = None,
             perturb: float = 0.0) -> list[dict[str, Any]]:
    """The ends of case ``name``'s episodes (its seeds, or ``seeds``)."""
    _, scenario, policy, case_seeds, drive, limit, holds = next(c for c in CASES
                                                                 if c[0] == name)
    env = parallel = None
    human = HUMANS.get(name.rsplit("-", 1)[-1])
    if policy == "human-agent":
        parallel = parallel_env(scenario)
    else:
        env = gym.make(str(scenario_spec(scenario).continuous_id), drive=drive, human=human)
    return [{"seed": s, **episode(env, parallel, policy, s, limit, holds, perturb)}
            for s in (case_seeds if seeds is None else seeds)]


def record(names: set[str] | None = None,
           perturb: float = 0.0) -> dict[str, list[dict[str, Any]]]:
    """Every case's episodes (or those of ``names``)."""
    out: dict[str, list[dict[str, Any]]] = {}
    for name, *_ in CASES:
        if names is None or name in names:
            out[name] = run_case(name, perturb=perturb)
            print(f"{name}: {len(out[name])} episodes", file=sys.stderr, flush=True)
    return out


def compare(ref: dict[str, Any], got: dict[str, Any]) -> list[str]:
    """How ``got`` (an episode's ends) differs from ``ref`` beyond the tolerances:
    the same step count and outcome, sums within 1e-6 relative (1e-9 absolute), the object's
    final position within 1e-6 m.
    """
    bad = [f"{k}: {ref[k]!r} != {got[k]!r}" for k in
           ("steps", "terminated", "truncated", "fault", "placed", "reached") if ref[k] != got[k]]
    for k in ("episode_effort", "return", "peak_force", *SUMMED):
        if not math.isclose(ref[k], got[k], rel_tol=1e-6, abs_tol=1e-9):
            bad.append(f"{k}: {ref[k]!r} != {got[k]!r}")
    off = float(np.max(np.abs(np.subtract(ref["pos"], got["pos"]))))
    if off > 1e-6:
        bad.append(f"object position off by {off:.3g} m")
    if not np.allclose(got["sensed"], ref["sensed"], rtol=1e-6, atol=1e-6):
        bad.append(f"wrist reading {got['sensed']} != {ref['sensed']}")
    return bad


def deviations(ref: dict[str, Any], got: dict[str, Any]) -> tuple[float, float]:
    """The largest relative difference of the sums and the position's difference [m]."""
    rel = max(abs(ref[k] - got[k]) / max(abs(ref[k]), 1e-9)
              for k in ("episode_effort", "peak_force", *SUMMED))
    return rel, float(np.max(np.abs(np.subtract(ref["pos"], got["pos"]))))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", nargs="?", type=Path, default=DEFAULT)
    p.add_argument("--check", action="store_true",
                   help="replay every recorded episode and compare (writes nothing)")
    p.add_argument("--cases", default=None, help="comma-separated case names (default all)")
    p.add_argument("--perturb", type=float, default=0.0,
                   help="with --check: move the object by this much [m] along x after each "
                        "reset (how far rounding alone moves an episode's end)")
    args = p.parse_args()
    names = set(args.cases.split(",")) if args.cases else None
    if not args.check:
        args.out.write_text(json.dumps(record(names), indent=1) + "\n")
        return
    reference = json.loads(args.out.read_text())
    failed = 0
    for name, episodes in record(names, args.perturb).items():
        worst_rel = worst_pos = 0.0
        for ref, got in zip(reference[name], episodes, strict=True):
            bad = compare(ref, got)
            rel, pos = deviations(ref, got)
            worst_rel, worst_pos = max(worst_rel, rel), max(worst_pos, pos)
            if bad:
                failed += 1
                print(f"{name} seed {ref['seed']}: " + "; ".join(bad))
        print(f"{name}: {len(episodes)} episodes, largest relative difference {worst_rel:.2g}, "
              f"position {worst_pos:.2g} m")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
