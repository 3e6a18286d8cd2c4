"""MuJoCo's C functions for compiled (numba) code: the C backend's control periods call
``mj_step1``, ``mj_jacSite``, ``mj_solveM``, ``mj_step2`` ... from inside one compiled step.

The functions are those of the ``libmujoco`` that the ``mujoco`` package ships and its
Python bindings use (the same library, loaded once per process), declared with the
signatures of the header it ships (``mujoco/include/mujoco/mujoco.h``) and resolved by name
when numba links the code (so ``cache=True`` keeps working across processes). A model and a
data are passed by address (``MjModel._address``, ``MjData._address``: ints), arrays by
``arr.ctypes.data``.

Unlike the bindings, these calls do not turn MuJoCo's fatal errors (``mju_error``: e.g. an
arena too small for the contacts) into Python exceptions; warnings are recorded in
``MjData.warning`` as always.
"""

from __future__ import annotations

import glob
import os

import llvmlite.binding as llvm
import mujoco
from numba import types

__all__ = ["mj_jac", "mj_jacSite", "mj_solveM", "mj_step", "mj_step1", "mj_step2"]


def _library() -> str:
    """The path of the ``libmujoco`` beside the ``mujoco`` package."""
    here = os.path.dirname(mujoco.__file__)
    found = sorted(glob.glob(os.path.join(here, "libmujoco.so*"))
                   + glob.glob(os.path.join(here, "libmujoco*.dylib"))
                   + glob.glob(os.path.join(here, "mujoco.dll")))
    if not found:
        raise ImportError(f"the mujoco package at {here} has no libmujoco")
    return found[0]


llvm.load_library_permanently(_library())

_ptr = types.uintp
# void mj_step1(const mjModel* m, mjData* d); mj_step2, mj_step likewise
mj_step1 = types.ExternalFunction("mj_step1", types.void(_ptr, _ptr))
mj_step2 = types.ExternalFunction("mj_step2", types.void(_ptr, _ptr))
mj_step = types.ExternalFunction("mj_step", types.void(_ptr, _ptr))
# void mj_jacSite(const mjModel* m, const mjData* d, mjtNum* jacp, mjtNum* jacr, int site)
mj_jacSite = types.ExternalFunction("mj_jacSite",  # noqa: N816 (MuJoCo's name)
                                    types.void(_ptr, _ptr, _ptr, _ptr, types.int32))
# void mj_jac(const mjModel* m, const mjData* d, mjtNum* jacp, mjtNum* jacr,
#             const mjtNum point[3], int body)
mj_jac = types.ExternalFunction("mj_jac", types.void(_ptr, _ptr, _ptr, _ptr, _ptr, types.int32))
# void mj_solveM(const mjModel* m, mjData* d, mjtNum* x, const mjtNum* y, int n)
mj_solveM = types.ExternalFunction("mj_solveM",  # noqa: N816 (MuJoCo's name)
                                   types.void(_ptr, _ptr, _ptr, _ptr, types.int32))
