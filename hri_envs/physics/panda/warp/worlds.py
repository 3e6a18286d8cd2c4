"""N worlds of the Panda scene stepped together on MuJoCo Warp: :class:`WarpWorlds`.

Each world runs the C backend's abstract step (:meth:`hri_envs.physics.panda.sim.PandaSim.step`):
the robot's grasp toggle (approach, close, check the fingers, weld; or unweld and retreat),
the human's toggle, then the motion until the object settles or a time limit, the faults, the
observed state and the inferred human action. The worlds advance in lockstep, one control
period (``control_every_steps`` physics steps) at a time:

* *per control period, vectorised over the worlds* (numpy on the arrays of MuJoCo Warp's
  ``Data``): the human's reference and noise and their arm's actuator targets, the arm's
  wrench, the wrist sensor's reading and its compensation, bias, noise and delay, the
  grip's overload, the seat law, disagreement-aware variable impedance, the robot's
  straight line, the impedance controller (site Jacobians from the joint axes, ``M⁻¹`` by
  MuJoCo Warp's ``solve_m``, the 6 × 6 operational-space inverse by batched Cholesky), the
  impulses, the stability, floor and settle tests; the IK reference is one batched
  mink-warp step of every world due for an update;
* *per world, at the few events of a step* (its start, the end of each phase, its end):
  plain Python, as in the C backend;
* *physics*: ``mujoco_warp.step1``/``step2``/``step`` for all worlds at once. A world whose
  step has ended waits for the others frozen: its integration state (qpos, qvel, act,
  warm start, time) is put back after each period.

Per-world model values (the object's true mass, the human's strength and gains, the finger
servos' stiffness while welded) live in MuJoCo Warp's per-world model arrays; the grasps are
per world (:mod:`~hri_envs.physics.panda.warp.build`). Resets are made by a C
:class:`~hri_envs.physics.panda.sim.PandaSim` (its mink IK places the arm) and copied into the
world.

The class is assembled from one module per concern: :mod:`~hri_envs.physics.scene.warp.model`
(MuJoCo Warp's model and data on the host), :mod:`~hri_envs.physics.panda.warp.build` (this
scene's worlds: per-world arrays, resets, switches), :mod:`~hri_envs.physics.panda.warp.events`
(a step's events), :mod:`~hri_envs.physics.panda.warp.period` (the control period),
:mod:`~hri_envs.physics.scene.warp.control` (the vectorised control laws) and
:mod:`~hri_envs.physics.scene.warp.ik` (the batched IK).

Differences from the C backend, all within the tolerances of ``tests/test_mjwarp.py``:
MuJoCo Warp computes in float32 (the C backend in float64); MuJoCo's ``BADQACC``/``BADQVEL``
warnings are not kept per world (the ``unstable`` fault comes from non-finite or too fast
velocities only); mink-warp's IK is an ADMM box-constrained QP (:data:`IK_ADMM_ITERATIONS`),
mink's is daqp; a fault found before a control period's physics (``pulled_out``,
``ik_failure``) ends the world's step after that period's physics, 8 ms later than the C
backend; a frozen world's kinematics are those of its current state (C: of the state one
physics step before).
"""


from __future__ import annotations

import mujoco
import numpy as np

from hri_envs.physics.panda.sim import StepResult
from hri_envs.physics.panda.warp.build import IDLE
from hri_envs.physics.panda.warp.period import PandaPeriod
from hri_envs.physics.scene.warp.ik import IK_ADMM_ITERATIONS
from hri_envs.physics.scene.warp.model import NCONMAX, NJMAX

__all__ = ["IK_ADMM_ITERATIONS", "NCONMAX", "NJMAX", "WarpWorlds"]


class WarpWorlds(PandaPeriod):
    """``n_worlds`` worlds of one scenario's Panda scene on MuJoCo Warp.

    Args:
        graph: The task graph.
        n_worlds: How many worlds are stepped together.
        design: Physical design (default: the scenario's).
        options: Validated ``physics`` options (as for
            :class:`~hri_envs.physics.panda.sim.PandaSim`).
        device: Warp device (default: Warp's default device, a GPU where there is one).
        ik_rate: Rate [Hz] of the IK reference updates.

    Attributes:
        template: The C simulation that resets worlds (its IK places the arm) and renders.
        device: The Warp device the worlds run on ("cpu", "cuda:0", ...).
        on_period: Called after every control period with the (N,) mask of the worlds that
            ran it (for videos; None: nothing).
    """

    def step(self, states: np.ndarray, a_r: np.ndarray, a_h: np.ndarray,
             active: np.ndarray) -> list[StepResult | None]:
        """One abstract step of every ``active`` world (the others stay frozen).

        Args:
            states: (N,) the abstract state each world observed before the step.
            a_r: (N,) the robot's abstract action per world.
            a_h: (N,) the human's true abstract action per world.
            active: (N,) bool, the worlds that step.

        Returns:
            Per world its :class:`~hri_envs.physics.panda.steps.StepResult`, None where inactive.
        """
        self._refresh()
        rows = np.flatnonzero(active)
        for i in rows:
            w = self.worlds[i]
            if w.fault is not None and w.result is None:  # a reset that failed
                continue
            self.begin_step(int(i), int(states[i]), int(a_r[i]), int(a_h[i]))
        while (self.phase != IDLE).any():
            self.run_period()
        out: list[StepResult | None] = [None] * self.n
        for i in rows:
            out[i] = self.worlds[i].result
        return out

    def sync_template(self, i: int) -> mujoco.MjData:
        """Copy world ``i``'s state into the C template's data (for pictures); its data."""
        tpl = self.template
        return self.sync_to(i, tpl.model, tpl.data)
