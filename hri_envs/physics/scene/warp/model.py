"""A MuJoCo scene on MuJoCo Warp, N worlds of it, and its arrays on the host: :class:`WarpModel`.

What every backend on MuJoCo Warp needs from a compiled C model, whatever it simulates (the
v0 Panda scene, :mod:`~hri_envs.physics.panda.warp.worlds`; the continuous envs' scene with the
whole arm, :mod:`~hri_envs.physics.carry.warp.worlds`):

* the Warp model and the data of ``n`` worlds (``put_model``, ``make_data``), with the
  model values that differ per world (gains, force ranges, masses, margins) tiled along a
  leading axis of worlds;
* host access to any array of ``Data`` or ``Model`` (on Warp's CPU device a view, written
  back only when it is a copy, i.e. on a GPU);
* a world's state copied from, or into, a C ``MjData`` (resets are simulated by a C
  template; pictures are drawn from one);
* the worlds that do not step in a control period kept frozen (:meth:`WarpModel.freeze`).
"""

from __future__ import annotations

import copy
from collections.abc import Iterable, Sequence
from typing import Any

import mujoco
import numpy as np

from hri_envs.physics.scene.warp.device import require_warp

__all__ = ["NCONMAX", "NJMAX", "STATE_FIELDS", "WORLD_DATA", "WarpModel"]

#: Contacts allocated per world, and constraint rows (both far above what the scenes use).
NCONMAX, NJMAX = 48, 300
#: The integration state of a world: what a frozen world keeps.
STATE_FIELDS: tuple[str, ...] = ("qpos", "qvel", "act", "qacc_warmstart", "time")
#: What a reset copies from a C ``MjData`` (the rest of the state is zeroed).
_COPIED = ("qpos", "qvel", "ctrl", "act", "mocap_pos", "mocap_quat")
_ZEROED = ("qacc_warmstart", "xfrc_applied", "qacc")


#: The Data arrays that make a world's state (what :meth:`WarpModel.copy_rows` copies).
WORLD_DATA = ("qpos", "qvel", "ctrl", "act", "mocap_pos", "mocap_quat", "eq_active",
              "qacc_warmstart", "xfrc_applied", "time")


class WarpModel:
    """``n_worlds`` worlds of a compiled MuJoCo model on MuJoCo Warp.

    Args:
        model: The C model (copied; mid-phase culling, which MuJoCo Warp cannot switch off,
            is switched back on in the copy).
        n_worlds: How many worlds.
        per_world: Model fields whose values may differ per world.
        device: Warp device (default: Warp's default device, a GPU where there is one).

    Attributes:
        m, d: MuJoCo Warp's model and data.
        n: The number of worlds; nv: degrees of freedom per world.
        device: The Warp device the worlds run on ("cpu", "cuda:0", ...).
    """

    def __init__(self, model: mujoco.MjModel, n_worlds: int, per_world: Sequence[str],
                 device: str | None = None) -> None:
        wp, mjw, _ = require_warp()
        self._wp, self._mjw = wp, mjw
        self.n = n = int(n_worlds)
        self.device = str(wp.get_device(device))
        mjm = copy.copy(model)
        mjm.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_MIDPHASE)
        self._mjm = mjm
        self.per_world = tuple(per_world)
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(mjm)
            self.d = mjw.make_data(mjm, nworld=n, nconmax=NCONMAX, njmax=NJMAX)
            for name in self.per_world:
                arr = getattr(self.m, name)
                tiled = np.repeat(arr.numpy()[:1], n, axis=0)
                setattr(self.m, name, wp.array(tiled, dtype=arr.dtype))
            self._rhs = wp.zeros((n, mjm.nv), dtype=float)
            self._sol = wp.zeros((n, mjm.nv), dtype=float)
        self.nv = mjm.nv
        #: Each world's sensor readings as of its last forward pass or step.
        self.sensordata = np.zeros((n, mjm.nsensordata))
        self._placed: set[int] = set()  # worlds placed since the last forward pass

    # ------------------------------------------------------------------ host access
    def _get(self, name: str) -> np.ndarray:
        """A Data array on the host (a view on the CPU device; write back with _put)."""
        return getattr(self.d, name).numpy()

    def _assign(self, arr: Any, value: np.ndarray) -> None:
        """Write ``value`` into the Warp array ``arr`` (nothing to do for its own view on
        the CPU device).
        """
        if self.device != "cpu" or value.ctypes.data != arr.ptr:
            arr.assign(value.astype(arr.numpy().dtype, copy=False))

    def _put(self, name: str, value: np.ndarray) -> None:
        self._assign(getattr(self.d, name), value)

    def _model_put(self, name: str, value: np.ndarray) -> None:
        self._assign(getattr(self.m, name), value)

    def _refresh(self) -> None:
        """Kinematics and sensors of the worlds placed since the last call (one forward
        pass of all the worlds; the others' are recomputed from their unchanged state).
        """
        if self._placed:
            self._mjw.forward(self.m, self.d)
            rows = np.fromiter(self._placed, dtype=np.int64)
            self.sensordata[rows] = self._get("sensordata")[rows]
            self._placed.clear()

    def set_rows(self, name: str, rows: np.ndarray | int, value: np.ndarray | float) -> None:
        """Data array ``name`` of the worlds ``rows`` set to ``value``."""
        arr = self._get(name)
        arr[rows] = value
        self._put(name, arr)

    def set_model_rows(self, name: str, rows: np.ndarray | int,
                       value: np.ndarray | float) -> None:
        """Per-world model array ``name`` of the worlds ``rows`` set to ``value``."""
        arr = getattr(self.m, name).numpy()
        arr[rows] = value
        self._model_put(name, arr)

    # ------------------------------------------------------------------ C data in and out
    def load_world(self, i: int, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """World ``i`` takes the state of a C ``data`` (time 0, no warm start, no applied
        forces) and ``model``'s per-world values.
        """
        for name in _COPIED:
            self.set_rows(name, i, getattr(data, name))
        self.set_rows("eq_active", i, data.eq_active)
        for name in _ZEROED:
            self.set_rows(name, i, 0.0)
        self.set_rows("time", i, 0.0)
        for name in self.per_world:
            if name != "geom_margin":  # switched per world by the backend itself
                self.set_model_rows(name, i, getattr(model, name))

    def copy_rows(self, src: int, rows: np.ndarray,
                  data_fields: Iterable[str] = WORLD_DATA) -> None:
        """The worlds ``rows`` take world ``src``'s ``data_fields`` and per-world model
        values.
        """
        for name in data_fields:
            self.set_rows(name, rows, self._get(name)[src])
        for name in self.per_world:
            self.set_model_rows(name, rows, getattr(self.m, name).numpy()[src])

    def sync_to(self, i: int, model: mujoco.MjModel, data: mujoco.MjData) -> mujoco.MjData:
        """Copy world ``i``'s state into a C ``data`` of ``model`` (for pictures); ``data``."""
        for name in ("qpos", "qvel", "mocap_pos", "mocap_quat", "ctrl"):
            getattr(data, name)[:] = self._get(name)[i]
        data.eq_active[:] = self._get("eq_active")[i]
        mujoco.mj_forward(model, data)
        return data

    # ------------------------------------------------------------------ stepping helpers
    def freeze(self, frozen: np.ndarray) -> dict[str, np.ndarray] | None:
        """The integration state of the ``frozen`` worlds, to :meth:`thaw` after stepping."""
        if not frozen.any():
            return None
        return {name: self._get(name)[frozen].copy() for name in STATE_FIELDS}

    def thaw(self, frozen: np.ndarray, saved: dict[str, np.ndarray] | None) -> None:
        """Put back the state :meth:`freeze` saved: the frozen worlds did not move."""
        if saved is None:
            return
        for name, value in saved.items():
            arr = self._get(name)
            arr[frozen] = value
            self._put(name, arr)

    def solve_m(self, rows: np.ndarray, columns: Sequence[np.ndarray], n: int) -> np.ndarray:
        """``M⁻¹ c`` of each world in ``rows`` for each (R, n) right-hand side ``c`` of
        ``columns`` (the first ``n`` dofs; the others zero), by MuJoCo Warp's factorised
        mass matrix: (R, len(columns), n).
        """
        out = np.zeros((len(rows), len(columns), n))
        rhs_host = np.zeros((self.n, self.nv))
        for c, col in enumerate(columns):
            rhs_host[:] = 0.0
            rhs_host[rows, :n] = col
            self._rhs.assign(rhs_host.astype(np.float32))
            self._mjw.solve_m(self.m, self.d, self._sol, self._rhs)
            out[:, c] = self._sol.numpy()[rows, :n]
        return out

    def touching(self, rows: np.ndarray, geom: int) -> np.ndarray:
        """(R,) bool: a contact of each world in ``rows`` involves ``geom``."""
        nacon = min(int(self.d.nacon.numpy()[0]), self.d.contact.worldid.shape[0])
        out = np.zeros(len(rows), bool)
        if nacon == 0:
            return out
        world = self.d.contact.worldid.numpy()[:nacon]
        geoms = self.d.contact.geom.numpy()[:nacon]
        hit = np.unique(world[(geoms == geom).any(axis=1)])
        return np.isin(rows, hit)
