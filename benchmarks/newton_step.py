"""Newton's ``SolverSemiImplicit`` on the same spring network (particles of radius 0, springs
only), for the throughput comparison. Newton's springs damp relative velocity (kd) while
warp_cut damps each node (-D v); both are run without damping in the spring (kd = 0).
"""

from __future__ import annotations

import numpy as np


def available() -> str | None:
    """None if newton imports, else the reason it does not."""
    try:
        import newton  # noqa: F401
    except Exception as exc:  # any import failure means: skip with a note
        return f"{type(exc).__name__}: {exc}"
    return None


class NewtonSemiImplicit:
    """A Newton model of the TissueModel's nodes and springs, stepped by SolverSemiImplicit."""

    def __init__(self, model, device="cpu"):
        import newton

        builder = newton.ModelBuilder()
        mass = np.where(model.pinned, 0.0, model.masses)  # mass 0: kinematic (pinned)
        builder.add_particles(pos=[tuple(p) for p in model.points],
                              vel=[(0.0, 0.0, 0.0)] * model.node_count,
                              mass=mass.tolist(), radius=[0.0] * model.node_count)
        # the builder's per-spring call recomputes each rest length in Python; fill the
        # lists it keeps directly with the same values
        builder.spring_indices = model.springs.astype(np.int64).ravel().tolist()
        builder.spring_rest_length = model.rest_lengths.tolist()
        builder.spring_stiffness = model.stiffness.tolist()
        builder.spring_damping = [0.0] * model.spring_count
        builder.spring_control = [0.0] * model.spring_count
        self.model = builder.finalize(device=device)
        self.model.particle_grid = None
        self.solver = newton.solvers.SolverSemiImplicit(self.model)
        self.state_0 = self.model.state()
        self.state_1 = self.model.state()

    def step(self, h: float) -> None:
        self.state_0.clear_forces()
        self.solver.step(self.state_0, self.state_1, None, None, h)
        self.state_0, self.state_1 = self.state_1, self.state_0
