"""A physical human's behavioural signature: what they do in a few short, fixed interactions.

Two humans are the same when they behave the same. :func:`signature` puts a human
(:class:`~hri_envs.physics.carry.human.intention.HumanParams`) into :data:`PROBES`: fixed start /
goal
pairs of the scenario's default layout, each with a *passive* robot (stiffness 0: the
human leads and the robot follows) and a *stiff* robot that holds its grip still (the human
pushes against it towards their goal, up to their strength and grip), for
:data:`PROBE_S` seconds each. It records, per 40 ms step, the wrench the human's hand puts
on the handle (force [N]; torque [N m] / the scenario's lever [m], in N) and the object's
position [m], and keeps their means over windows of :data:`WINDOW_STEPS` steps (0.4 s):
an array (probes, windows, 9).

:func:`distance` compares two signatures channel by channel: the root mean square over the
probes and windows of the wrench's difference in units of :data:`FORCE_TOLERANCE_N` and of
the path's difference in units of :data:`PATH_TOLERANCE_M`, the larger of the two. Two
humans closer than 1 are the *same by behaviour*: within the tolerances, a robot that feels
the wrist wrench and sees the object could not tell them apart in these interactions.
0.5 N is ten times the wrist sensor's noise (0.05 N standard deviation per reading); 5 mm
is a sixth of the seats' 3 cm capture radius. The probes last 4 s because slow humans
(the weak and hesitant families) barely start in less: with 2.4 s probes, weak humans drawn
at random were within 1.2 of each other (median nearest distance), with 4 s 4.1.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hri_envs.physics.carry.human.intention import HumanParams
from hri_envs.physics.carry.sim import CarrySim

__all__ = ["FORCE_TOLERANCE_N", "PATH_TOLERANCE_M", "PROBES", "PROBE_S", "WINDOW_STEPS",
           "distance", "distances", "signature", "signatures"]

#: (start support, goal support, robot stiffness scale) of each probe interaction.
PROBES: tuple[tuple[int, int, float], ...] = ((1, 0, 0.0), (1, 0, 1.0), (0, 2, 0.0),
                                              (0, 2, 1.0))
#: [s] each probe's length.
PROBE_S = 4.0
#: Steps (40 ms) per window of the signature (0.4 s).
WINDOW_STEPS = 10
#: [N] the wrench's tolerance (RMS over the probes' windows).
FORCE_TOLERANCE_N = 0.5
#: [m] the object path's tolerance (RMS over the probes' windows).
PATH_TOLERANCE_M = 0.005
_SEED = 0  # the wrist sensor's noise does not enter the signature; its stream is fixed


def signature(sim: CarrySim, human: HumanParams) -> np.ndarray:
    """(P, W, 9) ``human``'s signature in ``sim`` (its scenario's default layout): per probe
    of :data:`PROBES` and window, the mean hand force [N] (3), torque / lever [N] (3) and
    object position [m] (3). A probe that ends early (a slip, a drop) repeats its last
    window's values.
    """
    steps = int(round(PROBE_S / sim.dt_step))
    windows = steps // WINDOW_STEPS
    out = np.zeros((len(PROBES), windows, 9))
    lever = sim.design.lever
    for p, (start, goal, stiffness) in enumerate(PROBES):
        sim.reset(start, goal, np.random.default_rng(_SEED), human=human)
        action = np.zeros(7)
        action[6] = 2.0 * stiffness - 1.0
        rows = np.zeros((steps, 9))
        n = 0
        for n in range(steps):
            res = sim.step(sim.command(action))
            f, t = sim.handle_wrench()
            rows[n, :3], rows[n, 3:6] = f, t / lever
            rows[n, 6:] = sim.object_pose().pos
            if res.fault is not None:
                rows[n + 1:] = rows[n]
                break
        out[p] = rows[:windows * WINDOW_STEPS].reshape(windows, WINDOW_STEPS, 9).mean(axis=1)
    return out


def _scaled(sig: np.ndarray) -> np.ndarray:
    """(..., P, W, 9) the signature in units of the tolerances."""
    s = np.asarray(sig, dtype=float)
    scale = np.array([FORCE_TOLERANCE_N] * 6 + [PATH_TOLERANCE_M] * 3)
    return s / scale


def distance(a: np.ndarray, b: np.ndarray) -> float:
    """The behavioural distance of two signatures (< 1: the same by behaviour)."""
    return float(distances(np.asarray(a)[None], np.asarray(b)[None])[0, 0])


def distances(a: np.ndarray, b: np.ndarray | None = None) -> np.ndarray:
    """(N, M) behavioural distances between the signatures ``a`` (N, P, W, 9) and ``b``
    (M, P, W, 9) (``b`` None: ``a`` with itself): max over the two channels of the RMS
    difference in tolerances.
    """
    a = _scaled(a)
    b = a if b is None else _scaled(b)
    n_win = a.shape[1] * a.shape[2]
    out = np.zeros((len(a), len(b)))
    for channel in (slice(0, 6), slice(6, 9)):
        x = a[..., channel].reshape(len(a), -1)
        y = b[..., channel].reshape(len(b), -1)
        sq = (x * x).sum(1)[:, None] + (y * y).sum(1)[None, :] - 2.0 * x.dot(y.T)
        out = np.maximum(out, np.sqrt(np.maximum(sq, 0.0) / n_win))
    return out


def signatures(sim: CarrySim, humans: Sequence[HumanParams]) -> np.ndarray:
    """(N, P, W, 9) the signatures of ``humans``, in order."""
    return np.stack([signature(sim, h) for h in humans])
