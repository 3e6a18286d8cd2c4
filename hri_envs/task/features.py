"""Human preference features φ(s, ι) (paper Sect. 4.5).

The contract is in docs/task-model.md, 'Preference features'.

Each feature is a product of Gaussian RBFs of distance (σ = 2 cm) and of angle (σ = 10°),
sometimes with a grasp indicator, measured relative to the intended goal ι, to the nearest
non-goal support, and to the comfortable carrying height. With O orientations there are
``8 + 6 (O + 1)`` features (26 for two orientations), in this order:

=====  =========================================================  ========
group  centred at                                                 count
=====  =========================================================  ========
0      resting on the goal support, one per μ                     4
1      the goal's mounting point, per orientation φ               O + 1
2      the goal column at carrying height, per φ                  O + 1
3      resting on the nearest non-goal support, one per μ         4
4      a non-goal mounting point, per φ                           O + 1
5      a non-goal column at carrying height, per φ                O + 1
6      the goal column at a non-goal (mounting) height, per φ     O + 1
7      a non-goal column at the goal's (mounting) height, per φ   O + 1
=====  =========================================================  ========

where φ runs over the scenario's orientations followed by the goal's own orientation.
A state's feature vector is divided by its sum when the sum exceeds 1.

"Non-goal" distances are taken as in the paper's published code: the horizontal distance to
the nearest non-goal column and the vertical distance to the nearest non-goal mounting
height, separately. So group 4 also fires where one non-goal support's column meets
another's height (for goal B on the hanger: "A column, 0.87 m" as well as C′); this is the
feature set the paper's results were obtained with, so we keep it.
"""

from __future__ import annotations

import numpy as np

from hri_envs.task.geometry import Scenario, quat_angle

__all__ = ["SIGMA_ANGLE", "SIGMA_DISTANCE", "feature_groups", "initial_theta", "state_features"]

SIGMA_DISTANCE = 0.02  # [m]
SIGMA_ANGLE = np.deg2rad(10.0)  # [rad]


def _rbf(d: np.ndarray, sigma: float) -> np.ndarray:
    return np.exp(-0.5 * (np.asarray(d) / sigma) ** 2)


def feature_groups(n_orientations: int) -> list[tuple[str, slice]]:
    """Names and index ranges of the feature groups, in order."""
    per_phi = n_orientations + 1
    sizes = [("goal support", 4), ("goal mounting point", per_phi),
             ("goal column, carrying height", per_phi), ("non-goal support", 4),
             ("non-goal mounting point", per_phi), ("non-goal column, carrying height", per_phi),
             ("goal column, non-goal height", per_phi), ("non-goal column, goal height", per_phi)]
    out, start = [], 0
    for name, n in sizes:
        out.append((name, slice(start, start + n)))
        start += n
    return out


def state_features(
    scenario: Scenario, position: np.ndarray, quaternion: np.ndarray, grasp: np.ndarray
) -> np.ndarray:
    """φ(s, ι) for every state and intention.

    Args:
        scenario: Supplies supports, mounting points, orientations and carrying height.
        position: (S, 3) nominal object positions [m].
        quaternion: (S, 4) object orientations.
        grasp: (S,) grasp codes μ.

    Returns:
        (K, S, F) features, F = 26 for two orientations.
    """
    sup_pos = np.stack([s.position for s in scenario.supports])  # (K, 3)
    sup_q = scenario.orientations[[s.orientation for s in scenario.supports]]  # (K, 4)
    mount = np.stack([s.mounting for s in scenario.supports])  # (K, 3)
    n_k = len(sup_pos)
    onehot_mu = (grasp[:, None] == np.arange(4)[None, :]).astype(float)  # (S, 4)

    out = []
    for goal in range(n_k):
        others = [k for k in range(n_k) if k != goal]
        phis = np.concatenate([scenario.orientations, sup_q[goal][None]])  # (O+1, 4)
        ang = _rbf(quat_angle(quaternion[:, None, :], phis[None, :, :]), SIGMA_ANGLE)  # (S, O+1)

        xy_goal = np.linalg.norm(position[:, :2] - mount[goal, :2], axis=1)  # (S,)
        z_goal = np.abs(position[:, 2] - mount[goal, 2])
        xy_other = np.min(np.linalg.norm(position[:, None, :2] - mount[None, others, :2], axis=2),
                          axis=1)
        z_other = np.min(np.abs(position[:, None, 2] - mount[None, others, 2]), axis=1)
        z_comfort = np.abs(position[:, 2] - scenario.comfort_height)

        d_goal_sup = np.linalg.norm(position - sup_pos[goal], axis=1)
        a_goal_sup = quat_angle(quaternion, sup_q[goal])
        d_others = np.linalg.norm(position[:, None, :] - sup_pos[None, others, :], axis=2)
        nearest = np.asarray(others)[np.argmin(d_others, axis=1)]  # (S,)
        d_near = np.linalg.norm(position - sup_pos[nearest], axis=1)
        a_near = quat_angle(quaternion, sup_q[nearest])

        def at(d_xy: np.ndarray, d_z: np.ndarray, ang: np.ndarray = ang) -> np.ndarray:
            return (_rbf(d_xy, SIGMA_DISTANCE) * _rbf(d_z, SIGMA_DISTANCE))[:, None] * ang

        phi = np.concatenate([
            (_rbf(d_goal_sup, SIGMA_DISTANCE) * _rbf(a_goal_sup, SIGMA_ANGLE))[:, None] * onehot_mu,
            at(xy_goal, z_goal),
            at(xy_goal, z_comfort),
            (_rbf(d_near, SIGMA_DISTANCE) * _rbf(a_near, SIGMA_ANGLE))[:, None] * onehot_mu,
            at(xy_other, z_other),
            at(xy_other, z_comfort),
            at(xy_goal, z_other),
            at(xy_other, z_goal),
        ], axis=1)
        total = phi.sum(axis=1, keepdims=True)
        phi = np.where(total > 1.0, phi / np.maximum(total, 1e-300), phi)
        out.append(phi)
    return np.stack(out)


def initial_theta(n_features: int) -> np.ndarray:
    """θ⁰: +0.1 on "resting on the goal support, μ = 0", -1 on "resting on a non-goal support,
    μ = 0", 0 elsewhere (paper Sect. 4.5).
    """
    theta = np.zeros(n_features)
    theta[0] = 0.1
    theta[4 + 2 * ((n_features - 8) // 6)] = -1.0  # F = 8 + 6 (O + 1)
    return theta
