"""XPBD with small steps (one constraint iteration per substep); see ``warp_cut.kernels.xpbd``."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..kernels import xpbd as K
from ..kernels.residual import link_constraints, link_valence
from ..kernels.xpbd import spring_valence
from ..sim.stability import StepLimit, node_stiffness_sums, stable_time_step
from .base import SolverBase
from .launches import LaunchSequence

__all__ = ["XPBDSolver", "xpbd_step_limits"]


class XPBDSolver(SolverBase):
    """Springs as compliant distance constraints (compliance 1/k) and residual links as
    zero-length ones (compliance r / F), Jacobi with split masses.

    Stable at any substep for the springs and links; the step only limits accuracy: far above
    the explicit limit one Jacobi iteration does not converge the constraints, and the sheet
    responds softer and more damped than its springs say.
    """

    @classmethod
    def step_limit(cls, model, links: bool = True) -> StepLimit:
        """The limit of the explicit part alone: the foundation and the bending (infinite
        without either). The springs and residual links are constraints, so ``links`` changes
        nothing.

        XPBD damps after the solve, so the explicit prediction ``x + h v + h^2 f / m`` is not
        damped within its own step, and damping lowers the limit instead of raising it as in
        semi-implicit Euler: see ``xpbd_step_limits``.
        """
        if model.foundation_stiffness <= 0 and not model.hinge_table.live_count:
            explicit = stable_time_step(model, links=links)
            return StepLimit(math.inf, math.inf, explicit.node, explicit.omega_max)
        sums = node_stiffness_sums(_ExplicitPart(model), links=False)
        rows = ~model.pinned & model.active & (sums > 0)
        if not rows.any():
            return StepLimit(math.inf, math.inf, -1, 0.0)
        m = model.masses[rows]
        omega2 = sums[rows] / m
        steps = xpbd_step_limits(omega2, model.damping[rows] / m)
        k = int(np.argmin(steps))
        omega_max = float(np.sqrt(omega2.max()))
        return StepLimit(float(steps[k]), 2.0 / omega_max, int(np.flatnonzero(rows)[k]), omega_max)

    def _derive(self) -> None:
        super()._derive()

        self._node_arrays()
        device = self.device
        indices, _, stiffness, count = self.spring_arrays()
        if count:
            wp.launch(spring_valence, dim=self.threads(count), device=device,
                      inputs=[indices, stiffness, self.chunk, count, self._valence,
                              self._stiffness_sum])
        if self._links_act():
            wp.launch(link_valence, dim=self.model.link_count, device=device,
                      inputs=[self.model.link_indices, self._valence])

    def _node_arrays(self) -> None:
        """The per-node work arrays, zeroed: made again only when the node count changes, so
        launches recorded before an edit that keeps the counts read the valences it derives."""
        n = self.model.node_count
        if getattr(self, "_valence", None) is not None and self._valence.shape[0] == n:
            self._valence.zero_()
            self._stiffness_sum.zero_()
            return
        device = self.device
        self._delta = wp.zeros(n, dtype=wp.vec3, device=device)
        self._valence = wp.zeros(n, dtype=wp.float32, device=device)
        self._stiffness_sum = wp.zeros(n, dtype=wp.float32, device=device)

    def _record(self, seq: LaunchSequence, state_in, state_out, h: float) -> None:
        m = self.model
        n = m.node_count
        chunk, nt = self.chunk, self.threads(n)
        x_in, forces = state_in.positions, state_in.forces
        self.add_hinge_forces(seq, x_in, forces)
        gravity = self.gravity if self.gravity is not None else wp.vec3(0.0)
        seq.add(K.predict_kernel(self.gravity is not None, self.foundation), nt,
                [x_in, state_in.velocities, forces, m.node_mass, m.node_damping, m.node_flags,
                 gravity, m.rest_positions, m.node_area, self.foundation_stiffness, h, chunk, n,
                 state_out.positions])
        indices, rest, stiffness, count = self.spring_arrays()
        inv_h2 = 1.0 / (h * h)
        seq.add(K.distance_constraints, self.threads(count),
                [state_out.positions, indices, rest, stiffness, m.node_mass, m.node_flags,
                 self._valence, inv_h2, chunk, count, self._delta])
        if self._links_act():
            seq.add(link_constraints, m.link_count,
                    [state_out.positions, m.link_indices, m.link_force, m.link_smoothing,
                     m.node_mass, m.node_flags, self._valence, self._stiffness_sum, inv_h2, self._delta])
        seq.add(K.finish_kernel(self.collision), nt,
                [x_in, m.node_mass, m.node_damping, m.node_flags, self._stiffness_sum,
                 self.tool_pose, h, chunk, n,
                 self._delta, state_out.positions, state_out.velocities, self.tool_force,
                 self.contact_count, self.contact_position_sum] + self.guard_inputs())


def xpbd_step_limits(omega2: np.ndarray, damping_rate: np.ndarray) -> np.ndarray:
    """Stable XPBD substeps [s] of the explicit forces, per node.

    For a mode of frequency omega (``omega2`` = omega^2 [1/s^2], the Gershgorin bound R / m)
    and damping rate c = D / m [1/s], one substep maps (x, h v) to
    ``x' = (1 - h^2 omega^2) x + h v`` and ``h v' = a (x' - x)``, a = 1 / (1 + h c): trace
    1 - h^2 omega^2 + a, determinant a. It is stable while ``h^2 omega^2 <= 2 (1 + a)``:
    2 / omega without damping, down to sqrt(2) / omega for heavy damping. The root of
    h^2 omega^2 (1 + h c) = 2 (2 + h c), the only positive one, is found by bisection
    between those two.
    """
    omega2 = np.asarray(omega2, dtype=np.float64)
    c = np.asarray(damping_rate, dtype=np.float64)
    lo, hi = np.sqrt(2.0 / omega2), 2.0 / np.sqrt(omega2)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        unstable = mid * mid * omega2 * (1.0 + mid * c) > 2.0 * (2.0 + mid * c)
        lo, hi = np.where(unstable, lo, mid), np.where(unstable, mid, hi)
    return lo


class _ExplicitPart:
    """A view of a model without its springs, for the explicit (foundation and hinge) part of
    the step limit."""

    def __init__(self, model):
        self._model = model
        self.springs = np.zeros((0, 2), dtype=np.int64)
        self.stiffness = np.zeros(0)

    def __getattr__(self, name):
        return getattr(self._model, name)
