"""Warp device code of warp_cut (installed as ``warp_cut.kernels``).

Each module is one Warp module, compiled on first launch only: a scene that
disables a physics term never launches, and so never compiles, its module.
Kernels are pure functions of typed arrays (no model objects), so a test can
build tiny arrays by hand on ``"cpu"`` and check one term alone.

Conventions: positions [m], velocities [m/s], forces [N] as ``wp.vec3``
(float32); spring and link endpoints as flat ``int32`` arrays ``[i0, j0, i1, j1, ...]``
where a negative index marks a deleted slot that every kernel skips.
Node flags are ``int32`` bit sets: ``NODE_ACTIVE`` and ``NODE_PINNED``, tested in kernels
with the functions of ``flags`` (``is_active``, ``is_pinned``, ``is_free``).
"""

from .flags import NODE_ACTIVE, NODE_PINNED

__all__ = ["NODE_ACTIVE", "NODE_PINNED"]
