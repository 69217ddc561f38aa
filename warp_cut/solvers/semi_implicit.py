"""Semi-implicit Euler: springs, residual links, bending, gravity, foundation, implicit damping, tool push-out."""

from __future__ import annotations

import warp as wp

from ..kernels.integrate import integrate_kernel
from ..kernels.residual import residual_link_forces
from ..kernels.springs import spring_forces
from .base import SolverBase
from .launches import LaunchSequence
from .limits import IncrementalLimit

__all__ = ["SemiImplicitSolver"]


class SemiImplicitSolver(SolverBase):
    """Semi-implicit Euler (springs, residual links, gravity, foundation, implicit damping,
    tool push-out).

    Two launches per substep on a model without links: the spring forces, then one pass over
    the nodes that adds gravity and the foundation, integrates, pushes nodes out of the tool
    and clears the force accumulator (``kernels.integrate``). Conditionally stable: see
    ``warp_cut.sim.stability``.
    tool_force (1,) vec3 [N], contact_count (1,) int32 and contact_position_sum (1,) vec3 [m]
    accumulate over substeps until ``clear_tool_stats``; the node pass runs the stability guard.
    """

    @classmethod
    def limit_tracker(cls, model, links: bool = True) -> IncrementalLimit:
        """The element bounds of ``warp_cut.sim.stability`` (the residual links' only if
        ``links`` act): an edit rates again only the elements at the nodes it touched."""
        return IncrementalLimit(model, links)

    def _extent(self) -> tuple:
        """Launches span the arrays' capacity (the kernels skip dead and unused slots), so an
        edit within capacity keeps the recorded launches: (node capacity, spring slots read,
        spring arrays read, whether links are launched, hinge arrays read)."""
        m = self.model
        indices = self.spring_arrays()[0]
        return (m.node_mass.shape[0], indices.shape[0] // 2, indices.ptr, self._links_on(), m.hinge_indices.ptr)

    def _links_on(self) -> bool:
        return self._links_act() or (self.residual_stress and self.links_expected)

    def _record(self, seq: LaunchSequence, state_in, state_out, h: float) -> None:
        m = self.model
        forces = state_in.forces
        indices, rest, stiffness, _ = self.spring_arrays()
        springs = indices.shape[0] // 2
        seq.add(spring_forces, self.threads(springs),
                [state_in.positions, indices, rest, stiffness, self.chunk, springs, forces])
        if self._links_on():
            seq.add(residual_link_forces, m.link_force.shape[0],
                    [state_in.positions, m.link_indices, m.link_force, m.link_smoothing, forces])
        self.add_hinge_forces(seq, state_in.positions, forces)
        node = integrate_kernel(self.gravity is not None, self.collision, self.foundation)
        nodes = m.node_mass.shape[0]
        seq.add(node, self.threads(nodes),
                [state_in.positions, state_in.velocities, forces, m.node_mass, m.node_damping,
                 m.node_flags, self.gravity if self.gravity is not None else wp.vec3(0.0),
                 m.rest_positions, m.node_area, self.foundation_stiffness, self.tool_pose, h,
                 self.chunk, m.used_slots, state_out.positions, state_out.velocities,
                 self.tool_force, self.contact_count, self.contact_position_sum]
                + self.guard_inputs(rest=False))
