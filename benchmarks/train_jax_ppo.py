"""Train the recurrent PPO robot in JAX against a population, draw its learning curve.

1. Train :mod:`agents.jax_ppo` (GRU actor-critic, PPO; rollouts, GAE and updates under one
   ``jit``) on :class:`hri_envs.jax.JaxRobotEnv`, in trials of the scenario's study length
   (hanger 8, wheel 20 episodes) with one human of the training population each.
2. Save ``OUT/<scenario>.npz`` (arrays + JSON config, no pickle), ``OUT/<scenario>_curve.json``
   and ``OUT/<scenario>_curve.png`` (mean episode return per update, against env steps, with a
   random valid-action policy's level for reference).
3. Rank it beside the Learner: ``hri-bench suite --agents learner,jaxppo:OUT``.

    .venv/bin/python benchmarks/train_jax_ppo.py --scenario hanger --total-steps 25000000
    .venv/bin/python benchmarks/train_jax_ppo.py --scenario wheel --total-steps 12000000

``--out`` (default ``out/jaxppo``) must be new, empty, or a folder this script wrote (it
keeps a list of its files there, :data:`MARKER`): a folder of other files is refused, not
overwritten. The package's shipped checkpoints (``agents/jax_ppo/checkpoints``) are
replaced only with ``--overwrite-shipped``; other folders of the packages and ``docs/`` are
refused. Same ``--seed``, same weights (on the same machine and JAX version).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import tyro

import agents
import baselines
import hri_bench
import hri_envs
from agents.jax_ppo.train import TrainConfig, random_policy_return, save, train
from hri_envs.errors import ConfigError, LearnerStateError
from hri_envs.jax.speed import device_name

#: The checkpoints shipped with the package (``jaxppo`` without a path plays them).
SHIPPED = Path(agents.__file__).resolve().parent / "jax_ppo" / "checkpoints"
#: The file in ``--out`` listing what this script wrote there.
MARKER = ".train_jax_ppo.json"
#: Folders never written into: the packages and the checkout's docs (``SHIPPED`` only with
#: ``--overwrite-shipped``).
PROTECTED = (*(Path(m.__file__).resolve().parent for m in (agents, baselines, hri_bench,
                                                             hri_envs)),
             Path(__file__).resolve().parent.parent / "docs")
#: What a ``ConfigError``'s field is called on this script's command line.
FLAG_OF = {"episodes_per_human": "episodes_per_trial"}


def draw_curve(curve: dict, random_level: float, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.6))
    steps = np.asarray(curve["steps"]) / 1e6
    ax.plot(steps, curve["episode_return"], label="recurrent PPO (training episodes)")
    by_ep = np.asarray(curve["return_by_episode"])
    ax.plot(steps, by_ep[:, 0], linewidth=0.8, alpha=0.7, label="its 1st episode with a human")
    ax.plot(steps, by_ep[:, -1], linewidth=0.8, alpha=0.7,
            label=f"its {by_ep.shape[1]}th episode with a human")
    ax.axhline(random_level, color="grey", linestyle="--", label="random valid actions")
    ax.set_xlabel("env steps [millions]")
    ax.set_ylabel("robot reward per episode")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def outputs(scenario: str) -> list[str]:
    """The files a training of ``scenario`` writes into ``--out``."""
    return [f"{scenario}.npz", f"{scenario}_curve.json", f"{scenario}_curve.png"]


def check_out(out: Path, overwrite_shipped: bool) -> bool:
    """Refuse an ``--out`` this script must not write into; True for the shipped folder.

    Raises:
        ConfigError: ``out`` is a file or cannot be created (a file on its path), the
            shipped checkpoints without
            ``overwrite_shipped``, inside a package or ``docs/``, or a folder holding
            files this script did not write (``field="out"``).
    """
    where = out.resolve()
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out} is not a folder; give a folder for the checkpoint and its "
                          "curve", field="out")
    above = next((p for p in out.absolute().parents if p.exists()), None)
    if above is not None and not above.is_dir():  # checked now, not after the training
        raise ConfigError(f"{out} cannot be created: {above} is not a folder; give a folder "
                          "for the checkpoint and its curve", field="out")
    if where == SHIPPED:
        if not overwrite_shipped:
            raise ConfigError(f"{out} holds the package's shipped checkpoints; train into a "
                              "folder of your own (default out/jaxppo) and rank it as "
                              "jaxppo:FOLDER, or add --overwrite-shipped to replace them",
                              field="out")
        return True
    for folder in PROTECTED:
        if where == folder or folder in where.parents:
            raise ConfigError(f"{out} is inside {folder}, which this script never writes "
                              "into; give a folder under out/ (default out/jaxppo)",
                              field="out")
    if not out.is_dir():
        return False
    ours: set[str] = set()
    try:
        listed = json.loads((out / MARKER).read_text())
        ours = set(listed["files"]) if isinstance(listed, dict) else set()
    except (OSError, ValueError, KeyError, TypeError):
        pass
    foreign = sorted(p.name for p in out.iterdir() if p.name != MARKER and p.name not in ours)
    if foreign:
        raise ConfigError(f"{out} holds files this script did not write "
                          f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); "
                          "give a new or empty folder, or one it wrote", field="out")
    return False


def claim(out: Path, scenario: str) -> None:
    """Create ``out`` and list the files this training writes in its :data:`MARKER`."""
    out.mkdir(parents=True, exist_ok=True)
    marker = out / MARKER
    files: set[str] = set()
    try:
        files = set(json.loads(marker.read_text())["files"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    doc = {"written_by": "benchmarks/train_jax_ppo.py",
           "files": sorted(files | set(outputs(scenario)))}
    marker.write_text(json.dumps(doc, indent=1) + "\n")


def main(cfg: Annotated[TrainConfig, tyro.conf.arg(name="")],
         out: Path = Path("out/jaxppo"), overwrite_shipped: bool = False) -> None:
    """Train the recurrent PPO robot in JAX, save the checkpoint, write and draw its
    learning curve.

    Writes OUT/SCENARIO.npz, OUT/SCENARIO_curve.json and OUT/SCENARIO_curve.png; rank the
    checkpoint with hri-bench suite --agents learner,jaxppo:OUT.

    Args:
        cfg: The training settings.
        out: The folder to write: new, empty, or one this script wrote (never the package).
        overwrite_shipped: Allow --out agents/jax_ppo/checkpoints (replaces agent jaxppo).
    """
    cfg.check()
    shipped = check_out(out, overwrite_shipped)
    print(f"training on {device_name()}: {cfg.scenario}, population {cfg.population}, "
          f"{cfg.updates} updates of {cfg.steps_per_update:,} steps, trials of "
          f"{cfg.trial_length()} episodes", flush=True)
    t0 = time.perf_counter()
    path = out / f"{cfg.scenario}.npz"
    result = train(cfg, log=lambda line: print(line, flush=True))
    if not shipped:
        claim(out, cfg.scenario)
    save(str(path), result)
    wall = time.perf_counter() - t0
    steps = cfg.updates * cfg.steps_per_update
    steady = steps / max(sum(result.curve["seconds"]) - result.compile_seconds, 1e-9)
    level = random_policy_return(cfg)
    doc = {"config": cfg.to_dict(), "device": device_name(), "wall_seconds": round(wall, 1),
           "compile_seconds": round(result.compile_seconds, 1), "steps": steps,
           "train_steps_per_s": round(steady), "random_policy_return": level,
           "load_average": list(os.getloadavg()),
           "curve": {k: np.round(v, 4).tolist() for k, v in result.curve.items()}}
    (out / f"{cfg.scenario}_curve.json").write_text(  # compact, 4 decimals: shipped in docs/
        json.dumps(doc, separators=(",", ":")) + "\n")
    draw_curve(result.curve, level, out / f"{cfg.scenario}_curve.png",
               f"{cfg.scenario}: recurrent PPO in JAX, population {cfg.population} "
               f"(seed {cfg.seed})")
    print(f"trained {steps:,} steps in {wall:.0f} s ({steady:,.0f} steps/s after "
          f"{result.compile_seconds:.0f} s compiling); final episode return "
          f"{result.curve['episode_return'][-1]:.3f} (random valid actions {level:.3f})")
    print(f"wrote {path}; rank it: .venv/bin/hri-bench suite --agents learner,jaxppo:"
          f"{out} --out out/suite-jaxppo")


def run(argv: list[str] | None = None) -> int:
    """The command line: 0 done, 2 a bad option (one line naming it), 1 a failure."""
    try:
        tyro.cli(main, args=argv)
    except ConfigError as exc:  # a bad value: one line naming its flag, exit 2 (as hri-bench)
        flag = FLAG_OF.get(exc.field or "", exc.field)
        named = f"argument --{flag.replace('_', '-')}: " if flag else ""
        print(f"train_jax_ppo.py: error: {named}{exc}", file=sys.stderr)
        return 2
    except (LearnerStateError, OSError) as exc:  # diverged, or the disk refused
        print(f"train_jax_ppo.py: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(run())
