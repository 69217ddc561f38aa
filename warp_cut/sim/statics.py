"""Static equilibrium of a spring network on the host (numpy), a reference for the dynamics.

Solves ``F(x) + f_ext = 0`` for the free nodes (live, not pinned) by Newton's method: each
step solves ``K dx = F(x) + f_ext`` with K = -dF/dx by conjugate gradients (matrix-free,
Jacobi-preconditioned). A spring (i, j) of stiffness k and rest length L0 at length L with
direction u contributes the block ``k [a I + (1 - a) u u^T]``, a = 1 - L0 / L, to K; a
compressed spring's negative transverse term is dropped (a = max(a, 0)), which keeps K
positive semi-definite (Newton then converges linearly for those springs, quadratically
otherwise). Residual links and the tool are left out: this is the spring network's own
equilibrium (used to check the prestress and the opening of a slit against fracture mechanics).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StaticResult", "spring_network_forces", "static_equilibrium"]


@dataclass(frozen=True)
class StaticResult:
    """positions (node_count, 3) [m]; residual: largest |net force| on a free node [N];
    newton_steps and cg_iterations (total) used; converged: residual <= the tolerance."""

    positions: np.ndarray
    residual: float
    newton_steps: int
    cg_iterations: int
    converged: bool


def spring_network_forces(x, springs, rest_lengths, stiffness) -> np.ndarray:
    """Net spring force on each node (n, 3) [N] at positions x (n, 3) [m] (paper Eq. 2)."""
    d = x[springs[:, 1]] - x[springs[:, 0]]
    length = np.linalg.norm(d, axis=1)
    scale = np.divide(stiffness * (length - rest_lengths), length, out=np.zeros(len(d)),
                      where=length > 0)
    f = d * scale[:, None]
    return _scatter(len(x), springs, f)


def _scatter(n, springs, f) -> np.ndarray:
    """Sum +f at the first node and -f at the second of every spring, (n, 3)."""
    out = np.empty((n, 3))
    for c in range(3):
        out[:, c] = (np.bincount(springs[:, 0], f[:, c], minlength=n)
                     - np.bincount(springs[:, 1], f[:, c], minlength=n))
    return out


class _Stiffness:
    """The tangent stiffness K at positions x, applied matrix-free."""

    def __init__(self, x, springs, rest, k, free):
        d = x[springs[:, 1]] - x[springs[:, 0]]
        length = np.maximum(np.linalg.norm(d, axis=1), 1e-300)
        self.u = d / length[:, None]
        self.a = np.maximum(0.0, 1.0 - rest / length)
        self.k = k
        self.springs = springs
        self.free = free.astype(np.float64)
        n = len(x)
        diag = np.zeros((n, 3))
        block_diag = k[:, None] * (self.a[:, None] + (1.0 - self.a[:, None]) * self.u ** 2)
        for c in range(3):
            diag[:, c] = (np.bincount(springs[:, 0], block_diag[:, c], minlength=n)
                          + np.bincount(springs[:, 1], block_diag[:, c], minlength=n))
        self.inv_diag = np.where(diag > 0, 1.0 / np.maximum(diag, 1e-300), 0.0) * self.free

    def apply(self, p) -> np.ndarray:
        dp = p[self.springs[:, 0]] - p[self.springs[:, 1]]
        along = np.einsum("ij,ij->i", self.u, dp)
        y = self.k[:, None] * (self.a[:, None] * dp + (1.0 - self.a[:, None]) * along[:, None] * self.u)
        return _scatter(len(p), self.springs, y) * self.free


def _cg(op: _Stiffness, b, tol, max_iterations) -> tuple[np.ndarray, int]:
    x = np.zeros_like(b)
    r = b.copy()
    z = r * op.inv_diag
    p = z.copy()
    rz = float(np.sum(r * z))
    target = tol * tol * rz
    for it in range(1, max_iterations + 1):
        ap = op.apply(p)
        pap = float(np.sum(p * ap))
        if pap <= 0.0:
            return x, it
        alpha = rz / pap
        x += alpha * p
        r -= alpha * ap
        z = r * op.inv_diag
        rz_new = float(np.sum(r * z))
        if rz_new <= target:
            return x, it
        p = z + (rz_new / rz) * p
        rz = rz_new
    return x, max_iterations


def static_equilibrium(model, positions=None, *, external=None, force_tolerance: float = 1e-9,
                       max_newton: int = 20, cg_tolerance: float = 1e-8,
                       cg_iterations: int = 20000, planar: bool = False) -> StaticResult:
    """The static equilibrium of ``model``'s springs (and optional external forces).

    Args:
        model: A TissueModel (its live springs, pinned and active nodes).
        positions: Start [m], shape (node_count, 3) (default the rest positions ``model.points``).
        external: Constant external forces [N] on the nodes, shape (node_count, 3), or None.
        force_tolerance: Stop when the largest net force on a free node is below this
            fraction of the largest spring force k |L - L0| at the start (or of 1 N if none).
        max_newton: Newton steps at most.
        cg_tolerance: Relative tolerance of each linear solve (preconditioned residual norm).
        cg_iterations: CG iterations at most per Newton step.
        planar: Hold every node's z (a flat sheet in a plane z = const: its plane-stress
            equilibrium). Without it a spring in compression can make the membrane, which has
            no bending stiffness, buckle out of its plane: another equilibrium.
    """
    x = np.array(model.points if positions is None else positions, dtype=np.float64)
    springs, rest, k = model.springs, model.rest_lengths, model.stiffness
    free = (model.active & ~model.pinned)[:, None] & np.array([True, True, not planar])
    ext = np.zeros_like(x) if external is None else np.asarray(external, dtype=np.float64)
    d = np.linalg.norm(x[springs[:, 1]] - x[springs[:, 0]], axis=1)
    scale = float(np.max(k * np.abs(d - rest))) if len(springs) else 0.0
    scale = max(scale, float(np.abs(ext).max()) if ext.size else 0.0) or 1.0
    total_cg, steps = 0, 0
    residual = np.inf
    for steps in range(max_newton + 1):
        f = (spring_network_forces(x, springs, rest, k) + ext) * free
        residual = float(np.abs(f).max()) if len(f) else 0.0
        if residual <= force_tolerance * scale or steps == max_newton:
            break
        dx, used = _cg(_Stiffness(x, springs, rest, k, free), f, cg_tolerance, cg_iterations)
        total_cg += used
        x += dx
    return StaticResult(x, residual, steps, total_cg, residual <= force_tolerance * scale)
