"""The human's control-period laws, compiled (numba), over a leading axis of worlds.

Part of :mod:`hri_envs.physics.scene.laws` (which says what the laws are and how they relate to the
numpy classes they mirror): the human's reference along their route
(:func:`intention_advance`, :meth:`~hri_envs.physics.carry.human.intention.IntentionHuman.advance`,
each world's route as arrays; :func:`route_progress`,
:meth:`~hri_envs.physics.carry.human.intention.IntentionHuman.progress`), the hand's reference for
the object's (:func:`hand_reference`) or for the human agent's command
(:func:`commanded_reference`), the torso's servo targets (:func:`torso_target`,
:class:`~hri_envs.physics.carry.human.whole_arm.WholeArm`), the object's weight on the hand of a
human carrying alone (:func:`carried_weight`), the hand impedance (:func:`hand_impedance`,
:class:`~hri_envs.physics.carry.human.arm_control.HandImpedance`) and the torque drive
(:func:`torque_drive`, :class:`~hri_envs.physics.carry.human.arm_control.TorqueDrive`).
"""

from __future__ import annotations

import math

import numpy as np

from hri_envs.physics.carry.human.intention import IntentionHuman
from hri_envs.physics.scene import lawmath as lm
from hri_envs.physics.scene.jit import kernel

__all__ = ["RouteArrays", "carried_weight", "commanded_reference", "hand_impedance",
           "hand_reference", "intention_advance", "route_frame", "route_progress", "torque_drive",
           "torso_target"]


@kernel
def _line_sample(start: np.ndarray, delta: np.ndarray, rotvec: np.ndarray, q0: np.ndarray,
                 q1: np.ndarray, dur: float, t: float, out: np.ndarray) -> None:
    """StraightLine.sample(t) into ``out`` (13,): position, quaternion, velocities."""
    tau = min(max(t / dur, 0.0), 1.0)
    s = lm.min_jerk(tau)
    ds = 30.0 * tau * tau * math.pow(1.0 - tau, 2.0) / dur
    q = lm.slerp(lm.quat4(q0), lm.quat4(q1), s)
    for c in range(3):
        out[c] = start[c] + s * delta[c]
        out[7 + c] = ds * delta[c]
        out[10 + c] = ds * rotvec[c]
    for c in range(4):
        out[3 + c] = q[c]


@kernel
def _line_progress(start: np.ndarray, delta: np.ndarray, rotvec: np.ndarray, q0: np.ndarray,
                   lever: float, pos: np.ndarray, quat: lm.Quat) -> float:
    """IntentionHuman._progress (clamped): how far along a line the object is."""
    dr = lm.rotation_error(quat, lm.quat4(q0))
    d = lm.vec3(delta)
    r = lm.vec3(rotvec)
    dp = (pos[0] - start[0], pos[1] - start[1], pos[2] - start[2])
    num = lm.dot3(dp, d) + lever * lever * lm.dot3(dr, r)
    den = lm.dot3(d, d) + lever * lever * lm.dot3(r, r)
    if den <= 1e-12:
        return 1.0
    return min(max(num / den, 0.0), 1.0)


@kernel
def intention_advance(rows: np.ndarray, dt: float, pos: np.ndarray, quat: np.ndarray,
                      index: np.ndarray, t: np.ndarray, done: np.ndarray, n_lines: np.ndarray,
                      hesitation: np.ndarray, start: np.ndarray, delta: np.ndarray,
                      rotvec: np.ndarray, q0: np.ndarray, q1: np.ndarray, dur: np.ndarray,
                      lever: float, grid: np.ndarray, phase: np.ndarray,
                      out: np.ndarray) -> None:
    """IntentionHuman.advance per world: the object references (R, 13) for the next ``dt``.

    Args:
        rows: (R,) the worlds (indices into the state and route arrays).
        dt: The control period [s].
        pos: (R, 3) the objects' positions now.
        quat: (R, 4) their orientations.
        index: (N,) each world's current line (updated).
        t: (N,) its clock on the line [s] (updated; negative while pausing).
        done: (N,) bool, the reference reached the route's end (updated).
        n_lines: (N,) each route's number of lines.
        hesitation: (N,) the pause [s] before a line after the first.
        start: (N, L, 3) each line's start position.
        delta: (N, L, 3) its translation.
        rotvec: (N, L, 3) its rotation vector.
        q0: (N, L, 4) its start orientation.
        q1: (N, L, 4) its goal orientation.
        dur: (N, L) its duration [s].
        lever: Metres per radian.
        grid: The phase table's times τ (IntentionHuman's 129 points in [0, 1]).
        phase: The minimum-jerk phase s(τ) at them (to invert it when yielding).
        out: (R, 13) position, quaternion, linear and angular velocity.
    """
    for j in range(len(rows)):
        i = rows[j]
        k = index[i]
        if done[i]:
            k = n_lines[i] - 1
            _line_sample(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], q1[i, k],
                         dur[i, k], math.inf, out[j])
            continue
        if t[i] >= dur[i, k]:
            if k + 1 < n_lines[i]:
                k += 1
                index[i] = k
                t[i] = -hesitation[i]
            else:
                done[i] = True
                _line_sample(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], q1[i, k],
                             dur[i, k], math.inf, out[j])
                continue
        if t[i] >= 0.0:
            s_obj = _line_progress(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], lever,
                                   pos[j], lm.quat4(quat[j]))
            if s_obj > lm.min_jerk(t[i] / dur[i, k]):  # the object leads: yield
                t[i] = max(t[i], lm.interp(s_obj, phase, grid) * dur[i, k])
        _line_sample(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], q1[i, k], dur[i, k],
                     max(t[i], 0.0), out[j])
        t[i] += dt


@kernel
def route_progress(rows: np.ndarray, pos: np.ndarray, quat: np.ndarray, n_lines: np.ndarray,
                   start: np.ndarray, delta: np.ndarray, rotvec: np.ndarray, q0: np.ndarray,
                   length: np.ndarray, lever: float, tolerance: float,
                   out: np.ndarray) -> None:
    """IntentionHuman.progress per world into ``out`` (R,): the object's progress along its
    whole route (``length`` (N, L): each line's path length, m + lever x rad).
    """
    for j in range(len(rows)):
        i = rows[j]
        q = lm.quat4(quat[j])
        total = 0.0
        for k in range(n_lines[i]):
            total += length[i, k]
        best, nearest, nearest_d, done = -1.0, 0.0, math.inf, 0.0
        for k in range(n_lines[i]):
            s = _line_progress(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], lever,
                               pos[j], q)
            e = lm.rotation_error(q, lm.quat4(q0[i, k]))
            dx = pos[j, 0] - (start[i, k, 0] + s * delta[i, k, 0])
            dy = pos[j, 1] - (start[i, k, 1] + s * delta[i, k, 1])
            dz = pos[j, 2] - (start[i, k, 2] + s * delta[i, k, 2])
            ex = e[0] - s * rotvec[i, k, 0]
            ey = e[1] - s * rotvec[i, k, 1]
            ez = e[2] - s * rotvec[i, k, 2]
            d = (math.sqrt(dx * dx + dy * dy + dz * dz)
                 + lever * math.sqrt(ex * ex + ey * ey + ez * ez))
            value = (done + s * length[i, k]) / total
            if d < tolerance:
                best = max(best, value)
            if d < nearest_d:
                nearest, nearest_d = value, d
            done += length[i, k]
        out[j] = best if best >= 0.0 else nearest


@kernel
def hand_reference(ref: np.ndarray, handle_pos: np.ndarray, handle_quat: np.ndarray,
                   out: np.ndarray) -> None:
    """CarrySim._hand_reference per world: the hand's grip-frame references (R, 13) for the
    object references ``ref`` (R, 13), the handle at ``handle_pos``, ``handle_quat`` in the
    object's frame.
    """
    h = lm.vec3(handle_pos)
    hq = lm.quat4(handle_quat)
    for j in range(ref.shape[0]):
        q = (ref[j, 3], ref[j, 4], ref[j, 5], ref[j, 6])
        m = lm.quat_to_mat(q)
        r = (m[0] * h[0] + m[1] * h[1] + m[2] * h[2], m[3] * h[0] + m[4] * h[1] + m[5] * h[2],
             m[6] * h[0] + m[7] * h[1] + m[8] * h[2])
        w = (ref[j, 10], ref[j, 11], ref[j, 12])
        wr = lm.cross3(w, r)
        hq_w = lm.quat_mul(q, hq)
        for c in range(3):
            out[j, c] = ref[j, c] + r[c]
            out[j, 7 + c] = ref[j, 7 + c] + wr[c]
            out[j, 10 + c] = w[c]
        for c in range(4):
            out[j, 3 + c] = hq_w[c]


@kernel
def commanded_reference(pos0: np.ndarray, quat0: np.ndarray, delta: np.ndarray,
                        rot: np.ndarray, s: float, dt_step: float, handle_quat: np.ndarray,
                        out: np.ndarray, obj_quat: np.ndarray) -> None:
    """The human agent's hand references (R, 13) a fraction ``s`` of the way from the hand's
    pose at the step's start (``pos0``, ``quat0``) by ``delta``, ``rot`` (R, 3) over
    ``dt_step``; ``obj_quat`` (R, 4): the object's orientation for that hand.
    """
    hc = lm.quat_conj(lm.quat4(handle_quat))
    for j in range(pos0.shape[0]):
        q = lm.rotate_by(lm.quat4(quat0[j]), (s * rot[j, 0], s * rot[j, 1], s * rot[j, 2]))
        o = lm.quat_mul(q, hc)
        for c in range(3):
            out[j, c] = pos0[j, c] + s * delta[j, c]
            out[j, 7 + c] = delta[j, c] / dt_step
            out[j, 10 + c] = rot[j, c] / dt_step
        for c in range(4):
            out[j, 3 + c] = q[c]
            obj_quat[j, c] = o[c]


@kernel
def torso_target(hand_pos: np.ndarray, obj_quat: np.ndarray, rest_quat: np.ndarray,
                 hand_in_torso: np.ndarray, height: np.ndarray, out: np.ndarray) -> None:
    """WholeArm.torso_target(hand_pos, WholeArm.yaw_of(obj_quat, rest_quat)) per world:
    (R, 4) the torso's slide and yaw targets (``hand_in_torso`` (R, 3): each world's
    comfortable hand in the torso's frame, ``height`` (R,): its torso's height [m]).
    """
    rc = lm.quat_conj(lm.quat4(rest_quat))
    for j in range(hand_pos.shape[0]):
        ox, oy, dz = hand_in_torso[j, 0], hand_in_torso[j, 1], hand_in_torso[j, 2]
        b = lm.rotate_vec((0.0, 1.0, 0.0), lm.quat_mul(lm.quat4(obj_quat[j]), rc))
        yaw = 0.0 if b[0] * b[0] + b[1] * b[1] < 0.09 else math.atan2(-b[0], b[1])
        c, s = math.cos(yaw), math.sin(yaw)
        out[j, 0] = hand_pos[j, 0] - -(c * ox - s * oy)
        out[j, 1] = hand_pos[j, 1] - -(s * ox + c * oy)
        out[j, 2] = (hand_pos[j, 2] - dz) - height[j]
        out[j, 3] = yaw


@kernel
def carried_weight(alone: np.ndarray, com: np.ndarray, grip: np.ndarray, weight_n: float,
                   ff: np.ndarray) -> None:
    """The hand's feed-forward wrench per world into ``ff`` (R, 6): where the human carries
    alone (``alone`` (R,)), the object's weight ``weight_n`` [N] held up at its centre of
    mass ``com`` (R, 3) from the grip frame at ``grip`` (R, 3); zero elsewhere.
    """
    for j in range(com.shape[0]):
        for c in range(6):
            ff[j, c] = 0.0
        if alone[j]:
            r = (com[j, 0] - grip[j, 0], com[j, 1] - grip[j, 1], com[j, 2] - grip[j, 2])
            t = lm.cross3(r, (0.0, 0.0, weight_n))
            ff[j, 2], ff[j, 3], ff[j, 4], ff[j, 5] = weight_n, t[0], t[1], t[2]


@kernel
def hand_impedance(jac: np.ndarray, qvel: np.ndarray, cols: np.ndarray, coupling: np.ndarray,
                   site_pos: np.ndarray, site_mat: np.ndarray, ref: np.ndarray,
                   gains: np.ndarray, ff: np.ndarray, q: np.ndarray, qd: np.ndarray,
                   posture: np.ndarray, kn: float, dn: float, reg: float,
                   out: np.ndarray) -> None:
    """HandImpedance.torques per world into ``out`` (R, n).

    Args:
        jac: (R, 6, J) the grip frame's Jacobian (translation, rotation) in J coordinates.
        qvel: (R, J) their velocities (the twist is ``jac @ qvel``).
        cols: (m,) the arm's columns of ``jac``.
        coupling: (R, m, n) ∂q_cols / ∂q_arm (the identity for the torque-driven arm).
        site_pos: (R, 3) the grip frame's position.
        site_mat: (R, 9) its orientation (row-major).
        ref: (R, 13) its reference (position, quaternion, velocities).
        gains: (R, 4) K, D, K_r, D_r.
        ff: (R, 6) a feed-forward wrench.
        q: (R, n) the arm's joint positions.
        qd: (R, n) their velocities.
        posture: (n,) the comfortable posture.
        kn: The posture term's stiffness.
        dn: Its damping.
        reg: The regularisation added to J Jᵀ.
        out: (R, n) the torques.
    """
    n_j, m, n = jac.shape[2], len(cols), out.shape[1]
    jn = np.empty((6, n))
    a = np.empty((6, 6))
    b = np.empty(6)
    x = np.empty(6)
    for r in range(jac.shape[0]):
        tw = np.zeros(6)
        for i in range(6):
            v = 0.0
            for c in range(n_j):
                v += jac[r, i, c] * qvel[r, c]
            tw[i] = v
            for c in range(n):
                v = 0.0
                for p in range(m):
                    v += jac[r, i, cols[p]] * coupling[r, p, c]
                jn[i, c] = v
        k, d, kr, dr = gains[r, 0], gains[r, 1], gains[r, 2], gains[r, 3]
        e = lm.rotation_error(lm.quat4(ref[r, 3:7]), lm.mat_to_quat(site_mat[r]))
        w = np.empty(6)
        for c in range(3):
            w[c] = k * (ref[r, c] - site_pos[r, c]) + d * (ref[r, 7 + c] - tw[c]) + ff[r, c]
            w[3 + c] = kr * e[c] + dr * (ref[r, 10 + c] - tw[3 + c]) + ff[r, 3 + c]
        tau0 = np.empty(n)
        for c in range(n):
            tau0[c] = kn * (posture[c] - q[r, c]) - dn * qd[r, c]
        for i in range(6):
            v = 0.0
            for c in range(n):
                v += jn[i, c] * tau0[c]
            b[i] = v
            for i2 in range(6):
                v = 0.0
                for c in range(n):
                    v += jn[i, c] * jn[i2, c]
                a[i, i2] = v + (reg if i == i2 else 0.0)
        lm.cholesky_solve(a, b, x)
        for c in range(n):
            t_task, t_null = 0.0, 0.0
            for i in range(6):
                t_task += jn[i, c] * w[i]
                t_null += jn[i, c] * x[i]
            out[r, c] = t_task + (tau0[c] - t_null)


@kernel
def torque_drive(tau: np.ndarray, lo: np.ndarray, hi: np.ndarray, out: np.ndarray,
                 sat: np.ndarray) -> None:
    """TorqueDrive.apply per world: ``out`` (R, n) the torques clipped to [lo, hi] (R, n);
    ``sat`` (R, n) counts the joints at a limit.
    """
    for r in range(tau.shape[0]):
        for c in range(tau.shape[1]):
            v = min(max(tau[r, c], lo[r, c]), hi[r, c])
            out[r, c] = v
            if v <= lo[r, c] + 1e-9 or v >= hi[r, c] - 1e-9:
                sat[r, c] += 1.0


@kernel
def route_frame(rows: np.ndarray, index: np.ndarray, t: np.ndarray, done: np.ndarray,
                n_lines: np.ndarray, start: np.ndarray, delta: np.ndarray, rotvec: np.ndarray,
                q0: np.ndarray, q1: np.ndarray, dur: np.ndarray, local_pos: np.ndarray,
                local_quat: np.ndarray, out: np.ndarray) -> None:
    """Where a frame fixed in the object (``local_pos``, ``local_quat``) would be with the
    object at each world's reference now, without advancing it (``carry.grip_reference``):
    its line's sample at max(t, 0), or the route's end once done. ``out`` (R, 7): position,
    quaternion. The route's arrays are :func:`intention_advance`'s.
    """
    ref = np.empty(13)
    lp = lm.vec3(local_pos)
    lq = lm.quat4(local_quat)
    for j in range(len(rows)):
        i = rows[j]
        k, at = index[i], max(t[i], 0.0)
        if done[i]:
            k, at = n_lines[i] - 1, math.inf
        _line_sample(start[i, k], delta[i, k], rotvec[i, k], q0[i, k], q1[i, k], dur[i, k], at,
                     ref)
        q = (ref[3], ref[4], ref[5], ref[6])
        m = lm.quat_to_mat(q)
        r = (m[0] * lp[0] + m[1] * lp[1] + m[2] * lp[2], m[3] * lp[0] + m[4] * lp[1]
             + m[5] * lp[2], m[6] * lp[0] + m[7] * lp[1] + m[8] * lp[2])
        qq = lm.quat_mul(q, lq)
        for c in range(3):
            out[j, c] = ref[c] + r[c]
        for c in range(4):
            out[j, 3 + c] = qq[c]


class RouteArrays:
    """Each world's route (:class:`~hri_envs.physics.carry.human.intention.IntentionHuman`'s
    straight lines) as arrays, for :func:`~hri_envs.physics.carry.human.laws.intention_advance` and
    :func:`~hri_envs.physics.carry.human.laws.route_progress`.

    Args:
        n: The number of worlds.
        lever: Metres per radian.

    Attributes:
        index, t, done: (n,) each world's line, clock [s] and end.
        n_lines, hesitation: (n,) each route's lines and pause before a line [s].
        start, delta, rotvec: (n, L, 3); q0, q1: (n, L, 4); dur, length: (n, L) the lines.
        grid, phase: The minimum-jerk phase s(τ) tabulated as IntentionHuman does.
    """

    start: np.ndarray
    delta: np.ndarray
    rotvec: np.ndarray
    q0: np.ndarray
    q1: np.ndarray
    dur: np.ndarray
    length: np.ndarray

    def __init__(self, n: int, lever: float) -> None:
        self.n, self.lever = n, float(lever)
        self.index = np.zeros(n, dtype=np.int64)
        self.t = np.zeros(n)
        self.done = np.ones(n, dtype=np.bool_)
        self.n_lines = np.ones(n, dtype=np.int64)
        self.hesitation = np.zeros(n)
        self.humans: list[IntentionHuman | None] = [None] * n
        self._alloc(1)
        self.grid = np.linspace(0.0, 1.0, 129)
        self.phase = self.grid**3 * (10.0 - 15.0 * self.grid + 6.0 * self.grid**2)

    def _alloc(self, n_lines: int) -> None:
        """Room for routes of ``n_lines`` lines (the other worlds' lines are kept)."""
        n, old = self.n, getattr(self, "start", None)
        unit = np.zeros((n, n_lines, 4))
        unit[..., 0] = 1.0
        new: dict[str, np.ndarray] = {
            "start": np.zeros((n, n_lines, 3)), "delta": np.zeros((n, n_lines, 3)),
            "rotvec": np.zeros((n, n_lines, 3)), "q0": unit, "q1": unit.copy(),
            "dur": np.ones((n, n_lines)), "length": np.zeros((n, n_lines))}
        for name, value in new.items():
            if old is not None:
                prev = getattr(self, name)
                value[:, :prev.shape[1]] = prev
            setattr(self, name, value)

    def bind(self, i: int, human: IntentionHuman) -> None:
        """World ``i`` follows ``human`` (its route, line, clock and end) unless it does."""
        if self.humans[i] is not human:
            lines = human.lines
            if len(lines) > self.start.shape[1]:
                self._alloc(len(lines))
            for k, ln in enumerate(lines):
                self.start[i, k], self.delta[i, k], self.rotvec[i, k] = (
                    ln.start.pos, ln.delta, ln.rotvec)
                self.q0[i, k], self.q1[i, k] = ln.start.quat, ln.goal.quat
                self.dur[i, k] = ln.duration
                self.length[i, k] = float(np.linalg.norm(ln.delta)
                                          + self.lever * np.linalg.norm(ln.rotvec))
            self.n_lines[i] = max(1, len(lines))
            self.hesitation[i] = human.params.hesitation_s
            self.humans[i] = human
        self.index[i], self.t[i], self.done[i] = human.index, human.t, human.done

    def copy_rows(self, src: int, rows: np.ndarray) -> None:
        """The worlds ``rows`` follow world ``src``'s route from where it is."""
        for name in ("index", "t", "done", "n_lines", "hesitation", "start", "delta", "rotvec",
                     "q0", "q1", "dur", "length"):
            value = getattr(self, name)
            value[rows] = value[src]
        for i in rows:
            self.humans[int(i)] = self.humans[src]

    def store(self, i: int) -> None:
        """World ``i``'s line, clock and end back into its human."""
        human = self.humans[i]
        if human is not None:
            human.index, human.t, human.done = (int(self.index[i]), float(self.t[i]),
                                                bool(self.done[i]))
