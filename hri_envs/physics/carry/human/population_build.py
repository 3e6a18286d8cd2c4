"""How the frozen physical populations were made (:mod:`~hri_envs.physics.carry.human.population`),
and
the figures that describe them.

:func:`build_scenario` draws each split's members family by family from
``default_rng([GENERATOR_SEED, scenario, split, family])`` (indices into
:data:`~hri_envs.physics.carry.human.population.SCENARIOS`,
:data:`~hri_envs.physics.carry.human.population.SPLITS`
and :data:`~hri_envs.physics.carry.human.families.FAMILIES`), probes each candidate
(:func:`~hri_envs.physics.carry.human.probe.signature`) and keeps it unless its arm cannot hold the
handle at a probe's start (``IKFailure``) or its signature is within the tolerance
(:func:`~hri_envs.physics.carry.human.probe.distances` < 1) of a member kept before it, in any
split of
the scenario (train first, then validation, then test). The result depends on the
simulator's arithmetic, so it is frozen by value in the data files; ``benchmarks/
physical_populations.py`` writes them (``--write``) and checks a sample against this
machine's simulation (``--check``).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from hri_envs.physics.carry.human.families import FAMILIES
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.human.population import (
    DATA_FILE,
    SCENARIOS,
    SIGNATURE_FILE,
    SPLITS,
    params_dict,
)
from hri_envs.physics.carry.human.probe import (
    FORCE_TOLERANCE_N,
    PATH_TOLERANCE_M,
    PROBE_S,
    PROBES,
    WINDOW_STEPS,
    distances,
    signature,
)
from hri_envs.physics.carry.sim import CarrySim, default_grip_force
from hri_envs.physics.scene.ik import IKFailure
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["GENERATOR_SEED", "build_scenario", "fingerprint", "label", "nearest", "write"]

GENERATOR_SEED = 40_2
_MAX_TRIES = 400  # candidates per member before giving up


def fingerprint(params: HumanParams) -> str:
    """The first 16 hex digits of the SHA-256 of a human's parameters."""
    text = json.dumps(params_dict(params), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def label(split: str, family: str, k: int, params: HumanParams) -> str:
    """``split/family-k (F|M, stature cm, mass kg)``."""
    return (f"{split}/{family}-{k:03d} ({params.sex[0].upper()}, {params.stature_m * 100:.0f}"
            f" cm, {params.body_mass_kg:.0f} kg)")


def build_scenario(graph: TaskGraph, progress: Callable[[str], None] | None = None
                   ) -> tuple[dict[str, Any], np.ndarray]:
    """The splits of ``graph``'s scenario (JSON-ready: {split: [member, ...], "rejected":
    {...}}) and the members' signatures (N, P, W, 9), train, validation and test in order.

    Raises:
        RuntimeError: A family gave no acceptable member in :data:`_MAX_TRIES` candidates.
    """
    scenario = graph.name
    sim = CarrySim(graph)
    grip = default_grip_force(sim.design)
    prefs = spec_of(graph).preferences
    kept: list[np.ndarray] = []
    doc: dict[str, Any] = {"rejected": {}}
    s_idx = SCENARIOS.index(scenario)
    for sp_idx, (split, makeup) in enumerate(SPLITS.items()):
        members, rejected = [], {"ik_failure": 0, "same_behaviour": 0}
        for family, count in makeup.items():
            fam = FAMILIES[family]
            rng = np.random.default_rng([GENERATOR_SEED, s_idx, sp_idx,
                                         list(FAMILIES).index(family)])
            for k in range(count):
                for _ in range(_MAX_TRIES):
                    params = fam.draw(rng, grip, prefs)
                    try:
                        sig = signature(sim, params)
                    except IKFailure:
                        rejected["ik_failure"] += 1
                        continue
                    if kept and distances(sig[None], np.stack(kept)).min() < 1.0:
                        rejected["same_behaviour"] += 1
                        continue
                    break
                else:
                    raise RuntimeError(f"{scenario} {split} {family}: no member in "
                                       f"{_MAX_TRIES} candidates")
                kept.append(sig)
                members.append({"family": family, "label": label(split, family, k, params),
                                "fingerprint": fingerprint(params),
                                "params": params_dict(params)})
                if progress is not None:
                    progress(f"{scenario} {split} {members[-1]['label']}")
        doc[split] = members
        doc["rejected"][split] = rejected
    return doc, np.stack(kept).astype(np.float32)


def write(directory: Path, scenarios: dict[str, tuple[dict[str, Any], np.ndarray]]) -> None:
    """Write the data file (members) and the signature file into ``directory``."""
    doc = {"version": 1, "generator_seed": GENERATOR_SEED, "splits": SPLITS,
           "probe": {"probes": [list(p) for p in PROBES], "probe_s": PROBE_S,
                     "window_steps": WINDOW_STEPS, "force_tolerance_n": FORCE_TOLERANCE_N,
                     "path_tolerance_m": PATH_TOLERANCE_M},
           "scenarios": {s: scenarios[s][0] for s in scenarios}}
    (directory / DATA_FILE).write_text(_dumps(doc) + "\n")
    arrays: dict[str, Any] = {s: v[1] for s, v in scenarios.items()}
    np.savez_compressed(directory / SIGNATURE_FILE, **arrays)


def _dumps(doc: Any, indent: str = "") -> str:
    """JSON with one member (a dict inside a list) per line."""
    if isinstance(doc, dict) and len(json.dumps(doc)) > 80:
        inner = indent + " "
        items = [f"{inner}{json.dumps(k)}: {_dumps(v, inner)}" for k, v in sorted(doc.items())]
        return "{\n" + ",\n".join(items) + f"\n{indent}}}"
    if isinstance(doc, list) and doc and isinstance(doc[0], dict):
        items = [indent + " " + json.dumps(v, sort_keys=True) for v in doc]
        return "[\n" + ",\n".join(items) + f"\n{indent}]"
    return json.dumps(doc, sort_keys=True)


def nearest(sigs: np.ndarray, sizes: dict[str, int]) -> dict[str, float]:
    """The smallest behavioural distances of a scenario's signatures (train, validation and
    test rows in order, ``sizes`` members each): within each split, and test against
    train and validation.
    """
    bounds, start = {}, 0
    for split, n in sizes.items():
        bounds[split] = slice(start, start + n)
        start += n
    d = distances(sigs)
    np.fill_diagonal(d, np.inf)
    out = {f"within {s}": float(d[b, b].min()) for s, b in bounds.items()}
    seen = slice(0, bounds["test"].start)
    out["test vs train+validation"] = float(d[bounds["test"], seen].min())
    out["all"] = float(d.min())
    return out
