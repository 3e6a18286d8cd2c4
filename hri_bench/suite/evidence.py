"""What a results file says of its references and agents, checked against the code here.

* :func:`agent_roles`: what each agent sees besides the robot's view, as a results file of
  suite v4 records it (a reference is never ranked), and :func:`role_errors`, the recorded
  roles that an installed agent's code does not declare;
* :func:`blind_errors`: ``blind``'s recorded values recomputed (they are exact expected
  rewards, so a forged reference differs);
* :func:`replayable`: whether an agent's recorded code is the code installed here (for
  ``--replay``, ``--fresh`` and the role check).

:mod:`hri_bench.suite.submission` runs the first two in ``validate``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np

from hri_bench.run.agents import agent_identity, agent_privilege
from hri_bench.run.regret import blind_values
from hri_bench.run.runner import make_schedule
from hri_bench.suite.tracks import TRACKS_BY_VERSION, track_config
from hri_envs.errors import ConfigError

__all__ = ["agent_roles", "blind_errors", "identity_key", "replayable", "role_errors"]

#: Per-run values are written rounded to this many decimals (as
#: :data:`hri_bench.suite.submission.DECIMALS`).
DECIMALS = 6


def _round(x: np.ndarray) -> list[Any]:
    return np.round(np.asarray(x, dtype=float), DECIMALS).tolist()


def agent_roles(agents: Sequence[str]) -> dict[str, dict[str, bool]]:
    """What each agent sees besides the robot's view, as a results file of suite v4 records
    it (:func:`hri_bench.run.agents.agent_privilege`): a reference is never ranked.
    """
    out = {}
    for a in agents:
        p = agent_privilege(a)
        out[a] = {"sees_intention": p.sees_intention, "knows_human": p.knows_human,
                  "reference": p.reference}
    return out


def role_errors(doc: Mapping[str, Any]) -> list[str]:
    """Suite v4: every agent has a role, and an agent whose code is installed here (a
    built-in, a registered agent, a ``module:Class`` whose files hash as recorded) has the
    role its code declares.
    """
    roles = doc.get("roles", {})
    errors = [f"roles: agent {a!r} has none" for a in doc["agents"] if a not in roles]
    errors += [f"roles: {a!r} is not an agent of the file" for a in roles
               if a not in doc["agents"]]
    for a, ident in doc["agents"].items():
        if a in roles and replayable(a, ident) is None:
            own = agent_roles([a])[a]
            if roles[a] != own:
                errors.append(f"roles.{a}: recorded {roles[a]}, its code declares {own}")
    return errors


def identity_key(identity: Any) -> str:
    """A code identity as one comparable string."""
    return json.dumps(identity, sort_keys=True)


def replayable(name: str, identity: Mapping[str, Any]) -> str | None:
    """Why agent ``name``'s runs cannot be replayed here (its code is not the recorded
    code), or None when they can.
    """
    try:
        now = agent_identity(name)
    except (ConfigError, OSError, ImportError) as exc:
        return f"not installed here ({exc})"
    if identity_key(now) != identity_key(identity):
        what = {"builtin": "the hri-envs version", "custom": "its source files",
                "sb3": "the model file", "jaxppo": "the checkpoint"}.get(
            str(identity.get("kind")), "its code")
        return f"{what} differ(s) from the recorded one"
    return None


def blind_errors(doc: Mapping[str, Any]) -> list[str]:
    """``blind``'s recorded values recomputed: they are exact expected rewards (the plan of
    :func:`hri_bench.run.regret.blind_values` for each run's episode starts), so a forged
    reference differs from them.
    """
    version = doc["suite"]["version"]
    tracks = TRACKS_BY_VERSION[version]
    errors = []
    for seed, by_track in doc["runs"].items():
        for name, block in by_track.items():
            if block["blind"] is None:
                continue
            cfg = track_config(tracks[name], ("passive",), runs_scale=doc["runs_scale"],
                               seed=int(seed), version=version)
            starts = make_schedule(cfg.graph, cfg.schedule,
                                   list(range(cfg.runs)), cfg.n_episodes, cfg.seed).start
            runs: Any = SimpleNamespace(config=cfg, schedule={"start": starts})  # what it reads
            values = _round(blind_values(runs))
            bad = [r for r, (a, b) in enumerate(zip(values, block["blind"], strict=True))
                   if a != b]
            if bad:
                errors.append(f"runs.{seed}.{name}.blind: run(s) {', '.join(map(str, bad[:5]))}"
                              f"{' (and more)' if len(bad) > 5 else ''} are not blind's exact "
                              "expected rewards for the runs' starts (a forged reference)")
    return errors


