"""Implicit (backward) Euler: one linearised Newton step per substep, matrix-free PCG.

See ``warp_cut.kernels.implicit`` for the equations. Unconditionally stable for the linear
spring network: the step is limited by accuracy (it damps the fast modes), not stability.
"""

from __future__ import annotations

import math

import warp as wp

from ..kernels import implicit as K
from ..kernels.collision import cylinder_push_out
from ..kernels.gravity import gravity_forces
from ..kernels.residual import residual_link_forces
from ..kernels.springs import spring_forces
from ..sim.stability import ElementRates, StepLimit, damped_step
from .base import SolverBase
from .launches import LaunchSequence

__all__ = ["ImplicitEulerSolver"]


class ImplicitEulerSolver(SolverBase):
    """Backward Euler with Jacobi-preconditioned conjugate gradients on the device.

    Extra options: cg_iterations (fixed count of CG iterations recorded per substep; later
    ones return at once after convergence), cg_tolerance (relative, on sqrt(r.z / r0.z0)).
    The tool is applied after the solve as a projection (push-out, as in the other solvers);
    its reaction uses the diagonal of the system matrix as the node's inertia.
    """

    def __init__(self, model, *, gravity=None, residual_stress: bool = True,
                 collision: bool = True, replay: str = "auto", cg_iterations: int = 40,
                 cg_tolerance: float = 1e-4, max_displacement: float = math.inf,
                 links_expected: bool = False, limits=None):
        self.cg_iterations = int(cg_iterations)
        self.cg_tolerance = float(cg_tolerance)
        device = model.device
        self.cg = wp.zeros((self.cg_iterations + 1, 2), dtype=wp.float64, device=device)
        """CG scalars per iteration: r.z and p.Ap."""
        super().__init__(model, gravity=gravity, residual_stress=residual_stress,
                         collision=collision, replay=replay, max_displacement=max_displacement,
                         links_expected=links_expected, limits=limits)

    @classmethod
    def step_limit(cls, model, links: bool = True) -> StepLimit:
        """No stability limit (infinite step) for the springs, links and foundation; node and
        omega_max as for the explicit step. The bending, when the sheet has any, is explicit
        (the hinge forces at the step's start): its own limit (``ElementRates.bending_bounds``,
        semi-implicit Euler's formula with the implicit damping)."""
        rates = ElementRates(model, links)
        explicit = rates.limit()
        (bend_mass, node), (bend_damping, _) = rates.bending_bounds()
        if bend_mass <= 0:
            return StepLimit(math.inf, math.inf, explicit.node, explicit.omega_max)
        return StepLimit(damped_step(bend_mass, bend_damping), 2.0 / math.sqrt(bend_mass), node,
                         explicit.omega_max)

    def _derive(self) -> None:
        super()._derive()
        n = self.model.node_count
        device = self.device
        self._vectors = {name: wp.zeros(n, dtype=wp.vec3, device=device)
                         for name in ("ap", "diagonal", "inv_diagonal", "x", "r", "z", "p")}

    def _record(self, seq: LaunchSequence, state_in, state_out, h: float) -> None:
        m = self.model
        n = m.node_count
        chunk, nt = self.chunk, self.threads(n)
        v = self._vectors
        x_in, forces = state_in.positions, state_in.forces
        indices, rest, stiffness, count = self.spring_arrays()
        links = self._links_act()
        h2, tol2 = h * h, self.cg_tolerance ** 2
        seq.add(K.cg_reset, self.cg_iterations + 1, [self.cg])
        seq.add(K.zero_vectors, nt, [chunk, n, v["diagonal"]])
        seq.add(spring_forces, self.threads(count),
                [x_in, indices, rest, stiffness, chunk, count, forces])
        if links:
            seq.add(residual_link_forces, m.link_count,
                    [x_in, m.link_indices, m.link_force, m.link_smoothing, forces])
        self.add_hinge_forces(seq, x_in, forces)  # explicit: see step_limit
        if self.gravity is not None:
            seq.add(gravity_forces, n, [m.node_mass, m.node_flags, self.gravity, forces])

        def stiffness_product(p, k_iter):
            seq.add(K.spring_matvec, self.threads(count),
                    [x_in, indices, rest, stiffness, p, h2, self.cg, k_iter, tol2, chunk, count,
                     v["ap"], v["diagonal"]])
            if links:
                seq.add(K.link_matvec, m.link_count,
                        [x_in, m.link_indices, m.link_force, m.link_smoothing, p, h2, self.cg,
                         k_iter, tol2, v["ap"], v["diagonal"]])

        stiffness_product(state_in.velocities, -1)  # also accumulates the diagonal
        seq.add(K.cg_start_kernel(self.foundation), nt,
                [state_in.velocities, forces, m.node_mass, m.node_damping, m.node_flags, x_in,
                 m.rest_positions, m.node_area, self.foundation_stiffness, h,
                 chunk, n, v["ap"], v["diagonal"], v["x"], v["r"], v["z"], v["p"],
                 v["inv_diagonal"], self.cg])
        curvature = K.cg_curvature_kernel(self.foundation)
        for k in range(self.cg_iterations):
            stiffness_product(v["p"], k)
            seq.add(curvature, nt, [v["p"], m.node_mass, m.node_damping, m.node_flags,
                                    m.node_area, self.foundation_stiffness, h, k, tol2, chunk, n,
                                    v["ap"], self.cg])
            seq.add(K.cg_descend, nt, [v["p"], v["inv_diagonal"], k, tol2, chunk, n, v["ap"],
                                       v["x"], v["r"], v["z"], self.cg])
            seq.add(K.cg_direction, nt, [v["z"], k, tol2, chunk, n, v["p"], self.cg])
        # the guard runs here; the push-out below moves a finite node by at most the tool
        # radius, with finite inertia, so it cannot make a finite state non-finite
        seq.add(K.implicit_advance, nt, [x_in, v["x"], m.node_flags, h, chunk, n,
                                         state_out.positions, state_out.velocities]
                + self.guard_inputs())
        if self.collision:
            seq.add(cylinder_push_out, n,
                    [state_out.positions, state_out.velocities, m.node_mass, m.node_damping,
                     m.node_flags, self.tool_pose, h, v["diagonal"], self.tool_force,
                     self.contact_count,
                     self.contact_position_sum])
