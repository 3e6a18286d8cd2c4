"""Human models fitted to recorded sessions, and the populations that seat them.

A recorded dataset (:mod:`hri_bench.data.datasets`) becomes a human of the human protocol in two
ways (docs/people.md, "Fitted humans"):

* ``bc`` — behaviour cloning: a count model of the human's action given the episode's
  start, its goal and the state, smoothed (:func:`hri_envs.humans.fitted.count_policy`);
* ``irl`` — the paper's own fit: the Learner's ME-IRL steps on θ (Algorithm 1's update,
  :class:`agents.learner.Learner`) over the recorded episodes, ``passes`` times, and its
  human policy estimate π̂_H = softmax(τ_H Q_H) as the human's policy.

The goal of a step is where its episode ended (what the person did reveals it, as it does
for the Learner), or the assigned goal when the episode was cut off. Participants of the
finished sessions (:data:`~hri_bench.data.datasets.UNFINISHED`) are split once per dataset
into a training and a held-out set (:func:`split_participants`, by a hash of the dataset
id and the participant's id): models are fitted on the training set only, and
:func:`evaluate` scores them on the held-out participants' steps. Every step is checked
first (:mod:`hri_bench.data.checks`; a fit also needs every human action valid in its
state); an episode recorded in two files is refused, never fitted twice.

In studies and the suite, ``--population recorded:DATASET`` seats the ``bc`` model,
``--population recorded-irl:DATASET`` the ``irl`` one (:func:`recorded_human`), each run's
human with its own random stream.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.config import default_config
from agents.learner import Learner
from agents.protocol import Trace
from hri_bench.core.atomic import atomic_path
from hri_bench.data.datasets import Dataset, open_dataset
from hri_envs.errors import ConfigError
from hri_envs.humans.fitted import (
    Steps,
    action_log_likelihood,
    count_policy,
    fitted_human,
    uniform_policy,
)
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.actions import WAIT
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import spec_of

__all__ = ["KINDS", "PREFIXES", "FittedModel", "evaluate", "fit", "is_recorded",
           "recorded_human", "recorded_info", "split_participants", "validate_recorded"]

#: Fitting methods.
KINDS: tuple[str, ...] = ("bc", "irl")
#: Population name prefix -> the fit it seats.
PREFIXES: dict[str, str] = {"recorded:": "bc", "recorded-irl:": "irl"}
#: Share of participants held out for evaluation (at least one when there are two or more).
TEST_FRACTION = 0.25
#: Passes of the Learner's ME-IRL update over the training episodes.
IRL_PASSES = 5


def is_recorded(name: Any) -> bool:
    """Whether a population name is a recorded dataset's (``recorded:`` or ``recorded-irl:``)."""
    return isinstance(name, str) and name.startswith(tuple(PREFIXES))


def _parse(name: str) -> tuple[str, str]:
    """(kind, dataset) of a ``recorded...:DATASET`` population name."""
    for prefix, kind in PREFIXES.items():
        if name.startswith(prefix):
            return kind, name[len(prefix):]
    raise ConfigError(f"{name!r} is no recorded population; give "
                      f"{' or '.join(p + 'DATASET' for p in PREFIXES)}", field="population")


def split_participants(dataset_id: str, participants: list[str],
                       test_fraction: float = TEST_FRACTION) -> tuple[list[str], list[str]]:
    """(train, held out): participants ordered by sha256(dataset id, participant), the first
    ``round(test_fraction · n)`` (at least 1 when n ≥ 2, none when n = 1) held out. The split
    of a participant never changes as sessions are added, except through that count.
    """
    order = sorted(participants, key=lambda p: hashlib.sha256(
        f"{dataset_id}/{p}".encode()).hexdigest())
    n = len(order)
    n_test = 0 if n < 2 else max(1, round(test_fraction * n))
    return sorted(order[n_test:]), sorted(order[:n_test])


@dataclass(frozen=True)
class _Episodes:
    """Recorded episodes of some participants, as arrays."""

    steps: Steps
    traces: list[Any]  # agents.protocol.Trace per episode
    goals: np.ndarray  # (E,) where each ended (-1: truncated)


def _episodes(dataset: Dataset, participants: list[str]) -> _Episodes:
    empty = np.zeros(0, dtype=np.int64)
    table = dataset.steps(participants)
    if table.num_rows == 0:
        return _Episodes(Steps(empty, empty, empty, empty), [], empty)
    col = {n: table.column(n).to_numpy(zero_copy_only=False)
           for n in ("participant", "episode", "step", "start", "assigned_intention", "state",
                     "next_state", "robot_action", "human_action", "terminated")}
    graph = dataset.graph
    invalid = ~graph.valid[col["state"].astype(np.int64), col["human_action"].astype(np.int64)]
    if invalid.any():
        i = int(np.flatnonzero(invalid)[0])
        s, a = int(col["state"][i]), int(col["human_action"][i])
        raise ConfigError(f"dataset {dataset.dataset_id}: participant {col['participant'][i]} "
                          f"episode {int(col['episode'][i]) + 1} step {int(col['step'][i])}: "
                          f"the human's action {a} is not valid in state {s} "
                          f"({graph.state_names[s]}); a human model is fitted to valid "
                          "actions only", field="dataset")
    key = np.array([f"{p}/{e}" for p, e in zip(col["participant"], col["episode"],
                                               strict=True)])
    cuts = np.flatnonzero(key[1:] != key[:-1]) + 1
    traces, goals, goal_of_step = [], [], np.zeros(table.num_rows, dtype=np.int64)
    for rows in np.split(np.arange(table.num_rows), cuts):
        last = rows[-1]
        ended = bool(col["terminated"][last])
        goal = int(graph.support[col["next_state"][last]]) if ended else -1
        goals.append(goal)
        goal_of_step[rows] = goal if goal >= 0 else int(col["assigned_intention"][rows[0]])
        traces.append(Trace(np.append(col["state"][rows], col["next_state"][last]).astype(
            np.int64), col["robot_action"][rows].astype(np.int64),
            col["human_action"][rows].astype(np.int64)))
    steps = Steps(col["start"].astype(np.int64), goal_of_step, col["state"].astype(np.int64),
                  col["human_action"].astype(np.int64)).checked(graph)
    return _Episodes(steps, traces, np.array(goals, dtype=np.int64))


def _irl_policy(graph: TaskGraph, episodes: _Episodes, passes: int) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    """(θ, π̂_H (I, S, A)) after ``passes`` of the Learner's update over the episodes."""
    learner = Learner(graph, 1, default_config(spec_of(graph)))
    for _ in range(passes):
        for trace, goal in zip(episodes.traces, episodes.goals, strict=True):
            if goal >= 0:
                learner.end_episode([trace], np.array([goal]))
    return learner.theta[0].copy(), np.array(learner.pi_h[0])


@dataclass(frozen=True)
class FittedModel:
    """A human model fitted to a dataset's training participants.

    Attributes:
        kind: "bc" or "irl".
        dataset_id, content_hash, synthetic: The data it was fitted to.
        policy: (K, K, S, A) its policy table.
        theta: (F,) the fitted preference θ ("irl"), else None (saved as an empty array).
        train, test: The participants fitted to and held out.
        settings: How it was fitted (smoothing, passes).
    """

    kind: str
    dataset_id: str
    content_hash: str
    synthetic: bool
    policy: np.ndarray
    theta: np.ndarray | None
    train: list[str]
    test: list[str]
    settings: dict[str, Any]

    def human(self, graph: TaskGraph) -> ScriptedHuman:
        """The model as a human of the protocol (a policy table; no passivity)."""
        prefix = next(p for p, k in PREFIXES.items() if k == self.kind)
        return fitted_human(graph, self.policy, f"{prefix}{self.dataset_id}")

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model as an ``.npz`` archive (JSON metadata and arrays; no pickle)."""
        meta = {"format": "hri-envs/fitted-human/1", "kind": self.kind,
                "dataset_id": self.dataset_id, "content_hash": self.content_hash,
                "synthetic": self.synthetic, "train": self.train, "test": self.test,
                "settings": self.settings}
        theta = np.zeros(0) if self.theta is None else self.theta
        path = Path(path)
        with atomic_path(path, ".npz") as tmp, open(tmp, "wb") as f:  # whole or not at all
            np.savez(f, meta=np.array(json.dumps(meta)), policy=self.policy, theta=theta)
        return path


def fit(dataset: Dataset, kind: str = "bc", *, smoothing: float = 1.0,
        passes: int = IRL_PASSES) -> FittedModel:
    """Fit a human model to the dataset's training participants (:func:`split_participants`).

    Raises:
        ConfigError: An unknown kind, or no recorded episode among the training
            participants (``field="dataset"``).
    """
    if kind not in KINDS:
        raise ConfigError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}", field="kind")
    graph = dataset.graph
    train, test = split_participants(dataset.dataset_id, dataset.participants(unfinished=False))
    episodes = _episodes(dataset, train)
    if not episodes.traces:
        left = dataset.unfinished()
        raise ConfigError(f"dataset {dataset.dataset_id} has no recorded episode of a "
                          "training participant to fit to" + (
                              f" ({len(left)} unfinished session(s) are left out)" if left
                              else ""), field="dataset")
    theta = None
    if kind == "irl":
        theta, pi_h = _irl_policy(graph, episodes, passes)
        policy = fitted_human(graph, pi_h, "irl").policy
        settings: dict[str, Any] = {"passes": passes}
    else:
        policy = count_policy(graph, episodes.steps, smoothing=smoothing)
        settings = {"smoothing": smoothing}
    return FittedModel(kind, dataset.dataset_id, dataset.content_hash(), dataset.synthetic,
                       policy, theta, train, test, settings)


#: A held-out step a model gives less probability than this is "unlikely" in
#: :func:`evaluate`'s breakdown.
UNLIKELY = 1e-3


def _accuracy(p: np.ndarray, actions: np.ndarray) -> float:
    """How often the likeliest action is the one taken, ties broken evenly at random (in
    expectation: a step whose action ties with k - 1 others for the top counts 1/k), so
    the uniform policy's is the expected accuracy of a uniform choice, 1/(valid actions).
    """
    top = p >= p.max(-1, keepdims=True) * (1 - 1e-12)
    hit = top[np.arange(len(actions)), actions]
    return float(np.mean(hit / top.sum(-1)))


def _breakdown(p_taken: np.ndarray, p_uniform: np.ndarray, actions: np.ndarray
               ) -> dict[str, Any]:
    """Where a model's held-out log-likelihood goes: the steps it finds unlikely
    (:data:`UNLIKELY`), how many of them are waits, their share of its total, and its and
    the uniform policy's mean over the other steps.
    """
    log_p = np.log(np.maximum(p_taken, 1e-300))
    low = p_taken < UNLIKELY
    total = float(log_p.sum())
    wait = actions == WAIT
    return {"unlikely_steps": int(low.sum()), "unlikely_waits": int((low & wait).sum()),
            "unlikely_share": float(log_p[low].sum() / total) if total < 0 else 0.0,
            "worst_log_likelihood": float(log_p.min()),
            "others_log_likelihood": float(log_p[~low].mean()) if (~low).any() else math.nan,
            "uniform_others_log_likelihood": (float(np.log(p_uniform[~low]).mean())
                                              if (~low).any() else math.nan),
            "waits": int(wait.sum())}


def evaluate(dataset: Dataset, models: list[FittedModel]) -> dict[str, Any]:
    """Each model's, and the uniform policy's, mean log-likelihood per step and accuracy
    (:func:`_accuracy`: ties shared evenly) on the held-out participants' steps (NaN
    without held-out participants), and for each model where its log-likelihood goes
    (:func:`_breakdown`, under ``"breakdown"``).
    """
    graph = dataset.graph
    _, test = split_participants(dataset.dataset_id, dataset.participants(unfinished=False))
    steps = _episodes(dataset, test).steps
    uniform = np.broadcast_to(uniform_policy(graph), (graph.n_intentions,
                                                      *uniform_policy(graph).shape))
    out: dict[str, Any] = {"held_out": test, "steps": int(len(steps.state))}
    rows = np.arange(len(steps.state))
    p_uniform = uniform[steps.start, steps.intention, steps.state][rows, steps.action]
    for name, policy in [("uniform", uniform), *((m.kind, m.policy) for m in models)]:
        ll, acc = action_log_likelihood(np.asarray(policy), steps, graph)
        out[name] = {"log_likelihood": ll, "accuracy": acc}
        if len(rows):
            p = np.asarray(policy)[steps.start, steps.intention, steps.state]
            out[name]["accuracy"] = _accuracy(p, steps.action)
            if name != "uniform":
                out[name]["breakdown"] = _breakdown(p[rows, steps.action], p_uniform,
                                                    steps.action)
    return out


@functools.lru_cache(maxsize=16)
def _model(path: str, content_hash: str, kind: str) -> FittedModel:
    del content_hash  # part of the key: a dataset that grew is fitted anew
    return fit(open_dataset(path), kind)


def _dataset_of(name: str, graph: TaskGraph) -> tuple[str, Dataset]:
    kind, ident = _parse(name)
    if not ident:
        raise ConfigError(f"population {name!r} names no dataset; give e.g. "
                          f"'recorded:{graph.name}-people-v0'", field="population")
    dataset = open_dataset(ident, field="population")
    if dataset.scenario != graph.name:
        raise ConfigError(f"population {name!r}: dataset {dataset.dataset_id} was recorded "
                          f"on the {dataset.scenario}, not the {graph.name}",
                          field="population")
    return kind, dataset


def validate_recorded(name: str, graph: TaskGraph) -> None:
    """Raise a :class:`ConfigError` (``field="population"``) unless ``name`` names a recorded
    dataset of ``graph``'s scenario whose steps all pass the checks (:mod:`hri_bench.data.checks`,
    and valid human actions) with a training participant's episode (the root is
    ``$HRI_BENCH_DATASETS``, else ``~/.hri-bench/datasets``; a dataset folder's path works
    too). Studies call it before anything is simulated.
    """
    _, dataset = _dataset_of(name, graph)
    try:
        dataset.content_hash()  # reads and checks every finished session's steps
        train, _ = split_participants(dataset.dataset_id, dataset.participants(unfinished=False))
        episodes = _episodes(dataset, train)
    except ConfigError as exc:
        raise ConfigError(f"population {name!r}: {exc}", field="population") from None
    if not episodes.traces:
        raise ConfigError(f"population {name!r}: dataset {dataset.dataset_id} has no recorded "
                          "episode of a training participant yet", field="population")


def recorded_info(name: str, graph: TaskGraph) -> dict[str, Any]:
    """A recorded population's ``population_info`` (as a split's,
    :meth:`hri_bench.run.study.StudyConfig.population_info`): ``hash`` is the content hash
    of the dataset's finished sessions (:meth:`Dataset.content_hash`, what the model is
    fitted to and scored on), ``version`` the dataset id's, ``members`` the training
    participants; and ``dataset_id``, ``synthetic``, ``fit`` (bc or irl).
    """
    kind, dataset = _dataset_of(name, graph)
    train, _ = split_participants(dataset.dataset_id, dataset.participants(unfinished=False))
    return {"name": name, "version": dataset.dataset_id.rsplit("-v", 1)[1],
            "hash": dataset.content_hash(), "held_out": None, "members": len(train),
            "dataset_id": dataset.dataset_id, "synthetic": dataset.synthetic, "fit": kind}


def recorded_human(name: str, graph: TaskGraph) -> ScriptedHuman:
    """The human ``recorded:DATASET`` (bc) or ``recorded-irl:DATASET`` (irl) names on
    ``graph``, fitted once per process and dataset content.
    """
    kind, dataset = _dataset_of(name, graph)
    model = _model(str(dataset.path.resolve()), dataset.content_hash(), kind)
    return fitted_human(graph, model.policy, name)
