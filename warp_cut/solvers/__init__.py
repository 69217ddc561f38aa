"""Time integrators. Each solver is bound to a DeviceModel and advances ``state_in -> state_out``
by one substep; ``warp_cut.solver.INTEGRATORS`` maps scene names to the classes."""
