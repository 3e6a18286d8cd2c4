"""Humans fitted to recorded steps: a policy table estimated from what people did.

A recording (``hri-bench dataset``, docs/people.md) holds, per step, the episode's start
support, the human's intention ι, the state and the human's action. Two fits turn such
steps into a human of the human protocol:

* **Behaviour cloning** (:func:`count_policy`): a tabular count model of the human's action
  given (start, ι, state), smoothed towards the same counts without the start and those
  towards a prior (uniform over the valid actions unless given, e.g. an IRL policy)::

      p(a | ι, s)        ∝ n(ι, s, a)        + α · prior(a | ι, s)
      p(a | k, ι, s)     ∝ n(k, ι, s, a)     + α · p(a | ι, s)

  with ``α`` the smoothing weight (in steps). A state never visited gets the prior.
* **IRL** (in :mod:`hri_bench.data.fit`): the Learner's own ME-IRL fit of a preference θ over
  the features φ, whose soft-max policy π̂_H(a | s, ι) is such a table too.

Either table becomes a :class:`~hri_envs.humans.scripted.ScriptedHuman` through
:func:`fitted_human` (no passivity, no turning back: what the person did in a step is in
the table), so it sits in every seat a scripted human sits in: the robot envs
(``human=``), :class:`~hri_envs.humans.tables.TableHumans` in the benchmark, and studies
(``--population recorded:DATASET``). :func:`action_log_likelihood` scores a table on
held-out steps.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from hri_envs.errors import ConfigError
from hri_envs.humans.scripted import ScriptedHuman
from hri_envs.task.graph import TaskGraph

__all__ = ["Steps", "action_log_likelihood", "count_policy", "fitted_human", "uniform_policy"]


class Steps(NamedTuple):
    """Recorded human steps, each (N,) int: the episode's start support, the intention ι,
    the state and the human's action.
    """

    start: np.ndarray
    intention: np.ndarray
    state: np.ndarray
    action: np.ndarray

    def checked(self, graph: TaskGraph) -> Steps:
        """These steps as int64 arrays, checked against ``graph``.

        Raises:
            ConfigError: Arrays of different lengths, or an index outside the graph's
                supports, states or actions, or an action invalid in its state (``field``
                names the array).
        """
        arrays = [np.asarray(x) for x in self]
        n = len(arrays[0]) if arrays[0].ndim == 1 else -1
        for name, x in zip(self._fields, arrays, strict=True):
            if x.ndim != 1 or len(x) != n or (n and x.dtype.kind not in "iu"):
                raise ConfigError(f"steps must be four 1-d integer arrays of one length; "
                                  f"{name} is {x.dtype} of shape {x.shape}", field=name)
        limits = {"start": graph.n_intentions, "intention": graph.n_intentions,
                  "state": graph.n_states, "action": graph.n_actions}
        for name, x in zip(self._fields, arrays, strict=True):
            if n and (x.min() < 0 or x.max() >= limits[name]):
                raise ConfigError(f"{name} must lie in [0, {limits[name]}) for the "
                                  f"{graph.name}; got values in [{x.min()}, {x.max()}]",
                                  field=name)
        out = Steps(*(x.astype(np.int64) for x in arrays))
        if n and not graph.valid[out.state, out.action].all():
            i = int(np.flatnonzero(~graph.valid[out.state, out.action])[0])
            raise ConfigError(f"step {i}: action {out.action[i]} is not valid in state "
                              f"{out.state[i]} of the {graph.name}", field="action")
        return out


def uniform_policy(graph: TaskGraph) -> np.ndarray:
    """(I, S, A) the uniform policy over each state's valid actions."""
    valid = graph.valid.astype(float)
    per_state = valid / valid.sum(1, keepdims=True)  # (S, A)
    return np.broadcast_to(per_state, (graph.n_intentions, *per_state.shape)).copy()


def _normalised(counts: np.ndarray, valid: np.ndarray) -> np.ndarray:
    counts = np.where(valid, counts, 0.0)
    total = counts.sum(-1, keepdims=True)
    return np.divide(counts, total, out=np.zeros_like(counts), where=total > 0)


def count_policy(graph: TaskGraph, steps: Steps, *, smoothing: float = 1.0,
                 prior: np.ndarray | None = None) -> np.ndarray:
    """(K, K, S, A) behaviour cloning: ``p(a | start, ι, s)`` from counts with smoothing.

    Args:
        graph: The task graph.
        steps: The recorded steps (:class:`Steps`).
        smoothing: α > 0, the weight of the level below in steps (see the module docstring).
        prior: (I, S, A) the policy a state without data gets (default
            :func:`uniform_policy`); zero on invalid actions, rows summing to 1.

    Returns:
        Probabilities over the valid actions of every (start, ι, state); zero elsewhere.
    """
    if isinstance(smoothing, bool) or not isinstance(smoothing, int | float) or not (
            np.isfinite(smoothing) and smoothing > 0):
        raise ConfigError(f"smoothing must be a number > 0, got {smoothing!r}",
                          field="smoothing")
    steps = steps.checked(graph)
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    valid = graph.valid.astype(bool)
    if prior is None:
        prior = uniform_policy(graph)
    prior = np.asarray(prior, dtype=float)
    if prior.shape != (n_k, n_s, n_a) or not np.all(np.isfinite(prior)) or (prior < 0).any():
        raise ConfigError(f"prior must be (I, S, A) = {(n_k, n_s, n_a)} probabilities, got "
                          f"shape {prior.shape}", field="prior")
    prior = _normalised(prior, valid[None])
    full = np.zeros((n_k, n_k, n_s, n_a))  # (K, K, S, A)
    np.add.at(full, (steps.start, steps.intention, steps.state, steps.action), 1.0)
    by_intention = full.sum(0)  # (I, S, A)
    middle = _normalised(by_intention + smoothing * prior, valid[None])
    return _normalised(full + smoothing * middle[None], valid[None, None])


def fitted_human(graph: TaskGraph, policy: np.ndarray, name: str) -> ScriptedHuman:
    """A :class:`ScriptedHuman` acting by a fitted ``policy`` (no passivity, never turns back).

    Args:
        graph: The task graph.
        policy: (K, K, S, A) ``p(a | start, ι, s)``, or (I, S, A) ``p(a | s, ι)`` shared by
            every start; probabilities over the valid actions.
        name: How the human is labelled (e.g. ``"recorded:hanger-people-v0"``).

    Raises:
        ConfigError: A table of another shape, with NaN or negative entries, probability on
            invalid actions, or a row that does not sum to 1 (``field="policy"``).
    """
    n_k, n_s, n_a = graph.n_intentions, graph.n_states, graph.n_actions
    table = np.asarray(policy, dtype=float)
    if table.shape == (n_k, n_s, n_a):
        table = np.broadcast_to(table, (n_k, *table.shape))
    if table.shape != (n_k, n_k, n_s, n_a):
        raise ConfigError(f"policy must be (K, K, S, A) = {(n_k, n_k, n_s, n_a)} or (I, S, A), "
                          f"got shape {np.shape(policy)}", field="policy")
    if not np.all(np.isfinite(table)) or (table < 0).any():
        raise ConfigError("policy must hold probabilities (finite, >= 0)", field="policy")
    if not np.allclose(table.sum(-1), 1.0, atol=1e-9):
        raise ConfigError("every row of policy must sum to 1 over the valid actions",
                          field="policy")
    table = table / table.sum(-1, keepdims=True)
    table = np.where(graph.valid[None, None].astype(bool), table, 0.0)
    return ScriptedHuman(graph, np.ascontiguousarray(table), name,
                         np.full((n_k, n_k), -1, dtype=np.int64))


def action_log_likelihood(policy: np.ndarray, steps: Steps, graph: TaskGraph
                          ) -> tuple[float, float]:
    """Mean log-likelihood per step and accuracy (the most likely action was taken) of a
    (K, K, S, A) policy table on ``steps``; ``(nan, nan)`` for no steps.
    """
    steps = steps.checked(graph)
    if len(steps.state) == 0:
        return float("nan"), float("nan")
    p = policy[steps.start, steps.intention, steps.state]  # (N, A)
    chosen = p[np.arange(len(steps.state)), steps.action]
    log_lik = float(np.mean(np.log(np.maximum(chosen, 1e-300))))
    accuracy = float(np.mean(np.argmax(p, axis=-1) == steps.action))
    return log_lik, accuracy
