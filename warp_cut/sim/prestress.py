"""A prestressed sheet: the residual stress as an in-plane membrane tension from the start.

Skin in the body is under tension (SPEC section 1, "Prestress"). With
``material.residual_stress_model = "prestress"`` the sheet carries the residual stress
sigma_r = E eps_r [Pa] as a uniform isotropic membrane tension

    T = sigma_r x thickness      [N/m]

and its rest lengths are chosen so that the initial, pinned configuration is in equilibrium.
A uniform isotropic stress T in a triangle is equivalent to forces along its edges: the triangle
pulls each vertex with ``-T grad(area)``, which is, edge by edge, a tension

    f_e = (T / 2) (cot alpha_e + cot beta_e) |e|      [N]

with alpha_e, beta_e the angles opposite edge e in its one or two triangles (the cotangent or
force-density form of a constant stress; an edge on one triangle has one term). Summed over a
node's edges these forces are ``-T grad_x_i(total area)``: zero at every interior node of a flat
mesh, whatever its triangles (moving a node inside a flat sheet does not change its area), and
``T x (mean-curvature normal)`` on a curved one. Each spring then gets the rest length

    L0_e = L_e - f_e / k_e

so that its force k_e (L_e - L0_e) is f_e in the initial configuration. L0 must stay positive:
f_e < k_e L_e, else the tension is too large for the springs (an error names the parameters).
An edge with obtuse opposite angles summing above 180 degrees gets f_e < 0 (it is compressed).

On a curved mesh the net normal force T x 2H x area at each node (H the mean curvature) is not
balanced by the springs: the pinned border holds only its own nodes, so without a support the
sheet flattens or bulges until its springs balance it; the foundation (``physics.foundation``)
holds it near its shape, within about 2 H T / k_f of it.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["membrane_edge_tensions", "prestressed_rest_lengths"]


def _edge_keys(edges: np.ndarray, n: int) -> np.ndarray:
    return edges[:, 0] * n + edges[:, 1]


def membrane_edge_tensions(points, triangles, springs, tension: float) -> np.ndarray:
    """Edge tensions f (s,) [N] equivalent to a uniform isotropic membrane tension.

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3).
        springs: Node pairs, shape (s, 2); a spring on no triangle gets 0.
        tension: T [N/m] (stress x thickness).

    Returns:
        f_e = (T / 2) sum over the triangles at edge e of cot(angle opposite e) x |e|, shape (s,)
        (positive: the spring pulls its ends together).
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    spr = np.sort(np.asarray(springs, dtype=np.int64).reshape(-1, 2), axis=1)
    f = np.zeros(len(spr))
    if len(spr) == 0 or len(tri) == 0:
        return f
    n = len(pts)
    cot_sum = np.zeros(len(spr))
    order = np.argsort(_edge_keys(spr, n))
    spring_keys = _edge_keys(spr, n)[order]
    for k in range(3):  # the edge opposite corner k, and the cotangent of the angle at k
        c, a, b = tri[:, k], tri[:, (k + 1) % 3], tri[:, (k + 2) % 3]
        u, v = pts[a] - pts[c], pts[b] - pts[c]
        cross = np.linalg.norm(np.cross(u, v), axis=1)
        cot = np.divide(np.einsum("ij,ij->i", u, v), cross, out=np.zeros(len(tri)), where=cross > 0)
        keys = _edge_keys(np.sort(np.column_stack([a, b]), axis=1), n)
        pos = np.minimum(np.searchsorted(spring_keys, keys), len(spr) - 1)
        found = spring_keys[pos] == keys
        np.add.at(cot_sum, order[pos[found]], cot[found])
    length = np.linalg.norm(pts[spr[:, 1]] - pts[spr[:, 0]], axis=1)
    return 0.5 * float(tension) * cot_sum * length


def prestressed_rest_lengths(points, triangles, springs, stiffness, tension: float,
                             what: str = "the membrane tension", max_ratio: float | None = None) -> np.ndarray:
    """Rest lengths (s,) [m] that put the mesh in equilibrium under the membrane tension.

    Args:
        points: Node positions [m] (the prestressed configuration), shape (n, 3).
        triangles: Node indices, shape (t, 3).
        springs: Node pairs, shape (s, 2).
        stiffness: Spring stiffness k [N/m], scalar or shape (s,).
        tension: T [N/m].
        what: How the error message names the tension (e.g. the scene keys it comes from).
        max_ratio: None: refuse a spring that cannot carry its tension (below). Else f / (k L)
            is held within +-max_ratio, and a spring with k L = 0 carries none: the guard of a
            cut's edit, whose triangles may be nearly flat (``TopologyEditor``).

    Returns:
        L0 = L - f / k, shape (s,).

    Raises:
        InputError: if ``max_ratio`` is None and a spring would need L0 <= 0 (f >= k L) or
            carries tension with k = 0.
    """
    pts = np.asarray(points, dtype=np.float64)
    spr = np.asarray(springs, dtype=np.int64).reshape(-1, 2)
    k = np.broadcast_to(np.asarray(stiffness, dtype=np.float64), (len(spr),))
    f = membrane_edge_tensions(pts, triangles, spr, tension)
    length = np.linalg.norm(pts[spr[:, 1]] - pts[spr[:, 0]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(f == 0.0, 0.0, f / (k * length))
    if max_ratio is not None:
        return length * (1.0 - np.where(np.isfinite(ratio), np.clip(ratio, -max_ratio, max_ratio), 0.0))
    bad = ~(ratio < 1.0)
    if np.any(bad):
        s = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{what} T = {tension:.4g} N/m is too large for the springs: spring {s} "
            f"(nodes {tuple(int(v) for v in spr[s])}) needs a tension f = {f[s]:.4g} N but has "
            f"k L = {k[s] * length[s]:.4g} N (rest length L0 = L - f/k must stay > 0; "
            f"{int(bad.sum())} springs affected); lower the residual strain or Young's modulus, "
            f"or make the springs stiffer")
    return length * (1.0 - ratio)
