"""Time integrators: each solver is bound to a DeviceModel and advances ``state_in -> state_out``
by one substep.

``INTEGRATORS`` maps the names a scene uses (``[solver] integrator``) to solver classes; the
contract they share is in ``warp_cut.solvers.base``. Only the physics a scene enables is
launched (and so compiled): gravity and the tool are folded into specialised node kernels,
residual-stress links are their own module.
"""

from .implicit import ImplicitEulerSolver
from .semi_implicit import SemiImplicitSolver
from .xpbd import XPBDSolver

__all__ = ["SemiImplicitSolver", "ImplicitEulerSolver", "XPBDSolver", "INTEGRATORS"]

INTEGRATORS = {
    "semi_implicit": SemiImplicitSolver,
    "implicit_euler": ImplicitEulerSolver,
    "xpbd": XPBDSolver,
}
"""Integrator names a scene or Simulator accepts, and their solver classes."""
