"""A physical human fitted to recorded physical sessions, and the population that seats it.

The continuous envs' human is the reference human of
:class:`~hri_envs.physics.carry.human.intention.HumanParams`: a route to their goal (their
``preference``), a minimum-jerk reference along it at their ``speed``, started after ``reaction_s``
and paused ``hesitation_s`` before each line, yielding to a robot that leads their way. A
participant of ``hri-bench serve
--physical`` moves their hand's target themselves; this module finds the reference human
whose hand target comes nearest theirs, step by step, on the object's recorded motion
(teacher forcing: the reference advanced on the recorded object poses, exactly as
:class:`~hri_bench.people.synthetic.ScriptedLeader` advances it on the page's frames):

* per participant, the ``preference`` is the route (of the scenario's preferences) whose
  reference at the default timing comes nearest, then ``speed``, ``reaction_s`` and
  ``hesitation_s`` are fitted by nonlinear least squares (:func:`scipy.optimize.
  least_squares`, bounded: :data:`BOUNDS`) of the hand target's position and of its
  rotation (metres, the rotation in radians times :data:`LEVER_M`);
* the arm's body, strength, grip and stiffness are not what a person's target says: they
  are the session's own (``session.json``'s ``human_params``, the arm the server
  simulated), with the stiffness scaled by the mean impedance scale the participant asked
  for.

Participants are split once per dataset into training and held-out ones (the graph fits'
:func:`~hri_bench.data.fit.split_participants`). :func:`fit_physical` fits every training
participant; the fitted population (:meth:`PhysicalFit.population`, one member per training
participant) is scored on the held-out participants by the hand-target error of its member
nearest each held-out participant (the error a population of these humans leaves on a new
person), beside the same error on the training participants and the default human's
(:class:`HumanParams`) on both. :meth:`PhysicalFit.save` writes the population as a file
any physical population name may point at: ``fitted:<path>`` (:func:`hri_envs.physics.
carry.human.population.physical_population`), so a physical suite or env seats it as it seats the
frozen ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hri_bench.data.datasets import Dataset
from hri_bench.data.fit import split_participants
from hri_envs.errors import ConfigError
from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.human.population import save_population
from hri_envs.task.graph import TaskGraph
from hri_envs.task.scenarios import NamedScenario

__all__ = ["BOUNDS", "FITTED", "LEVER_M", "PhysicalFit", "fit_physical", "target_error"]

#: The reference's parameters fitted by least squares, and their bounds.
FITTED: tuple[str, ...] = ("speed", "reaction_s", "hesitation_s")
BOUNDS: dict[str, tuple[float, float]] = {"speed": (0.3, 2.5), "reaction_s": (0.0, 2.0),
                                          "hesitation_s": (0.0, 2.5)}
#: A rotation of the target [rad] weighs as this many metres of its position.
LEVER_M = 0.1


@dataclass(frozen=True)
class _Episode:
    start: int
    goal: int
    layout: list[float]
    objects: np.ndarray   # (T, 7) the object's pose before each step
    targets: np.ndarray   # (T, 7) the participant's hand targets


@dataclass(frozen=True)
class _Person:
    participant: str
    episodes: tuple[_Episode, ...]
    human: HumanParams      # the session's simulated arm
    stiffness: float        # the mean impedance scale the participant asked for
    steps: int


def _people(dataset: Dataset, participants: Sequence[str]) -> list[_Person]:
    meta = {m["participant"]: m for m in dataset.sessions()}
    table = dataset.steps(list(participants))
    who = np.asarray(table.column("participant").to_pylist())
    episode = table.column("episode").to_numpy()
    start = table.column("start").to_numpy()
    goal = table.column("assigned_intention").to_numpy()
    obs = table.column("robot_observation").to_pylist()
    targets = table.column("hand_target").to_pylist()
    layouts = table.column("layout").to_pylist()
    stiff = table.column("stiffness").to_numpy()
    out = []
    for p in participants:
        rows = np.flatnonzero(who == p)
        eps = []
        for e in sorted(set(episode[rows].tolist())):
            r = rows[episode[rows] == e]
            eps.append(_Episode(int(start[r[0]]), int(goal[r[0]]), list(layouts[r[0]] or []),
                                np.asarray([obs[i][:7] for i in r], dtype=float),
                                np.asarray([targets[i] for i in r], dtype=float)))
        out.append(_Person(p, tuple(eps), HumanParams.of(meta[p].get("human_params") or {}),
                           float(np.mean(stiff[rows])), len(rows)))
    return out


def _predict(graph: TaskGraph, ep: _Episode, params: HumanParams) -> np.ndarray:
    """(T, 7) the reference human's hand targets on the episode's recorded object poses."""
    from hri_bench.people.synthetic import ScriptedLeader  # noqa: PLC0415

    leader = ScriptedLeader(graph, params)
    leader.begin({"layout": ep.layout, "start": ep.start, "goal": ep.goal},
                 {"bodies": ["object"]})
    return np.asarray([leader.target({"poses": list(o)}) for o in ep.objects])


def _residuals(graph: TaskGraph, episodes: Sequence[_Episode], params: HumanParams
               ) -> np.ndarray:
    """Per step: the target's position error (3) and its rotation error [rad] x LEVER_M."""
    parts = []
    for ep in episodes:
        pred = _predict(graph, ep, params)
        dots = np.abs(np.sum(pred[:, 3:] * ep.targets[:, 3:], axis=1)) / (
            np.linalg.norm(pred[:, 3:], axis=1) * np.linalg.norm(ep.targets[:, 3:], axis=1))
        angle = 2.0 * np.arccos(np.clip(dots, 0.0, 1.0))
        parts.append(np.column_stack([pred[:, :3] - ep.targets[:, :3], LEVER_M * angle]))
    return np.concatenate(parts).ravel() if parts else np.zeros(0)


def target_error(graph: TaskGraph, episodes: Sequence[_Episode], params: HumanParams
                 ) -> float:
    """The root-mean-square hand-target error [m] of ``params`` on ``episodes`` of ``graph``'s
    scenario (per step,
    over the position's 3 coordinates and the weighted rotation).
    """
    r = _residuals(graph, episodes, params)
    return float(np.sqrt(np.mean(r * r))) if r.size else math.nan


def _path_error(graph: TaskGraph, episodes: Sequence[_Episode], params: HumanParams) -> float:
    """How far the recorded targets lie from the route of ``params`` whatever the timing:
    the mean distance [m] from each recorded target position to the nearest of the
    reference's (fast, without pauses) and back.
    """
    fast = dataclasses.replace(params, speed=BOUNDS["speed"][1], reaction_s=0.0,
                               hesitation_s=0.0)
    total = 0.0
    for ep in episodes:
        pred = _predict(graph, ep, fast)[:, :3]
        d = np.linalg.norm(pred[:, None, :] - ep.targets[None, :, :3], axis=2)
        total += float(d.min(axis=0).mean() + d.min(axis=1).mean())
    return total


def _timed(base: HumanParams, x: Sequence[float] | np.ndarray) -> HumanParams:
    """``base`` with :data:`FITTED`'s values ``x``."""
    speed, reaction, hesitation = (float(v) for v in x)
    return dataclasses.replace(base, speed=speed, reaction_s=reaction,
                               hesitation_s=hesitation)


def _fit_person(graph: TaskGraph, person: _Person, preferences: Sequence[str]) -> HumanParams:
    from scipy.optimize import least_squares  # noqa: PLC0415

    base = dataclasses.replace(person.human, stiffness=person.human.stiffness
                               * max(person.stiffness, 1e-3))
    preference = min(preferences, key=lambda p: _path_error(
        graph, person.episodes, dataclasses.replace(base, preference=p)))
    base = dataclasses.replace(base, preference=preference)
    low = np.array([BOUNDS[k][0] for k in FITTED])
    high = np.array([BOUNDS[k][1] for k in FITTED])

    def residuals(x: np.ndarray) -> np.ndarray:
        return _residuals(graph, person.episodes, _timed(base, x))

    best: tuple[float, np.ndarray] | None = None
    defaults = HumanParams()
    for x0 in ([getattr(defaults, k) for k in FITTED], [0.8, 0.6, 0.8]):
        res = least_squares(residuals, np.clip(x0, low, high), bounds=(low, high),
                            diff_step=0.02, x_scale=np.array([0.3, 0.2, 0.3]),
                            max_nfev=40)
        if best is None or res.cost < best[0]:
            best = (float(res.cost), res.x)
    assert best is not None
    return _timed(base, [round(float(v), 4) for v in best[1]])


@dataclass(frozen=True)
class PhysicalFit(NamedScenario):
    """Reference humans fitted to a physical dataset's training participants (the
    scenario's name resolved once: :attr:`graph`).

    Attributes:
        dataset_id, scenario, content_hash: The dataset fitted (its scenario's name, its
            hash at the fit).
        synthetic: The dataset holds scripted humans, not people.
        train, held_out: The participants fitted to and held out.
        members: (len(train),) each training participant's fitted human.
        scores: The hand-target RMS errors [m] (module docstring): ``train`` and
            ``held_out`` of the fitted population (its nearest member), ``default_train``
            and ``default_held_out`` of the default human; and ``steps_train``,
            ``steps_held_out``.
    """

    dataset_id: str
    scenario: str
    content_hash: str
    synthetic: bool
    train: tuple[str, ...]
    held_out: tuple[str, ...]
    members: tuple[HumanParams, ...]
    scores: dict[str, float]

    def population(self) -> Any:
        """The fitted humans as a
        :class:`~hri_envs.physics.carry.human.population.PhysicalPopulation` (family ``fitted``, one
        member per training participant).
        """
        from hri_envs.physics.carry.human.population import fitted_population  # noqa: PLC0415

        return fitted_population(f"fitted:{self.dataset_id}", self.graph, self.members,
                                 [f"fitted/{p}" for p in self.train])

    def save(self, path: str | Path) -> Path:
        """Write the population file (``fitted:<path>`` names it); returns its path."""
        source = {"dataset": self.dataset_id, "content_hash": self.content_hash,
                  "synthetic": self.synthetic, "train": list(self.train),
                  "held_out": list(self.held_out), "fitted": list(FITTED),
                  "scores": self.scores}
        return save_population(path, self.graph, self.members,
                               [f"fitted/{p}" for p in self.train], source=source)


def fit_physical(dataset: Dataset) -> PhysicalFit:
    """Fit a reference human to each training participant of a physical dataset and score
    the fitted population on the held-out ones (module docstring).

    Raises:
        ConfigError: Not a physical dataset, or fewer than two finished participants.
    """
    if not dataset.physical:
        raise ConfigError(f"{dataset.dataset_id} holds graph sessions; fit them with "
                          "hri_bench.data.fit.fit", field="dataset")
    who = dataset.participants(unfinished=False)
    if len(who) < 2:
        raise ConfigError(f"{dataset.dataset_id} has {len(who)} finished participant(s); a "
                          "physical fit needs two or more (one held out)", field="dataset")
    train, test = split_participants(dataset.dataset_id, who)
    preferences = tuple(dataset.spec.preferences)
    fitting, held = _people(dataset, train), _people(dataset, test)
    members = tuple(_fit_person(dataset.graph, p, preferences) for p in fitting)
    sc = dataset.graph

    def nearest(people: list[_Person]) -> float:
        sq = [min(target_error(sc, p.episodes, m) for m in members) ** 2 * p.steps
              for p in people]
        return float(np.sqrt(np.sum(sq) / max(1, sum(p.steps for p in people))))

    def default(people: list[_Person]) -> float:
        d = HumanParams()
        sq = [target_error(sc, p.episodes, _timed(dataclasses.replace(
              p.human, preference=None), [d.speed, d.reaction_s, d.hesitation_s])) ** 2
              * p.steps for p in people]
        return float(np.sqrt(np.sum(sq) / max(1, sum(p.steps for p in people))))

    scores = {"train": nearest(fitting), "held_out": nearest(held),
              "default_train": default(fitting), "default_held_out": default(held),
              "steps_train": float(sum(p.steps for p in fitting)),
              "steps_held_out": float(sum(p.steps for p in held))}
    return PhysicalFit(dataset.dataset_id, dataset.scenario, dataset.content_hash(),
                       dataset.synthetic, tuple(train), tuple(test), members, scores)
