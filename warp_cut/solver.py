"""Solvers: bound to a DeviceModel, they advance ``state_in -> state_out`` by one substep.

Only the physics a scene enables is launched (and so compiled): gravity, residual-stress
links and the tool test live in separate Warp modules.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .control import Tool
from .device_model import DeviceModel
from .state import State

__all__ = ["SemiImplicitSolver", "INTEGRATORS"]


class SemiImplicitSolver:
    """Semi-implicit Euler (springs, residual links, gravity, implicit damping, tool push-out).

    tool_force (1,) vec3 [N], contact_count (1,) int32 and contact_position_sum (1,) vec3 [m]
    accumulate over substeps until ``clear_tool_stats``.
    """

    def __init__(self, model: DeviceModel, *, gravity=None, residual_stress: bool = True,
                 collision: bool = True):
        self.model = model
        self.gravity = None if gravity is None else wp.vec3(*np.asarray(gravity, dtype=np.float32))
        self.residual_stress = bool(residual_stress)
        self.collision = bool(collision)
        device = model.device
        self.tool_force = wp.zeros(1, dtype=wp.vec3, device=device)
        self.contact_count = wp.zeros(1, dtype=wp.int32, device=device)
        self.contact_position_sum = wp.zeros(1, dtype=wp.vec3, device=device)

    def clear_tool_stats(self) -> None:
        self.tool_force.zero_()
        self.contact_count.zero_()
        self.contact_position_sum.zero_()

    def step(self, state_in: State, state_out: State, tool: Tool | None, h: float) -> None:
        """Advance by one substep h [s]. state_in.forces must be zero on entry (left zero)."""
        m = self.model
        device = m.device
        forces = state_in.forces
        if m.spring_count:
            from .kernels.springs import spring_forces

            wp.launch(spring_forces, dim=m.spring_count, device=device,
                      inputs=[state_in.positions, m.spring_indices, m.spring_rest_length,
                              m.spring_stiffness, forces])
        if self.residual_stress and m.link_count:
            from .kernels.residual import residual_link_forces

            wp.launch(residual_link_forces, dim=m.link_count, device=device,
                      inputs=[state_in.positions, m.link_indices, m.link_force,
                              m.link_smoothing, forces])
        if self.gravity is not None:
            from .kernels.gravity import gravity_forces

            wp.launch(gravity_forces, dim=m.node_count, device=device,
                      inputs=[m.node_mass, m.node_flags, self.gravity, forces])
        from .kernels.integrate import integrate_semi_implicit

        wp.launch(integrate_semi_implicit, dim=m.node_count, device=device,
                  inputs=[state_in.positions, state_in.velocities, forces, m.node_mass,
                          m.node_damping, m.node_flags, float(h)],
                  outputs=[state_out.positions, state_out.velocities])
        if self.collision and tool is not None and tool.radius > 0:
            from .kernels.collision import cylinder_push_out

            wp.launch(cylinder_push_out, dim=m.node_count, device=device,
                      inputs=[state_out.positions, state_out.velocities, m.node_mass,
                              m.node_damping, m.node_flags, wp.vec3(*tool.p0), wp.vec3(*tool.p1),
                              tool.radius, float(h), self.tool_force, self.contact_count,
                              self.contact_position_sum])


INTEGRATORS = {"semi_implicit": SemiImplicitSolver}
"""Integrator names a scene or Simulator accepts, and their solver classes."""
