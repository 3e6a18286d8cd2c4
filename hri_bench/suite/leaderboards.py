"""The suite's numbers per track and its leaderboards: ``suite.json``'s track summaries
(:func:`track_summary` and its v2, v3 forms: means and IQMs with 95 % bootstrap CIs, the
episodes to converge, :data:`CONVERGED`) and ``leaderboard.md``'s text per suite version
(:func:`leaderboard` to :func:`leaderboard_v4`). :func:`hri_bench.suite.running.run_suite`
calls them; see docs/benchmark.md, "Suite".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hri_bench.core import stats
from hri_bench.run import metrics
from hri_bench.run.regret import ALL_REFERENCES, REFERENCES, reference_summary
from hri_bench.run.study import (
    StudyResult,
    regret_reference,
)
from hri_bench.suite import results_v3, results_v4
from hri_bench.suite.markdown import code, escape, number, with_ci
from hri_bench.suite.submission import task_section
from hri_bench.suite.tracks import (
    ALPHA,
    DELTA,
    DELTA_V3,
    MAX_BLOCKS,
    POWER,
    Track,
    detectable_v3,
)

#: An agent has converged from the first episode after which its mean regret over runs
#: stays at or below this (reward units per episode).
CONVERGED = 0.05


def _summary(x: np.ndarray, seed: int) -> dict[str, Any]:
    """Mean and IQM over runs of each run's episode mean, with 95 % CIs
    (:func:`hri_bench.run.metrics.summary` without the median); per-episode means.
    """
    per_ep = stats.per_episode(x, seed, iqm_ci=False)
    return {**metrics.summary(x.mean(1), seed, median=False),
            "per_episode": {"mean": per_ep["mean"], "ci95": per_ep["ci95"]}}


def episodes_to_converge(regret: np.ndarray, threshold: float = CONVERGED) -> int | None:
    """The first episode (1-based) from which the mean regret over runs stays ≤ threshold.

    Args:
        regret: (runs, episodes) regret against blind.
        threshold: The tolerance, reward units per episode.

    Returns:
        The episode, or None when the last episode's mean regret is above the threshold.
    """
    above = np.flatnonzero(regret.mean(0) > threshold + 1e-12)
    if len(above) == 0:
        return 1
    last = int(above[-1]) + 1  # 1-based episode of the last excursion
    return None if last == regret.shape[1] else last + 1


def track_summary(track: Track, result: StudyResult) -> dict[str, Any]:
    """The ``suite.json`` entry of a track."""
    cfg = result.config
    blind, note = regret_reference(result)
    agents: dict[str, Any] = {}
    for name, m in result.metrics.items():
        entry: dict[str, Any] = {"reward": _summary(m["reward"], cfg.seed)}
        if blind is not None:
            regret = blind - m["reward"]
            entry["regret"] = _summary(regret, cfg.seed)
            entry["episodes_to_converge"] = episodes_to_converge(regret)
        else:
            entry["regret"] = None
            entry["episodes_to_converge"] = None
        entry.update(wrong_rate=float(m["wrong"].mean()), passive_rate=float(m["passive"].mean()),
                     truncation_rate=float(m["truncated"].mean()))
        agents[name] = entry
    return {"description": track.description, "scenario": track.scenario,
            "runs": cfg.runs, "episodes": cfg.n_episodes,
            "settings": cfg.settings(), "regret": note,
            "regret_reported": blind is not None, "agents": agents,
            "failed_agents": sorted(result.failures)}


def track_summary_v2(track: Track, result: StudyResult) -> dict[str, Any]:
    """A v2 ``suite.json`` entry: v1's, plus the reference, the gaps, the population and
    the power analysis.
    """
    entry = track_summary(track, result)
    ref = reference_summary(result)
    cfg = result.config
    for name, gaps in ref.pop("gaps").items():
        entry["agents"][name]["gap_to_upper"] = gaps["to_upper"]
        entry["agents"][name]["gap_to_lower"] = gaps["to_lower"]
    entry["reference"] = ref
    entry["population"] = cfg.population_info()
    entry["headline"] = track.headline
    entry["stable_preference"] = track.stable
    sd = track.pilot_sd
    entry["power"] = {
        "delta": DELTA, "power": POWER, "alpha": ALPHA, "pilot_sd": sd,
        "runs_needed": None if not sd else stats.runs_for_difference(sd, DELTA, power=POWER,
                                                                     alpha=ALPHA),
        "runs": cfg.runs,
        "detectable": None if not sd else round(stats.detectable_difference(
            sd, cfg.runs, power=POWER, alpha=ALPHA), 4)}
    return entry


def track_summary_v3(track: Track, result: StudyResult) -> dict[str, Any]:
    """A v3 ``suite.json`` entry: v2's, with v3's power analysis (humans, runs per human,
    the pilot's two spreads, the difference detected and whether it meets
    :data:`DELTA_V3`) in place of v2's.
    """
    entry = track_summary_v2(track, result)
    humans = getattr(track, "humans", 1)
    between, within = getattr(track, "pilot_between", 0.0), getattr(track, "pilot_within", 0.0)
    runs = result.config.runs
    humans = min(humans, runs)  # a runs scale below 1 meets fewer of them
    blocks = max(1, runs // humans)
    found = detectable_v3(between, within, humans, blocks)  # one human: blocks == runs
    entry["power"] = {"delta": DELTA_V3, "power": POWER, "alpha": ALPHA, "humans": humans,
                      "runs_per_human": blocks, "pilot_between": between,
                      "pilot_within": within, "detectable": found,
                      "met": bool(found <= DELTA_V3)}
    return entry


def _cells(tr: dict[str, Any], agents: list[str], value: Any) -> list[str]:
    """A leaderboard row's cells: ``value(entry)`` per agent, "raised" where it failed on the
    track, "—" where it does not run there.
    """
    return ["raised" if a in tr["failed_agents"] else "—" if tr["agents"].get(a) is None
            else value(tr["agents"][a]) for a in agents]


def _overview(doc: dict[str, Any]) -> list[str]:
    """One table over all tracks: mean regret [95 % CI] (reward, marked "r", where n/a)."""
    agents = list(doc["agents"]) + [a for a in ("oracle", "blind", "informed")
                                    if a not in doc["agents"]]
    agents = [a for a in agents if any(a in tr["agents"] for tr in doc["tracks"].values())]
    lines = ["## Overview", "", "Mean regret vs blind per episode [95 % CI]; where regret is "
             "n/a, the mean reward (marked r). — : the agent does not run on the track; raised: "
             "it failed there (errors.log).", "",
             "| track | " + " | ".join(code(a) for a in agents) + " |",
             "|---|" + "---|" * len(agents)]
    for name, tr in doc["tracks"].items():
        cells = _cells(tr, agents, (lambda e: with_ci(e["regret"])) if tr["regret_reported"]
                       else (lambda e: "r " + with_ci(e["reward"])))
        lines.append(f"| {escape(name)} | " + " | ".join(cells) + " |")
    return [*lines, ""]


def leaderboard(doc: dict[str, Any]) -> str:
    """The ``leaderboard.md`` text of a v1 ``suite.json`` document."""
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Regret = blind's exact "
             "expected episode reward minus the agent's, per episode; mean and IQM over runs "
             "of each run's mean over its episodes, with 95 % bootstrap CIs. Lower regret is "
             "better; agents are sorted by mean regret (by reward where regret is n/a).", "",
             "References: `informed` is the information bound (the exact optimum for a robot "
             "that sees the intention); `blind` is the ceiling for intention-blind robots "
             "(regret 0 by definition in expectation); `oracle` is the paper's heuristic "
             "(sees the intention, not optimal: no bound). Regret is n/a where the human is "
             "Boltzmann (the held-out population): the exact blind plan does not fit it.",
             ""]
    lines += _overview(doc)
    for name, tr in doc["tracks"].items():
        lines += [f"## {escape(name)}", "", f"{escape(tr['description'])} ({tr['runs']} runs × "
                  f"{tr['episodes']} episodes).", ""]
        if not tr["regret_reported"]:
            lines += [f"Regret n/a: {escape(tr['regret'].removeprefix('not reported: '))}.",
                      ""]
        if tr["failed_agents"]:
            lines += ["Raised, no results (tracebacks in errors.log): "
                      + ", ".join(code(a) for a in tr["failed_agents"]) + ".", ""]
        lines += ["| agent | regret mean [95 % CI] | regret IQM [95 % CI] | "
                  "reward mean [95 % CI] | wrong | passive | truncated | converged at |",
                  "|---|---|---|---|---|---|---|---|"]

        def key(item: tuple[str, Any]) -> tuple[float, str]:
            a = item[1]
            v = a["regret"]["mean"] if a["regret"] is not None else -a["reward"]["mean"]
            return (v, item[0])

        for agent, a in sorted(tr["agents"].items(), key=key):
            conv = a["episodes_to_converge"]
            conv_text = "n/a" if a["regret"] is None else "never" if conv is None else str(conv)
            label = code(agent) + (" (ref.)" if agent in REFERENCES else "")
            lines.append(f"| {label} | {with_ci(a['regret'])} | {with_ci(a['regret'], 'iqm')}"
                         f" | {with_ci(a['reward'])} | {a['wrong_rate']:.3f} | "
                         f"{a['passive_rate']:.3f} | {a['truncation_rate']:.1%} | {conv_text} |")
        lines.append("")
    return "\n".join(lines)


def _reference_cell(tr: dict[str, Any]) -> str:
    ref = tr["reference"]
    if ref["kind"] == "exact":
        return f"exact: blind {number(ref['lower_reward'])}, informed {number(ref['upper_reward'])}"
    if ref["kind"] == "bracket":
        return (f"bracket: blind in [{number(ref['lower_reward'])} (qmdp), "
                f"{number(ref['upper_reward'])} (informed)]")
    return ref["kind"]


def leaderboard_v2(doc: dict[str, Any]) -> str:
    """The ``leaderboard.md`` text of a v2 ``suite.json`` document."""
    ranked = [a for a in doc["agents"] if any(a in tr["agents"] for tr in doc["tracks"].values())]
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Headline: the frozen "
             "**test** split (the evaluation set; population hashes below). Every track has a "
             "reference: `blind` **exact** where it fits (the paper tracks), else a labelled "
             "**bracket** on it: `qmdp` below (a feasible intention-blind policy that knows "
             "the human's model; simulated) and `informed` above (the exact optimum that sees "
             "the intention; no robot expects more). Cells: an agent's **gap to the upper "
             "bound** (`informed`): the mean over runs of informed's run-mean reward per "
             "episode minus the agent's (paired runs: same humans, same schedules), with its "
             "95 % bootstrap CI; lower is better. Runs per track: enough to detect "
             f"{doc['power']['delta']} per episode at {doc['power']['power']:.0%} power "
             f"(α = {doc['power']['alpha']}), from a pilot's spread, within "
             f"[{doc['power']['min_runs']}, {doc['power']['max_runs']}].", "",
             "## Overview: gap to the upper bound (informed) per episode [95 % CI]", "",
             "| track | reference | " + " | ".join(code(a) for a in ranked) + " |",
             "|---|---|" + "---|" * len(ranked)]
    for name, tr in doc["tracks"].items():
        cells = _cells(tr, ranked, lambda e: with_ci(e["gap_to_upper"]))
        label = f"**{escape(name)}**" if tr["headline"] else escape(name)
        lines.append(f"| {label} | {_reference_cell(tr)} | " + " | ".join(cells) + " |")
    lines.append("")
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)


def _track_section(name: str, tr: dict[str, Any]) -> list[str]:
    """A v2 or v3 leaderboard's section of one track: its humans, power, reference and a
    table of the agents by mean reward with their gaps to both ends.
    """
    pop = tr["population"]
    pop_text = ("" if pop is None else f" Population {code(pop['name'])}." if pop["hash"] is None
                else f" Population {code(pop['name'])} v{pop['version']} ({pop['members']} "
                f"members), hash `{pop['hash'][:16]}`.")
    power = tr["power"]
    if "pilot_sd" in power:  # v2
        power_text = ("" if power["pilot_sd"] is None else
                      f" Pilot spread {power['pilot_sd']:.3f}: {power['runs_needed']} runs "
                      f"needed for {power['delta']}; {power['runs']} run, which detect "
                      f"{power['detectable']}.")
    else:
        power_text = (f" Power: {power['humans']} human(s) × {power['runs_per_human']} runs "
                      f"detect a normalised difference of {power['detectable']} at "
                      f"{power['power']:.0%} ({'meets' if power['met'] else 'MISSES'} the "
                      f"target {power['delta']}).")
    ref = tr["reference"]
    lines = [f"## {escape(name)}", "", f"{escape(tr['description'])} ({tr['runs']} runs × "
             f"{tr['episodes']} episodes).{pop_text}{power_text}", "",
             f"Reference: {_reference_cell(tr)}. {escape(ref['note'].capitalize())}.", ""]
    if tr["failed_agents"]:
        lines += ["Raised, no results (tracebacks in errors.log): "
                  + ", ".join(code(a) for a in tr["failed_agents"]) + ".", ""]
    lower = "regret vs blind (exact)" if ref["kind"] == "exact" else "gap to qmdp (lower)"
    lines += [f"| agent | reward mean [95 % CI] | gap to informed (upper) | {lower} | "
              "wrong | passive | truncated |", "|---|---|---|---|---|---|---|"]

    def key(item: tuple[str, Any]) -> tuple[float, str]:
        return (-item[1]["reward"]["mean"], item[0])

    for agent, a in sorted(tr["agents"].items(), key=key):
        label = code(agent) + (" (ref.)" if agent in ALL_REFERENCES else "")
        lines.append(f"| {label} | {with_ci(a['reward'])} | {with_ci(a['gap_to_upper'])} | "
                     f"{with_ci(a['gap_to_lower'])} | {a['wrong_rate']:.3f} | "
                     f"{a['passive_rate']:.3f} | {a['truncation_rate']:.1%} |")
    lines.append("")
    return lines


def leaderboard_v3(doc: dict[str, Any], results: dict[str, Any] | None) -> str:
    """The ``leaderboard.md`` text of a v3 suite: the headline and pairs
    (:func:`hri_bench.suite.results_v3.lead_section`), where learners fail, the tracks that miss
    their power target, the task's metrics, then a section per track.
    """
    lines = [f"# hri-envs benchmark suite v{doc['suite_version']}", "",
             f"Seed {doc['seed']}, runs scale {doc['runs_scale']}. Headline: the frozen test "
             "split v2 (160 different humans per scenario, none a train or validation human), "
             "one track per group of humans, each normalised to its reachable reference "
             "(docs/results.md, \"Ranking (suite v3)\").", ""]
    if results is not None:
        lines += [results_v3.lead_section(results), results_v3.failure_section(results)]
    missed = [f"{n} (detects {tr['power']['detectable']})" for n, tr in doc["tracks"].items()
              if not tr["power"]["met"]]
    target = (f"Power target: a normalised difference of {DELTA_V3} at {POWER:.0%} "
              f"(α = {ALPHA}), with the two-stage spread a pilot on the validation-v2 split "
              f"measured; at most {MAX_BLOCKS} runs per human.")
    lines += ["## Power", "", target + (" Tracks that miss it: " + "; ".join(missed) + "."
                                        if missed else " Every track meets it."), ""]
    if results is not None:
        lines.append(task_section(results))
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)


def leaderboard_v4(doc: dict[str, Any], results: dict[str, Any] | None) -> str:
    """The ``leaderboard.md`` text of a v4 suite: v3's (:func:`leaderboard_v3`) with the
    learners ranked apart from the references, shared ranks and the references' noise in
    the intervals (:func:`hri_bench.suite.results_v4.lead_section`).
    """
    text = leaderboard_v3(doc, None)
    head, rest = text.split("\n## Power", 1)
    head = head.replace("the frozen test split v2 (160 different humans per scenario, none a "
                        "train or validation human)", "the frozen test split v3 (160 humans "
                        "per scenario, none the same as another or as a train or validation "
                        "human by behaviour, docs/humans.md)").replace(
        "\"Ranking (suite v3)\"", "\"Ranking (suite v4)\"")
    parts = [head.rstrip("\n"), ""]
    if results is not None:
        refs = [a for a, r in results.get("roles", {}).items() if r["reference"]]
        parts += [results_v4.lead_section(results),
                  results_v3.failure_section(results, refs)]
    power = rest.split("\n## ", 1)[0].rstrip("\n").replace("validation-v2", "validation-v3")
    lines = [*parts, "## Power" + power, ""]
    if results is not None:
        lines.append(task_section(results))
    for name, tr in doc["tracks"].items():
        lines += _track_section(name, tr)
    return "\n".join(lines)
