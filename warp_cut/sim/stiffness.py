"""Spring stiffness from the material, so the sheet is the material's at any mesh resolution.

The paper gives every spring the same constant K. On a uniform near-equilateral mesh that is
a membrane of E t = 2 K / sqrt(3) whatever the spacing, but one unrelated to the material's E
and thickness, and wrong wherever triangles differ in size or shape (graded meshes, mesh
files, re-meshed cut borders). The ``"material"`` model derives each spring's stiffness from
Young's modulus E [Pa], the thickness t [m] and the triangles around the edge (van Gelder
1998, "Approximate simulation of elastic membranes by triangulated spring meshes"):

    k_ij = E t sum_(T adjacent to ij) |T| / |e_ij|^2      [N/m]

For a uniform mesh of equilateral triangles an interior edge gets ``k = (sqrt(3) / 2) E t``
whatever the edge length, the classical result for a spring lattice of a membrane with
Poisson's ratio 1/3 (border edges, with one triangle, get half). Springs that border no
triangle (extra springs a caller adds) keep the fallback stiffness given.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STIFFNESS_MODELS", "material_stiffness", "van_gelder_stiffness"]

STIFFNESS_MODELS = ("constant", "material")
"""``[material] stiffness_model`` values: the paper's constant K, or derived from E and t."""


def van_gelder_stiffness(youngs_modulus: float, thickness: float, area_sum, length_sq):
    """k = E t sum|T| / |e|^2 [N/m] for edges with adjacent triangle area ``area_sum`` [m^2] and
    squared length ``length_sq`` [m^2] (scalars or arrays)."""
    return youngs_modulus * thickness * np.asarray(area_sum) / np.asarray(length_sq)


def material_stiffness(points, triangles, springs, youngs_modulus: float, thickness: float,
                       fallback: float | np.ndarray = 0.0) -> np.ndarray:
    """Per-spring stiffness (s,) [N/m] by van Gelder's formula (see the module doc).

    points (n, 3) [m]; triangles (t, 3); springs (s, 2) node pairs; youngs_modulus E [Pa];
    thickness t [m]; fallback: stiffness [N/m] of springs with no adjacent triangle.
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    spr = np.sort(np.asarray(springs, dtype=np.int64).reshape(-1, 2), axis=1)
    if len(spr) == 0:
        return np.zeros(0)
    corners = pts[tri]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    tri_edges = np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    n = len(pts)
    # sum the areas of the triangles at each edge, matched to springs through a scalar key
    def key(e):
        return e[:, 0] * n + e[:, 1]
    order = np.argsort(key(spr))
    spring_keys = key(spr)[order]
    pos = np.searchsorted(spring_keys, key(tri_edges))
    pos = np.minimum(pos, len(spr) - 1)
    found = spring_keys[pos] == key(tri_edges)
    area_sum = np.zeros(len(spr))
    np.add.at(area_sum, order[pos[found]], np.repeat(area, 3)[found])
    length2 = np.sum((pts[spr[:, 1]] - pts[spr[:, 0]]) ** 2, axis=1)
    k = np.broadcast_to(np.asarray(fallback, dtype=np.float64), (len(spr),)).copy()
    has = (area_sum > 0) & (length2 > 0)
    k[has] = van_gelder_stiffness(youngs_modulus, thickness, area_sum[has], length2[has])
    return k
