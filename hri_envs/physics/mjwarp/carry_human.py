"""The continuous envs' human over a leading axis of worlds: their intention's reference
(:class:`WarpIntention`, :class:`~hri_envs.physics.intention.IntentionHuman` per world) and
their whole arm's control (:class:`WarpArms`: the torso's targets,
:class:`~hri_envs.physics.arm_control.HandImpedance`, the torque drive, the hand's wrench on
the handle, the greatest lift).

The formulas and their order are the C code's (:mod:`hri_envs.physics.intention`,
:mod:`hri_envs.physics.arm_control`, :class:`~hri_envs.physics.whole_arm.WholeArm`), on
``(R, ...)`` arrays of the worlds ``rows``.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

from hri_envs.physics.arm_control import POSTURE_REGULARIZATION
from hri_envs.physics.intention import IntentionHuman
from hri_envs.physics.mjwarp import batchmath as bm
from hri_envs.physics.mjwarp.control import chain_jacobian
from hri_envs.physics.mjwarp.model import WarpModel
from hri_envs.physics.whole_arm import WholeArm

__all__ = ["Samples", "WarpArms", "WarpIntention", "rotate_by"]



class Samples(NamedTuple):
    """Trajectory samples of the worlds ``rows``: (R, 3), (R, 4), (R, 3), (R, 3)."""

    pos: np.ndarray
    quat: np.ndarray
    vel: np.ndarray
    angvel: np.ndarray


def rotate_by(quat: np.ndarray, rotvec: np.ndarray) -> np.ndarray:
    """(R, 4) ``quat`` turned by the world-frame rotation vectors ``rotvec`` (R, 3)
    (``carry._rotate`` per world).
    """
    angle = np.linalg.norm(rotvec, axis=1)
    small = angle < 1e-12
    safe = np.where(small, 1.0, angle)
    dq = np.concatenate([np.cos(angle / 2)[:, None],
                         (np.sin(angle / 2) / safe)[:, None] * rotvec], axis=1)
    return np.where(small[:, None], quat, bm.quat_mul(dq, quat))


class WarpIntention:
    """Every world's :class:`~hri_envs.physics.intention.IntentionHuman`: its route's lines
    as arrays (padded to the longest route), its line, clock and end.

    Args:
        n: The number of worlds.
        lever: Metres per radian.

    Attributes:
        humans: Each world's C human (its route; :meth:`sync` brings its clock up to date).
    """

    def __init__(self, n: int, lever: float) -> None:
        self.n, self.lever = n, lever
        self.humans: list[IntentionHuman | None] = [None] * n
        self.index = np.zeros(n, dtype=np.int64)
        self.t = np.zeros(n)
        self.done = np.ones(n, dtype=bool)
        self.hesitation = np.zeros(n)
        self.n_lines = np.ones(n, dtype=np.int64)
        self._alloc(1)
        # The minimum-jerk phase s(τ) on a grid, to invert it when the human yields.
        self._tau = np.linspace(0.0, 1.0, 129)
        self._phase = self._tau**3 * (10.0 - 15.0 * self._tau + 6.0 * self._tau**2)

    def _alloc(self, n_lines: int) -> None:
        """Room for routes of ``n_lines`` lines (what is there is kept)."""
        n, old = self.n, getattr(self, "start", None)
        unit = np.tile([1.0, 0.0, 0.0, 0.0], (n, n_lines, 1))
        new: dict[str, np.ndarray] = {
            "start": np.zeros((n, n_lines, 3)), "delta": np.zeros((n, n_lines, 3)),
            "rotvec": np.zeros((n, n_lines, 3)), "q0": unit, "q1": unit.copy(),
            "dur": np.ones((n, n_lines)), "length": np.zeros((n, n_lines))}
        if old is not None:
            for name, value in new.items():
                prev = getattr(self, name)
                value[:, :prev.shape[1]] = prev
        self.start, self.delta, self.rotvec = new["start"], new["delta"], new["rotvec"]
        self.q0, self.q1, self.dur, self.length = new["q0"], new["q1"], new["dur"], new["length"]

    def set_world(self, i: int, human: IntentionHuman) -> None:
        """World ``i`` follows ``human``'s route (just planned)."""
        lines = human.lines
        if len(lines) > self.start.shape[1]:
            self._alloc(len(lines))
        self.humans[i] = human
        self.n_lines[i] = max(1, len(lines))
        for k, ln in enumerate(lines):
            self.start[i, k], self.delta[i, k], self.rotvec[i, k] = (ln.start.pos, ln.delta,
                                                                     ln.rotvec)
            self.q0[i, k], self.q1[i, k], self.dur[i, k] = ln.start.quat, ln.goal.quat, \
                ln.duration
            self.length[i, k] = float(np.linalg.norm(ln.delta)
                                      + self.lever * np.linalg.norm(ln.rotvec))
        self.index[i], self.t[i], self.done[i] = human.index, human.t, human.done
        self.hesitation[i] = human.params.hesitation_s

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` follow world ``src``'s route from where it is."""
        for name in ("index", "t", "done", "hesitation", "n_lines", "start", "delta", "rotvec",
                     "q0", "q1", "dur", "length"):
            value = getattr(self, name)
            value[rows] = value[src]
        for i in rows:
            self.humans[int(i)] = self.humans[src]

    def sync(self, i: int) -> IntentionHuman:
        """World ``i``'s C human with its clock, line and end brought up to date."""
        human = self.humans[i]
        if human is None:
            raise RuntimeError(f"world {i} was never reset")
        human.index, human.t, human.done = int(self.index[i]), float(self.t[i]), \
            bool(self.done[i])
        return human

    def _line_progress(self, rows: np.ndarray, k: np.ndarray, pos: np.ndarray,
                       quat: np.ndarray) -> np.ndarray:
        """IntentionHuman._progress (clamped) of line ``k`` (R,) of each world in ``rows``."""
        lv = self.lever
        delta, rotvec = self.delta[rows, k], self.rotvec[rows, k]
        dp = pos - self.start[rows, k]
        dr = bm.rotation_error(quat, self.q0[rows, k])
        num = bm.dot(dp, delta) + lv * lv * bm.dot(dr, rotvec)
        den = bm.dot(delta, delta) + lv * lv * bm.dot(rotvec, rotvec)
        flat = den <= 1e-12
        return np.where(flat, 1.0, np.clip(num / np.where(flat, 1.0, den), 0.0, 1.0))

    def _sample(self, rows: np.ndarray, k: np.ndarray, t: np.ndarray) -> Samples:
        return Samples(*bm.line_sample(t, self.dur[rows, k], self.start[rows, k],
                                       self.delta[rows, k], self.q0[rows, k],
                                       self.q1[rows, k], self.rotvec[rows, k]))

    def advance(self, rows: np.ndarray, dt: float, pos: np.ndarray,
                quat: np.ndarray) -> Samples:
        """IntentionHuman.advance per world: the object references for the next ``dt``."""
        idx, t, done = self.index[rows], self.t[rows], self.done[rows]
        over = ~done & (t >= self.dur[rows, idx])
        has_next = over & (idx + 1 < self.n_lines[rows])
        idx = np.where(has_next, idx + 1, idx)
        t = np.where(has_next, -self.hesitation[rows], t)
        done = done | (over & ~has_next)
        going = ~done
        dur = self.dur[rows, idx]
        yielding = going & (t >= 0.0)
        if yielding.any():
            y = np.flatnonzero(yielding)
            s_obj = self._line_progress(rows[y], idx[y], pos[y], quat[y])
            tau = t[y] / dur[y]
            s_ref = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)
            ahead = s_obj > s_ref
            jump = np.maximum(t[y], np.interp(s_obj, self._phase, self._tau) * dur[y])
            t[y] = np.where(ahead, jump, t[y])
        last = self.n_lines[rows] - 1
        k = np.where(done, last, idx)
        out = self._sample(rows, k, np.where(done, np.inf, np.maximum(t, 0.0)))
        t = np.where(going, t + dt, t)
        self.index[rows], self.t[rows], self.done[rows] = idx, t, done
        return out

    def progress(self, rows: np.ndarray, pos: np.ndarray, quat: np.ndarray,
                 tolerance_m: float = 0.05) -> np.ndarray:
        """IntentionHuman.progress per world: (R,) progress along the whole route."""
        r = len(rows)
        total = self.length[rows].sum(axis=1)
        best, nearest, nearest_d = np.full(r, -1.0), np.zeros(r), np.full(r, np.inf)
        done = np.zeros(r)
        for k in range(int(self.n_lines[rows].max(initial=1))):
            ks = np.full(r, k)
            real = k < self.n_lines[rows]
            s = self._line_progress(rows, ks, pos, quat)
            p = self.start[rows, k] + s[:, None] * self.delta[rows, k]
            e = bm.rotation_error(quat, self.q0[rows, k]) - s[:, None] * self.rotvec[rows, k]
            d = np.linalg.norm(pos - p, axis=1) + self.lever * np.linalg.norm(e, axis=1)
            value = (done + s * self.length[rows, k]) / total
            best = np.where(real & (d < tolerance_m), np.maximum(best, value), best)
            closer = real & (d < nearest_d)
            nearest = np.where(closer, value, nearest)
            nearest_d = np.where(closer, d, nearest_d)
            done = done + np.where(real, self.length[rows, k], 0.0)
        return np.where(best >= 0.0, best, nearest)


class WarpArms:
    """The whole arm's indices and the human's controller, per world.

    Args:
        n: The number of worlds.
        model: The C scene.
        arm: The C sim's :class:`~hri_envs.physics.whole_arm.WholeArm`.
        posture: (7,) the comfortable posture; posture_gains: (K_n, D_n).
        actuators: (7,) the arm's torque motors.
        rest_quat: The object's rest orientation; handle_pos, handle_quat: the handle in
            the object's frame.

    Attributes:
        gains: (n, 4) each world's hand impedance (K, D, K_r, D_r).
        lo, hi: (n, 7) each world's strength limits [N m].
    """

    def __init__(self, n: int, model: mujoco.MjModel, arm: WholeArm, posture: np.ndarray,
                 posture_gains: tuple[float, float], actuators: np.ndarray,
                 rest_quat: np.ndarray, handle_pos: np.ndarray, handle_quat: np.ndarray) -> None:
        a = arm
        self.grip_site, self.handle_site = a.grip_site, a.handle_site
        self.arm_qpos, self.arm_dofs = a.arm_qpos, a.arm_dofs
        self.torso_actuators = a.torso_actuators
        #: (n, 3) each world's comfortable hand in the torso frame, (n,) its torso height
        #: [m] (the human's body size, :class:`~hri_envs.physics.body.ArmBody`).
        self.hand_in_torso = np.tile(a.hand_in_torso, (n, 1))
        self.torso_height = np.full(n, a.torso_height_m)
        torso_joints = [int(np.flatnonzero(model.jnt_dofadr == d)[0]) for d in a.torso_dofs]
        self.joints = np.array([*torso_joints, *a.arm_joints])
        self.dofs = model.jnt_dofadr[self.joints]
        self.hinge = model.jnt_type[self.joints] == mujoco.mjtJoint.mjJNT_HINGE
        self.n_torso = len(torso_joints)
        self.posture = np.asarray(posture, float)
        self.kn, self.dn = posture_gains
        self.actuators = np.asarray(actuators)
        self.rest_quat = np.asarray(rest_quat, float)
        self.handle_pos = np.asarray(handle_pos, float)
        self.handle_quat = np.asarray(handle_quat, float)
        n_j = len(self.posture)
        self.gains = np.ones((n, 4))
        self.lo, self.hi = -np.ones((n, n_j)), np.ones((n, n_j))

    def hand_reference(self, ref: Samples) -> Samples:
        """CarrySim._hand_reference per world: the hand's grip frame for object references."""
        rot = bm.quat_to_mat(ref.quat)
        r = np.einsum("nij,j->ni", rot, self.handle_pos)
        return Samples(ref.pos + r, bm.quat_mul(ref.quat, np.broadcast_to(
            self.handle_quat, ref.quat.shape)), ref.vel + np.cross(ref.angvel, r), ref.angvel)

    def object_quat(self, hand_quat: np.ndarray) -> np.ndarray:
        """The object's orientation for the hand's grip frame ``hand_quat`` (R, 4)."""
        conj = self.handle_quat * np.array([1.0, -1.0, -1.0, -1.0])
        return bm.quat_mul(hand_quat, np.broadcast_to(conj, hand_quat.shape))

    def torso_targets(self, hand_pos: np.ndarray, quat: np.ndarray,
                      rows: np.ndarray) -> np.ndarray:
        """WholeArm.torso_target(hand_pos, yaw_of(quat)) per world of ``rows``: (R, 4)."""
        rest = np.broadcast_to(self.rest_quat * np.array([1.0, -1.0, -1.0, -1.0]), quat.shape)
        b = bm.rotate(bm.quat_mul(quat, rest), np.broadcast_to([0.0, 1.0, 0.0], hand_pos.shape))
        yaw = np.where(b[:, 0] * b[:, 0] + b[:, 1] * b[:, 1] < 0.09, 0.0,
                       np.arctan2(-b[:, 0], b[:, 1]))
        c, s = np.cos(yaw), np.sin(yaw)
        ox, oy, dz = self.hand_in_torso[rows].T
        torso = hand_pos - np.stack([-(c * ox - s * oy), -(s * ox + c * oy), dz], axis=1)
        return np.stack([torso[:, 0], torso[:, 1], torso[:, 2] - self.torso_height[rows], yaw],
                        axis=1)

    def _jacobian(self, wm: WarpModel, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        site = wm._get("site_xpos")[rows, self.grip_site].astype(float)
        jac, _, _ = chain_jacobian(wm, rows, self.joints, self.hinge, site)
        return jac, site

    def torques(self, wm: WarpModel, rows: np.ndarray, ref: Samples,
                feedforward: np.ndarray, gains: np.ndarray) -> np.ndarray:
        """HandImpedance.torques per world: (R, 7) joint torques for the hand's references,
        plus the (R, 6) feed-forward wrenches, with the (R, 4) gains.
        """
        jac_all, site = self._jacobian(wm, rows)
        qvel = wm._get("qvel")[rows].astype(float)
        twist = np.einsum("rij,rj->ri", jac_all, qvel[:, self.dofs])
        jac = jac_all[:, :, self.n_torso:]  # (R, 6, 7): the arm's own coordinates
        k, d, kr, dr = (gains[:, c:c + 1] for c in range(4))
        quat = bm.mat_to_quat(wm._get("site_xmat")[rows, self.grip_site].astype(float))
        w = np.concatenate([k * (ref.pos - site) + d * (ref.vel - twist[:, :3]),
                            kr * bm.rotation_error(ref.quat, quat)
                            + dr * (ref.angvel - twist[:, 3:])], axis=1) + feedforward
        tau = np.einsum("rij,ri->rj", jac, w)
        q = wm._get("qpos")[rows][:, self.arm_qpos].astype(float)
        tau0 = self.kn * (self.posture - q) - self.dn * qvel[:, self.arm_dofs]
        jjt = np.einsum("rin,rjn->rij", jac, jac) + POSTURE_REGULARIZATION * np.eye(6)
        x = np.linalg.solve(jjt, np.einsum("rin,rn->ri", jac, tau0)[..., None])[..., 0]
        return tau + (tau0 - np.einsum("rin,ri->rn", jac, x))

    def max_lift(self, wm: WarpModel, rows: np.ndarray) -> np.ndarray:
        """CarrySim.max_lift_n per world: (R,) the greatest upward force [N] at the hand."""
        jac, _ = self._jacobian(wm, rows)
        moment = np.abs(jac[:, 2, self.n_torso:])
        lim = np.minimum(-self.lo[rows], self.hi[rows])
        with np.errstate(divide="ignore"):
            ratio = np.where(moment > 1e-9, lim / np.where(moment > 1e-9, moment, 1.0), np.inf)
        return ratio.min(axis=1)

    def handle_wrench(self, wm: WarpModel, rows: np.ndarray, sensordata: np.ndarray,
                      adr: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """CarrySim._handle_wrench per world: the hand's force and torque on the handle."""
        rot = wm._get("site_xmat")[rows, self.handle_site].astype(float).reshape(-1, 3, 3)
        f_adr, t_adr = adr
        return (-np.einsum("rij,rj->ri", rot, sensordata[:, f_adr:f_adr + 3]),
                -np.einsum("rij,rj->ri", rot, sensordata[:, t_adr:t_adr + 3]))

    def slip(self, wm: WarpModel, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """How far [m] and by what angle [rad] the handle is off the hand's grip, per world."""
        xpos, xmat = wm._get("site_xpos"), wm._get("site_xmat")
        off = np.linalg.norm(xpos[rows, self.grip_site].astype(float)
                             - xpos[rows, self.handle_site].astype(float), axis=1)
        q1 = bm.mat_to_quat(xmat[rows, self.grip_site].astype(float))
        q2 = bm.mat_to_quat(xmat[rows, self.handle_site].astype(float))
        return off, np.linalg.norm(bm.rotation_error(q1, q2), axis=1)
