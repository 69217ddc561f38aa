"""Solvers: bound to a DeviceModel, they advance ``state_in -> state_out`` by one substep.

``INTEGRATORS`` maps the names a scene uses (``[solver] integrator``) to solver classes; the
contract they share is in ``warp_cut.solvers.base``. Only the physics a scene enables is
launched (and so compiled): gravity and the tool are folded into specialised node kernels,
residual-stress links are their own module.
"""

from __future__ import annotations

import warp as wp

from .solvers.base import SolverBase
from .solvers.implicit import ImplicitEulerSolver
from .solvers.launches import LaunchSequence
from .solvers.xpbd import XPBDSolver

__all__ = ["SemiImplicitSolver", "ImplicitEulerSolver", "XPBDSolver", "INTEGRATORS"]


class SemiImplicitSolver(SolverBase):
    """Semi-implicit Euler (springs, residual links, gravity, implicit damping, tool push-out).

    Two launches per substep on a model without links: the spring forces, then one pass over
    the nodes that adds gravity, integrates, pushes nodes out of the tool and clears the force
    accumulator (``kernels.integrate``). Conditionally stable: see ``warp_cut.stability``.
    tool_force (1,) vec3 [N], contact_count (1,) int32 and contact_position_sum (1,) vec3 [m]
    accumulate over substeps until ``clear_tool_stats``.
    """

    def _record(self, seq: LaunchSequence, state_in, state_out, h: float) -> None:
        from .kernels.integrate import integrate_kernel
        from .kernels.springs import spring_forces

        m = self.model
        forces = state_in.forces
        indices, rest, stiffness, count = self.spring_arrays()
        seq.add(spring_forces, self.threads(count),
                [state_in.positions, indices, rest, stiffness, self.chunk, count, forces])
        if self.residual_stress and m.link_count:
            from .kernels.residual import residual_link_forces

            seq.add(residual_link_forces, m.link_count,
                    [state_in.positions, m.link_indices, m.link_force, m.link_smoothing, forces])
        node = integrate_kernel(self.gravity is not None, self.collision)
        seq.add(node, self.threads(m.node_count),
                [state_in.positions, state_in.velocities, forces, m.node_mass, m.node_damping,
                 m.node_flags, self.gravity if self.gravity is not None else wp.vec3(0.0),
                 self.tool_pose, h, self.chunk, m.node_count, state_out.positions,
                 state_out.velocities, self.tool_force, self.contact_count,
                 self.contact_position_sum])


INTEGRATORS = {
    "semi_implicit": SemiImplicitSolver,
    "implicit_euler": ImplicitEulerSolver,
    "xpbd": XPBDSolver,
}
"""Integrator names a scene or Simulator accepts, and their solver classes."""
