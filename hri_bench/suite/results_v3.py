"""Suite v3's part of a results file: who each run met, the statistics, the leaderboard.

A results file of suite v3 (``schema_version`` "2", docs/results.md) adds to the layout of
v1 and v2 what treating the humans as a sample needs: per track the humans its population
holds (``tracks.T.members``: family, parameters, label and model fingerprint) and per run
the one it met (``runs.S.T.humans``: indices into ``members``). :func:`compute` derives
every statistic from the runs alone, with :mod:`hri_bench.report.ranking`: per seed, track and
agent the task's metrics (regret and learning measured against the track's *reachable
reference*) and the normalised score; across seeds and tracks the headline, the pairs and
what learners fail on. :func:`lead_section` and :func:`failure_section` write them for
``leaderboard.md``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from hri_bench.report import ranking
from hri_bench.run import metrics
from hri_bench.run.agents import AGENTS
from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.tracks import FLOOR
from hri_envs.humans.finite_state import as_model
from hri_envs.humans.scripted import preference_human
from hri_envs.humans.splits import MixtureSpec, population

__all__ = ["FLOOR", "REACHABLE", "SCHEMA_VERSION", "compute", "failure_section",
           "lead_section", "members", "run_humans"]

#: The results file's layout for suite v3.
SCHEMA_VERSION = "2"
#: Suite v4's: v3's, with the agents' roles (``roles``: what each sees, whether it is a
#: reference) and the reference and floor re-estimated in every bootstrap replicate.
SCHEMA_V4 = "3"
#: The normalised score's floor (0) and the reachable references (1), in order of
#: preference: blind's exact values where they were recorded, else ``qmdp``.
REACHABLE = ("blind", "qmdp")
#: The humans each agent's worst list names.
WORST = 5


# ------------------------------------------------------------------- who each run met
def members(cfg: Any) -> list[dict[str, Any]]:
    """The humans a track's study meets (``tracks.T.members``): a split's members, or the
    one scripted human of a track without a population.
    """
    graph = cfg.graph
    if cfg.population is None:
        pref = cfg.preference or cfg.spec.default_preference
        model = as_model(preference_human(graph, pref, passive=cfg.human_passive,
                                          turn_back=cfg.turn_back))
        return [{"family": "preference", "params": [["preference", pref]], "label": pref,
                 "fingerprint": model.fingerprint}]
    spec = population(cfg.population, cfg.graph, dict(cfg.human_params))
    if not isinstance(spec, MixtureSpec):
        raise ValueError(f"suite v3 tracks meet a split's members, not {cfg.population!r}")
    return [{"family": d.family, "params": [list(p) for p in d.params], "label": d.label(),
             "fingerprint": f} for d, f in zip(spec.member_draws, spec.fingerprints(),
                                               strict=True)]


def run_humans(cfg: Any) -> list[int]:
    """Each run's human, as an index into :func:`members` (``runs.S.T.humans``)."""
    if cfg.population is None:
        return [0] * cfg.runs
    spec = population(cfg.population, cfg.graph, dict(cfg.human_params))
    assert isinstance(spec, MixtureSpec)
    return [spec.member_index(cfg.seed, r) for r in range(cfg.runs)]


# --------------------------------------------------------------------- the statistics
def _reachable(block: Mapping[str, Any]) -> tuple[str, np.ndarray]:
    """(name, (runs, episodes)) the reachable reference per run and episode: blind's exact
    values, else qmdp's rewards averaged over the runs of each human (per episode).
    """
    if block.get("blind") is not None:
        return "blind", np.asarray(block["blind"], dtype=float)
    if "qmdp" not in block["agents"]:
        raise ValueError("no reachable reference (blind or qmdp) on the track")
    q = np.asarray(block["agents"]["qmdp"]["reward"], dtype=float)
    humans = np.asarray(block["humans"])
    out = np.empty_like(q)
    for g in ranking.human_groups(humans.tolist()):
        out[g] = q[g].mean(0)
    return "qmdp", out


def _normalisation(block: Mapping[str, Any]) -> tuple[dict[str, Any], np.ndarray]:
    """The track's normalisation (its reachable reference and floor, their mean rewards) and
    the reference per run and episode (:func:`_reachable`).
    """
    name, ref = _reachable(block)
    if FLOOR not in block["agents"]:
        raise ValueError(f"no floor ({FLOOR}) on the track")
    floor = float(np.asarray(block["agents"][FLOOR]["reward"], dtype=float).mean())
    return {"reference": name, "reference_reward": float(ref.mean()), "floor": FLOOR,
            "floor_reward": floor}, ref


def _scores(block: Mapping[str, Any], norm: Mapping[str, Any]) -> dict[str, np.ndarray]:
    return {a: ranking.normalise(np.asarray(e["reward"], dtype=float).mean(1),
                                 norm["reference_reward"], norm["floor_reward"])
            for a, e in block["agents"].items()}


def compute(doc: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(statistics, aggregate)`` of a suite v3 results document, from its runs alone.

    ``statistics[seed][track]``: ``normalisation`` (the reachable reference and the floor,
    their mean rewards) and per agent (``agents``) :func:`hri_bench.run.metrics.agent_metrics`
    against the reachable reference (so ``regret``, ``learning_episodes`` and the asymptote
    are defined on every track) plus ``normalised`` (this seed's runs). ``aggregate``: every
    seed pooled per track: the headline and pairs (:func:`hri_bench.report.ranking.headline`), the
    per-seed headline means, the gap to the reachable reference per track and per family,
    and each agent's :data:`WORST` humans.
    """
    threshold = float(doc["threshold"])
    tracks = doc.get("tracks", {})
    v4 = doc.get("schema_version") == SCHEMA_V4
    scales: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}  # v4: reference and floor
    statistics: dict[str, Any] = {}
    pooled: dict[str, dict[str, list[np.ndarray]]] = {}
    gaps: dict[str, dict[str, list[np.ndarray]]] = {}
    humans: dict[str, list[np.ndarray]] = {}
    seed0 = int(next(iter(doc["runs"]), 0))
    seed_means: dict[str, dict[str, list[float]]] = {}
    for seed, by_track in doc["runs"].items():
        statistics[seed] = {}
        for track, block in by_track.items():
            norm, ref = _normalisation(block)
            drift = tracks.get(track, {}).get("settings", {}).get("human_drift")
            if v4:  # raw run means, normalised per replicate
                z = {a: np.asarray(e["reward"], dtype=float).mean(1)
                     for a, e in block["agents"].items()}
                scale = (ref.mean(1) if norm["reference"] == "blind" else z["qmdp"], z[FLOOR])
                scales.setdefault(track, []).append(scale)
                one = ranking.Track(track, z, block["humans"], int(seed), reference=scale[0],
                                    floor=scale[1])
            else:
                z = _scores(block, norm)
                one = ranking.Track(track, z, block["humans"], int(seed))
            per_agent = {}
            for agent, entry in block["agents"].items():
                arrays = {k: np.asarray(v, dtype=float) for k, v in entry.items()}
                stat = metrics.agent_metrics(arrays, ref, int(seed), threshold, drift)
                stat["normalised"] = ranking.public(ranking.summarise(one, agent))
                per_agent[agent] = stat
                pooled.setdefault(track, {}).setdefault(agent, []).append(z[agent])
                gaps.setdefault(track, {}).setdefault(agent, []).append(
                    ref.mean(1) - arrays["reward"].mean(1))
            humans.setdefault(track, []).append(np.asarray(block["humans"]))
            statistics[seed][track] = {"normalisation": norm, "agents": per_agent}
    every = set(pooled)
    agents = [a for a in doc["agents"] if all(a in pooled[t] and len(pooled[t][a]) ==
                                              len(humans[t]) for t in every)]
    partial = {a: sorted(t for t in every if a in pooled[t]) for a in doc["agents"]
               if a not in agents}
    order = [t for t in tracks if t in every] + sorted(every - set(tracks))
    ranked = [ranking.Track(t, {a: np.concatenate(pooled[t][a]) for a in agents},
                            np.concatenate(humans[t]).tolist(), seed0,
                            headline=bool(tracks.get(t, {}).get("headline", False)),
                            **({"reference": np.concatenate([r for r, _ in scales[t]]),
                                "floor": np.concatenate([f for _, f in scales[t]])} if v4
                               else {}))
              for t in order]
    aggregate: dict[str, Any] = {"score": "normalised: 1 at the track's reachable reference "
                                          "(blind exact, else qmdp), 0 at the floor (passive)",
                                 "partial": partial}
    if not agents or not any(t.headline for t in ranked):
        aggregate.update(headline=None, seeds={}, gap=None, families=None, worst=None)
        return statistics, aggregate
    aggregate["headline"] = ranking.headline(ranked, agents)
    lead = set(aggregate["headline"]["tracks"])
    for seed, by_track in doc["runs"].items():
        for a in agents:
            seed_means.setdefault(a, {})[seed] = [
                float(np.mean(statistics[seed][t]["agents"][a]["normalised"]["mean"]))
                for t in by_track if t in lead]
    aggregate["seeds"] = {a: _spread({s: float(np.mean(v)) for s, v in by_seed.items() if v})
                          for a, by_seed in seed_means.items()}
    aggregate["gap"] = {a: {t.name: _gap(t, np.concatenate(gaps[t.name][a])) for t in ranked}
                        for a in agents}
    aggregate["families"] = {a: _families(ranked, gaps, tracks, a) for a in agents}
    aggregate["worst"] = {a: _worst(ranked, gaps, tracks, a) for a in agents}
    if v4:
        roles = doc.get("roles", {})
        blind = [a for a in aggregate["headline"]["order"]
                 if not roles.get(a, {}).get("reference", False)]
        aggregate["ranks"] = ranking.shared_ranks(blind, aggregate["headline"]["pairs"])
        aggregate["worse_than_floor"] = {a: ranking.worse_than_floor(ranked, a, FLOOR)
                                         for a in agents}
    return statistics, aggregate


def _spread(by_seed: Mapping[str, float]) -> dict[str, Any]:
    values = np.array(list(by_seed.values()))
    return {"by_seed": dict(by_seed), "std": float(values.std(ddof=1)) if len(values) > 1
            else 0.0, "min": float(values.min()), "max": float(values.max())}


def _gap(track: ranking.Track, gap: np.ndarray) -> dict[str, Any]:
    """The mean gap to the reachable reference (reward per episode) with its two-stage CI."""
    w, big = track.weights()
    lo, hi = np.quantile(big @ gap, [(1 - ranking.LEVEL) / 2, (1 + ranking.LEVEL) / 2])
    return {"mean": float(w @ gap), "ci95": [float(lo), float(hi)]}


def _normalised(track: ranking.Track, agent: str) -> np.ndarray:
    """The agent's run scores normalised with the track's point reference and floor."""
    floor, span, _, _ = track.scale()
    return (np.asarray(track.scores[agent], dtype=float) - floor) / span


def _per_human(track: ranking.Track, values: np.ndarray) -> dict[Any, float]:
    out = {}
    for g in ranking.human_groups(track.humans):
        out[track.humans[int(g[0])]] = float(values[g].mean())
    return out


def _families(ranked: Sequence[ranking.Track], gaps: Mapping[str, Any],
              tracks: Mapping[str, Any], agent: str) -> dict[str, Any]:
    """Per family (headline tracks): its humans, the mean over them of the agent's gap to
    the reachable reference (reward per episode) and of its normalised score.
    """
    rows: dict[str, dict[str, list[float]]] = {}
    for t in ranked:
        if not t.headline:
            continue
        members = tracks.get(t.name, {}).get("members") or []
        gap = _per_human(t, np.concatenate(gaps[t.name][agent]))
        score = _per_human(t, _normalised(t, agent))
        for h, g in gap.items():
            family = members[h]["family"] if h < len(members) else "?"
            row = rows.setdefault(family, {"gap": [], "normalised": []})
            row["gap"].append(g)
            row["normalised"].append(score[h])
    return {f: {"humans": len(r["gap"]), "gap": float(np.mean(r["gap"])),
                "normalised": float(np.mean(r["normalised"]))} for f, r in rows.items()}


def _worst(ranked: Sequence[ranking.Track], gaps: Mapping[str, Any],
           tracks: Mapping[str, Any], agent: str) -> list[dict[str, Any]]:
    """The agent's :data:`WORST` humans over the headline tracks, by normalised score."""
    rows = []
    for t in ranked:
        if not t.headline:
            continue
        members = tracks.get(t.name, {}).get("members") or []
        score = _per_human(t, _normalised(t, agent))
        gap = _per_human(t, np.concatenate(gaps[t.name][agent]))
        for h, z in score.items():
            m = members[h] if h < len(members) else {}
            rows.append({"track": t.name, "member": int(h), "family": m.get("family"),
                         "label": m.get("label"), "normalised": z, "gap": gap[h]})
    rows.sort(key=lambda r: (r["normalised"], r["track"], r["member"]))
    return rows[:WORST]


# --------------------------------------------------------------------- leaderboard text
def mark(agent: str) -> str:
    """What the leaderboard of suite v3 says an agent is, from what its registered
    :class:`~hri_bench.run.agents.AgentSpec` declares (not from its name): the floor, an agent
    that sees ι (a reference or not), a reference that knows the human's model; nothing for
    an agent of one's own (suite v4 reads each agent's role from the file instead).
    """
    spec = AGENTS.find(agent)
    if agent == FLOOR:
        return " (floor)"
    if spec is None:
        return ""
    if not spec.intention_blind:
        return " (ref., sees ι)" if spec.role == "reference" else " (sees ι)"
    return " (ref., reachable)" if spec.plans else ""


def _name(agent: str) -> str:
    return f"{code(agent)}{mark(agent)}"


def lead_section(doc: Mapping[str, Any]) -> str:
    """The leaderboard's lead for suite v3: the headline table (normalised mean with its
    two-stage CI, IQM, seed spread, wins/ties/losses against the next agent), the
    wins/ties/losses and paired differences of every pair, and where the order and the
    tracks disagree.
    """
    agg = doc["aggregate"]
    head = agg.get("headline")
    if head is None:
        return "## Across tracks\n\nNo agent ran on every track: no headline.\n"
    order, block, pairs = head["order"], head["agents"], head["pairs"]
    n = len(head["tracks"])
    seeds = ", ".join(str(s) for s in doc["seeds"])
    lines = ["## Headline: normalised score on the test split", "",
             f"Each run's mean episode reward normalised per track: 1 at the track's "
             f"reachable reference (`blind` exact on the paper's anchor, else `qmdp`, an "
             f"intention-blind robot that knows each human's model), 0 at the floor "
             f"(`passive`). Headline: the mean over the {n} headline tracks (each weighs the "
             "same; they partition the test humans) of each track's mean over its humans; "
             "95 % CIs from a two-stage bootstrap (humans, then runs within each human). "
             f"IQM: the mean of the tracks' interquartile means. Suite seeds {seeds}. W/T/L: "
             "headline tracks where the agent's paired difference to the next agent's "
             "(same humans, seeds and runs) has its CI above 0 / across 0 / below 0. Sorted "
             "by the headline mean.", "",
             "| rank | agent | headline [95 % CI] | IQM [95 % CI] | seed sd (min–max) | "
             "W/T/L vs next | Δ vs next [95 % CI] |", "|---|---|---|---|---|---|---|"]
    for i, a in enumerate(order):
        e, sp = block[a], agg["seeds"].get(a, {})
        if i + 1 < len(order):
            p = pairs[a][order[i + 1]]
            wtl = f"{p['wins']}/{p['ties']}/{p['losses']}"
            delta = with_ci(p["difference"])
        else:
            wtl = delta = "·"
        spread = (f"{number(sp.get('std'))} ({number(sp.get('min'))} to {number(sp.get('max'))})"
                  if len(sp.get("by_seed", {})) > 1 else "· (one seed)")
        lines.append(f"| {i + 1} | {_name(a)} | {with_ci(e)} | {with_ci(e, 'iqm')} | {spread} | "
                     f"{wtl} | {delta} |")
    partial = {a: t for a, t in (agg.get("partial") or {}).items() if a not in REACHABLE}
    if partial:
        lines += ["", "Not ranked (no runs on every track of every seed): "
                  + "; ".join(f"{_name(a)} ({len(t)} track(s))" for a, t in partial.items())
                  + "."]
    lines += ["", "### Every pair: wins/ties/losses over the headline tracks, and the paired "
              "headline difference", "", "Row agent against column agent.", "",
              "| row vs column | " + " | ".join(_name(b) for b in order) + " |",
              "|---|" + "---|" * len(order)]
    for a in order:
        cells = ["·" if a == b else f"{pairs[a][b]['wins']}/{pairs[a][b]['ties']}/"
                 f"{pairs[a][b]['losses']}, {number(pairs[a][b]['difference']['mean'])}"
                 for b in order]
        lines.append(f"| {_name(a)} | " + " | ".join(cells) + " |")
    odd = [(a, b) for i, a in enumerate(order) for b in order[i + 1:]
           if pairs[a][b]["losses"] > pairs[a][b]["wins"]]
    lines += [""]
    if odd:
        lines += ["**Where the order and the tracks disagree:** "
                  + "; ".join(f"{_name(a)} is ranked above {_name(b)} but loses "
                              f"{pairs[a][b]['losses']} headline track(s) to it and wins "
                              f"{pairs[a][b]['wins']}: its wins are larger than its losses "
                              f"(paired headline difference "
                              f"{with_ci(pairs[a][b]['difference'])})" for a, b in odd) + ".", ""]
    else:
        lines += ["The order agrees with the tracks: no agent loses more headline tracks to "
                  "an agent ranked below it than it wins.", ""]
    lines += ["### Per track: normalised score [95 % CI]", "",
              "| track | " + " | ".join(_name(a) for a in order) + " |",
              "|---|" + "---|" * len(order)]
    for t in next(iter(block.values()))["per_track"]:
        label = f"**{escape(t)}**" if t in head["tracks"] else f"{escape(t)} (anchor)"
        lines.append(f"| {label} | " + " | ".join(with_ci(block[a]["per_track"][t])
                                                  for a in order) + " |")
    return "\n".join([*lines, ""])


def failure_section(doc: Mapping[str, Any], references: Sequence[str] = ("informed", "oracle")
                    ) -> str:
    """What learners fail on: per agent but ``references`` (v3: the agents that see ι;
    v4: every reference by its role) the gap to the reachable reference per track and per
    family, and its worst humans.
    """
    agg = doc["aggregate"]
    head = agg.get("headline")
    if head is None:
        return ""
    order = [a for a in head["order"] if a not in references]
    tracks = list(next(iter(agg["gap"].values())))
    lines = ["## What the agents fail on", "",
             "Gap to the reachable reference: its mean episode reward minus the agent's, "
             "per episode (the same runs; lower is better; negative: better than the "
             "reference), with two-stage 95 % CIs.", "",
             "| track | " + " | ".join(_name(a) for a in order) + " |",
             "|---|" + "---|" * len(order)]
    for t in tracks:
        lines.append(f"| {escape(t)} | " + " | ".join(with_ci(agg["gap"][a][t]) for a in order)
                     + " |")
    families = sorted({f for a in order for f in agg["families"][a]})
    lines += ["", "Per family (headline tracks): mean gap per episode (normalised score).", "",
              "| family | humans | " + " | ".join(_name(a) for a in order) + " |",
              "|---|---|" + "---|" * len(order)]
    for f in families:
        n = next(agg["families"][a][f]["humans"] for a in order if f in agg["families"][a])
        cells = [f"{number(e['gap'])} ({number(e['normalised'], 2)})" if e is not None else "–"
                 for e in (agg["families"][a].get(f) for a in order)]
        lines.append(f"| {escape(f)} | {n} | " + " | ".join(cells) + " |")
    lines += ["", f"Each agent's {WORST} worst humans (headline tracks, by normalised score; "
              "gap per episode).", ""]
    for a in order:
        worst = "; ".join(f"{escape(w['label'])} on {escape(w['track'])} "
                          f"({number(w['normalised'], 2)}, gap {number(w['gap'], 2)})"
                          for w in agg["worst"][a])
        lines.append(f"- {_name(a)}: {worst}")
    return "\n".join([*lines, ""])


def ranking_figure(doc: Mapping[str, Any], path: Any) -> Any:
    """``ranking.png``: each agent's headline normalised score with its 95 % CI, best on
    top, and its score on every headline track as small markers.
    """
    from hri_bench.core import plots  # matplotlib: the bench extra

    head = doc["aggregate"].get("headline")
    fig, ax = plots.new_figure(figsize=(6.4, 0.45 * max(len(head["order"]) if head else 1, 4)
                                        + 1.2))
    if head is not None:
        order = head["order"][::-1]
        for y, a in enumerate(order):
            e = head["agents"][a]
            color = plots.agent_style(a)[0]  # one colour per agent in every figure
            # A degenerate interval (one human, the floor's 0) may lie a rounding beside
            # its mean: never a negative bar.
            ax.errorbar([e["mean"]], [y], xerr=[[max(e["mean"] - e["ci95"][0], 0.0)],
                                                [max(e["ci95"][1] - e["mean"], 0.0)]],
                        fmt="o", color=color, capsize=3, markersize=6)
            per = [e["per_track"][t]["mean"] for t in head["tracks"]]
            ax.scatter(per, [y + 0.22] * len(per), s=9, color=color, alpha=0.6, linewidths=0)
        ax.set_yticks(range(len(order)), [plots.LABELS.get(a, a) for a in order])
        ax.axvline(0.0, color="#999999", linewidth=0.8, linestyle=":")
        ax.axvline(1.0, color="#333333", linewidth=0.8, linestyle="--")
    ax.set_xlabel("normalised score (0: passive floor, 1: reachable reference)")
    ax.set_title("Suite v3 headline, 95 % two-stage CI; dots: each headline track", fontsize=9)
    return plots.save_figure(fig, path)
