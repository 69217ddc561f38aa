"""Bending of the skin: a hinge on every interior edge of the mesh (discrete shells).

A membrane of springs has no bending stiffness: pressed in its plane it folds at no cost. Skin
is a plate of thickness t; its flexural rigidity is D = E t^3 / (12 (1 - nu^2)) [N m] (with the
lattice's nu = 1/3, D = 3 E t^3 / 32: 1.5e-5 N m for Table 1's E = 20 kPa, t = 2 mm).

A hinge is an interior edge (a, b) with the opposite corners k and l of its two triangles: k in
the triangle that runs a -> b, l in the one that runs b -> a (triangles wound CCW from outside).
Its energy is 1/2 k_h (theta - theta_0)^2 with theta the signed dihedral angle (0 where the two
triangles are coplanar, ``dihedral_angles``) and

    k_h = D |e|^2 / (A_1 + A_2)

(|e| the edge's rest length, A_1, A_2 the rest areas of its triangles; Grinspun et al. 2003's
|e| / h_e form). Calibrated on the regular lattice bent into a cylinder of curvature kappa along
its rows: the hinges then hold 0.97 x 1/2 D kappa^2 per unit area, the plate's energy in
cylindrical bending (``tests/test_bending.py``). Hinge energies depend on how the mesh lies on
the surface: the same lattice bent about an axis 17 or 40 degrees off its rows holds 2.1 and
5.5 times as much (flat triangles inscribed at a slant also tilt along the axis). It is a
bending resistance of the right order that stops a membrane from folding at no cost, not a
mesh-independent plate model.

theta_0 and k_h come from the shape the hinge is made at: the rest shape for the mesh's own
hinges, the current shape for hinges a cut makes (as its springs take their current length
outside a prestressed sheet, ``warp_cut.cut.topology``).

Arrays: hinges (h, 4) int64 [a, b, k, l]; points / positions (n, 3) [m].
"""

from __future__ import annotations

import numpy as np

__all__ = ["flexural_rigidity", "hinges_of", "dihedral_angles", "hinge_stiffness", "hinge_caps",
           "bending_rows", "hinge_rates", "mass_caps", "LATTICE_POISSON", "EQUILATERAL_RATE"]

LATTICE_POISSON = 1.0 / 3.0
"""Poisson's ratio of a regular triangle lattice of equal springs (the in-plane model)."""


def flexural_rigidity(youngs_modulus: float, thickness: float, poisson: float = LATTICE_POISSON) -> float:
    """D = E t^3 / (12 (1 - nu^2)) [N m] of a plate of Young's modulus E [Pa] and thickness t [m]."""
    return youngs_modulus * thickness ** 3 / (12.0 * (1.0 - poisson * poisson))


def hinges_of(triangles: np.ndarray) -> np.ndarray:
    """The hinges (h, 4) [a, b, k, l] of consistently wound triangles (t, 3), one per edge shared
    by exactly two triangles, with a < b; edges on one triangle (the border) have none."""
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if not len(tri):
        return np.zeros((0, 4), dtype=np.int64)
    start = tri.ravel()                          # directed edges start -> end, opposite corner
    end = tri[:, [1, 2, 0]].ravel()
    opposite = tri[:, [2, 0, 1]].ravel()
    n = int(tri.max()) + 1
    key = start * n + end
    order = np.argsort(key)
    sorted_keys = key[order]
    forward = start < end                        # a -> b with a < b: the first triangle
    reverse_key = end[forward] * n + start[forward]
    at = np.minimum(np.searchsorted(sorted_keys, reverse_key), len(sorted_keys) - 1)
    paired = sorted_keys[at] == reverse_key
    other = order[at[paired]]
    return np.stack([start[forward][paired], end[forward][paired],
                     opposite[forward][paired], opposite[other]], axis=1)


def _normals(x, hinges: np.ndarray):
    """Edge e = x_b - x_a (h, 3) and the unnormalised normals N1 = e x (x_k - x_a) of triangle
    (a, b, k) and N2 = (x_l - x_a) x e of triangle (b, a, l), both (h, 3), and the four corners'
    positions. ``x``: anything that an index array (h,) turns into positions (h, 3) [m]."""
    xa, xb, xk, xl = (np.asarray(x[hinges[:, c]], dtype=np.float64) for c in range(4))
    e = xb - xa
    return e, np.cross(e, xk - xa), np.cross(xl - xa, e), (xa, xb, xk, xl)


def dihedral_angles(positions: np.ndarray, hinges: np.ndarray) -> np.ndarray:
    """Signed dihedral angles theta [rad] (h,) in (-pi, pi]: the rotation about the edge a -> b
    from the first triangle's normal to the second's (0 when coplanar)."""
    e, n1, n2, _ = _normals(positions, hinges)
    unit_e = e / np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-300)
    n1 = n1 / np.maximum(np.linalg.norm(n1, axis=1, keepdims=True), 1e-300)
    n2 = n2 / np.maximum(np.linalg.norm(n2, axis=1, keepdims=True), 1e-300)
    sin = np.einsum("ij,ij->i", np.cross(n1, n2), unit_e)
    return np.arctan2(sin, np.einsum("ij,ij->i", n1, n2))


def hinge_stiffness(points, hinges: np.ndarray, rigidity: float) -> np.ndarray:
    """k_h = D |e|^2 / (A_1 + A_2) [N m] (h,) of hinges on ``points`` for rigidity D [N m]."""
    e, n1, n2, _ = _normals(points, hinges)
    areas = 0.5 * (np.linalg.norm(n1, axis=1) + np.linalg.norm(n2, axis=1))
    return rigidity * np.einsum("ij,ij->i", e, e) / np.maximum(areas, 1e-300)


EQUILATERAL_RATE = 32.0 / (3.0 * np.sqrt(3.0))
"""k_h |d theta / d x|^2 of a flat hinge of two equilateral triangles of edge l, in units of
D / l^2 (each of its four gradients is 1 / height)."""


def hinge_caps(points, hinges: np.ndarray, rigidity: float) -> np.ndarray:
    """The most a hinge may hold [N/m] (h,): k_h |d theta / d x|^2 of a flat equilateral hinge
    whose edge is the longest of the hinge's two triangles' edges at ``points``,
    EQUILATERAL_RATE D / l^2.

    The discrete-shell stiffness grows as 1 / A and the angle's gradient at a corner as 1 / h,
    or 1 / |e| at the ends of a short edge, so a hinge on a sliver (which a cut can make, or the
    motion of its nodes) would hold its corners ever harder and set an explicit step near zero.
    The force kernel scales k_h down to cap / |d theta / d x|^2 where it would hold more: a
    sliver bends more easily than the plate would, and the stable step has a bound that does
    not depend on the shape (``bending_rows``)."""
    x = [np.asarray(points[hinges[:, c]], dtype=np.float64) for c in range(4)]
    edges = [(0, 1), (0, 2), (1, 2), (0, 3), (1, 3)]
    longest2 = np.max([np.einsum("ij,ij->i", x[j] - x[i], x[j] - x[i]) for i, j in edges], axis=0)
    return EQUILATERAL_RATE * rigidity / np.maximum(longest2, 1e-300)


def hinge_rates(caps: np.ndarray, hinges: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """2 cap / m [1/s^2] (h,) of each hinge, m the least mass [kg] of its four nodes: the most a
    hinge adds to the bending's rate B_i / m_i at any of its nodes (``bending_rows``)."""
    return 2.0 * np.asarray(caps, dtype=np.float64) / np.maximum(_least_masses(hinges, masses), 1e-300)


def _least_masses(hinges: np.ndarray, masses: np.ndarray) -> np.ndarray:
    """The least mass [kg] (h,) of each hinge's four nodes."""
    hinges = np.asarray(hinges, dtype=np.int64).reshape(-1, 4)
    return np.min(np.asarray(masses, dtype=np.float64)[hinges], axis=1) if len(hinges) else np.zeros(0)


def mass_caps(caps: np.ndarray, hinges: np.ndarray, masses: np.ndarray, budget: float) -> np.ndarray:
    """``caps`` [N/m] (h,) lowered where a hinge would add more than ``budget`` [1/s^2] to the
    bending's rate at one of its nodes (``hinge_rates``): cap <= budget m / 2, m the least mass
    of its nodes.

    The shape cap (``hinge_caps``) bounds a hinge by its triangles' longest edge, but a cut can
    make small triangles with good angles (round a thin blade's slit, at its tip), and a node
    on them has a small lumped mass: the rate of an explicit bending term grows as D / (m l^2),
    as 1 / l^4, and one such node once set a step 100 times shorter than the uncut sheet's.
    With the budget the rate of the sheet's own hinges (``TissueModel.bending_budget``), no
    hinge a cut makes holds its nodes harder, for their mass, than the uncut sheet's did: a
    small triangle bends more easily than the plate would, as a sliver does."""
    return np.minimum(np.asarray(caps, dtype=np.float64), 0.5 * budget * _least_masses(hinges, masses))


def bending_rows(node_count: int, hinges: np.ndarray, caps: np.ndarray) -> np.ndarray:
    """A bound on the Gershgorin row sums [N/m] (node_count,) of the bending stiffness, whatever
    the shape: a hinge holding k g g^T with k |g|^2 <= cap adds k |g_v| sum_u |g_u| <= 2 cap to
    each of its four nodes (Cauchy-Schwarz over the four). For the stable step
    (``warp_cut.sim.stability``)."""
    rows = np.zeros(node_count)
    if len(hinges):
        np.add.at(rows, np.asarray(hinges).ravel(), np.repeat(2.0 * np.asarray(caps), 4))
    return rows
