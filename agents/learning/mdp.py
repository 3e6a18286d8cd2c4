"""The learners' math as pure, vectorised functions over numpy arrays (the dense reference).

Shapes: ``B`` independent learners (a leading batch axis), ``I`` intentions, ``S`` states,
``A`` actions, ``F`` features. Actions that are not valid in a state take no part in any
soft-max or expectation. The planning these build on (soft-max, Q-iteration, partner
transitions) is the task model's, :mod:`hri_envs.task.mdp`; the sparse, compiled forms of
the same numbers are :mod:`agents.learning.partner_mdp`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from hri_envs.task.mdp import softmax

__all__ = [
    "Demonstrations",
    "bayes_update",
    "bounded_softmax",
    "demonstrations",
    "expected_feature_counts",
    "irl_step",
    "remove_loops",
    "robot_reward",
]


def bounded_softmax(
    q: np.ndarray, valid: np.ndarray, temperature: float, eta: float,
    baseline: np.ndarray | None,
) -> np.ndarray:
    """The robot's bounded soft-max (paper Sect. 3.1, Alg. 1 l. 9).

    Only actions whose soft-max probability is at least
    ``max(p(baseline action), η · max_a p(a))`` keep their probability; the rest is renormalised.

    Args:
        q: (..., A) action values in one state per batch entry.
        valid: (..., A) bool.
        temperature: τ_R.
        eta: η in [0, 1].
        baseline: (...,) int, the passive baseline action; None: no baseline, the bound is
            ``η · max_a p(a)`` alone.

    Returns:
        (..., A) probabilities.
    """
    p = softmax(q, valid, temperature)
    bound = eta * p.max(axis=-1, keepdims=True)
    if baseline is not None:
        bound = np.maximum(np.take_along_axis(p, baseline[..., None], axis=-1), bound)
    kept = np.where(p >= bound * (1 - 1e-12), p, 0.0)
    return kept / kept.sum(axis=-1, keepdims=True)


def robot_reward(reward: np.ndarray, pi_h: np.ndarray) -> np.ndarray:
    """Expected robot reward R_R(s, ι, a_R) = Σ_{a_H} π̂_H(a_H|s, ι) R_R(s, a_R, a_H).

    Args:
        reward: (S, A, A) from :meth:`TaskGraph.reward`.
        pi_h: (..., S, A).

    Returns:
        (..., S, A).
    """
    return np.einsum("sra,...sa->...sr", reward, pi_h)


def bayes_update(
    belief: np.ndarray, likelihood: np.ndarray, beta: float
) -> np.ndarray:
    """Bayes filter over intentions (Eqs. 3-4), robust to zero likelihoods.

    ``b'(ι') ∝ π̂_H(a_H|s, ι') Σ_ι P(ι'|ι) b(ι)`` with ``P(ι'|ι) = β`` if equal, else
    ``(1-β)/(n-1)``. If every intention gave the observed action zero probability, the
    observation carries no information and the prediction step alone is returned, so the
    belief is never NaN, empty or all-zero.

    Args:
        belief: (..., I) current belief.
        likelihood: (..., I) π̂_H(a_H | s, ι) of the observed human action.
        beta: Intention bias in [1/n, 1].

    Returns:
        (..., I) new belief.
    """
    n = belief.shape[-1]
    if n == 1:
        return np.ones_like(belief)
    stay = beta * belief
    switch = (1.0 - beta) / (n - 1) * (belief.sum(axis=-1, keepdims=True) - belief)
    prior = stay + switch
    post = prior * likelihood
    total = post.sum(axis=-1, keepdims=True)
    ok = total > 1e-300
    post = np.where(ok, post / np.where(ok, total, 1.0), prior / prior.sum(-1, keepdims=True))
    return post


def remove_loops(states: np.ndarray) -> np.ndarray:
    """Indices of the states kept after removing loops (paper Sect. 3.3).

    Whenever a state is visited again, everything since its earlier visit is dropped, so the
    result is a path without repeated states from the first to the last state.

    Args:
        states: (T+1,) visited states s_0 .. s_T.

    Returns:
        Increasing indices into ``states``; the last index is always ``T``.
    """
    kept: list[int] = []  # indices into states, a loop-free path so far
    where: dict[int, int] = {}  # state -> its position in kept
    seq = np.asarray(states).tolist()
    for t, s in enumerate(seq):
        i = where.get(s)
        if i is not None:  # back at an earlier state: drop the loop
            for k in kept[i:]:
                del where[seq[k]]
            del kept[i:]
        where[s] = len(kept)
        kept.append(t)
    return np.asarray(kept, dtype=np.int64)


class Demonstrations(NamedTuple):
    """Loop-free demonstrations for one ME-IRL step.

    Attributes:
        counts: (B, F) Σ φ(s, ι) along each loop-free path.
        start: (B,) first state of each path.
        horizon: (B,) number of states of each path.
        paths: The loop-free state paths.
    """

    counts: np.ndarray
    start: np.ndarray
    horizon: np.ndarray
    paths: list[np.ndarray]


def demonstrations(
    features: np.ndarray, state_traces: Sequence[np.ndarray], intentions: np.ndarray
) -> Demonstrations:
    """Remove loops from each state trace and count its features (Alg. 1 l. 17).

    Args:
        features: (I, S, F) φ(s, ι).
        state_traces: One (T+1,) state sequence per run.
        intentions: (B,) the intention revealed by each episode.
    """
    paths = [np.asarray(s)[remove_loops(s)] for s in state_traces]
    counts = np.stack([features[i, p].sum(axis=0) for i, p in zip(intentions, paths, strict=True)])
    start = np.array([p[0] for p in paths], dtype=np.int64)
    horizon = np.array([len(p) for p in paths], dtype=np.int64)
    return Demonstrations(counts, start, horizon, paths)


def expected_feature_counts(
    transition: np.ndarray,
    policy: np.ndarray,
    features: np.ndarray,
    start: np.ndarray,
    terminal: np.ndarray,
    horizon: np.ndarray,
) -> np.ndarray:
    """Expected feature counts of a soft policy over a finite horizon (ME-IRL's E[φ]).

    The state distribution starts at ``start`` and is propagated ``horizon - 1`` times; no
    mass leaves the terminal state. Feature counts sum ``φ`` over the ``horizon`` steps.

    Args:
        transition: (B, S, A, S).
        policy: (B, S, A).
        features: (B, S, F).
        start: (B,) start states.
        terminal: (B,) terminal states (absorbing, not propagated).
        horizon: (B,) number of states of the demonstration.

    Returns:
        (B, F).
    """
    n_b, n_s = policy.shape[:2]
    p = np.einsum("bsa,bsaz->bsz", policy, transition)
    p[np.arange(n_b), terminal, :] = 0.0
    d = np.zeros((n_b, n_s))
    d[np.arange(n_b), start] = 1.0
    svf = d.copy()
    for t in range(1, int(horizon.max())):
        d = np.einsum("bs,bsz->bz", d, p)
        svf += d * (t < horizon)[:, None]
    return np.einsum("bs,bsf->bf", svf, features)


def irl_step(
    theta: np.ndarray,
    demo_counts: np.ndarray,
    expected_counts: np.ndarray,
    learning_rate: float,
) -> np.ndarray:
    """One ME-IRL gradient step, θ rescaled to max |θ| = 1 (paper Sect. 4.5).

    Args:
        theta: (B, F).
        demo_counts: (B, F) Σ φ along the (loop-free) demonstration.
        expected_counts: (B, F) E[Σ φ] under the model.
        learning_rate: λ.

    Returns:
        (B, F) new θ.
    """
    new = theta + learning_rate * (demo_counts - expected_counts)
    scale = np.abs(new).max(axis=-1, keepdims=True)
    return np.where(scale > 0, new / np.where(scale > 0, scale, 1.0), new)
