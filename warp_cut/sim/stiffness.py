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

from ..mesh.geometry import edge_keys, half_edges, triangle_areas

__all__ = ["STIFFNESS_MODELS", "material_stiffness", "membrane_modulus", "van_gelder_stiffness"]

STIFFNESS_MODELS = ("constant", "material")
"""``[material] stiffness_model`` values: the paper's constant K, or derived from E and t."""


def membrane_modulus(material, stiffness_model: str) -> float:
    """The sheet's in-plane Young's modulus x thickness, E2D [N/m]: E t for ``"material"``
    springs; for the paper's constant K, that of a near-equilateral lattice, 2 K / sqrt(3)
    (``material`` a ``warp_cut.sim.material.Material``)."""
    if stiffness_model == "material":
        return material.youngs_modulus * material.thickness
    return 2.0 * material.stiffness / np.sqrt(3.0)


def van_gelder_stiffness(modulus_2d: float, area_sum, length_sq):
    """k = E2D sum|T| / |e|^2 [N/m] for edges with adjacent triangle area ``area_sum`` [m^2] and
    squared length ``length_sq`` [m^2] (scalars or arrays) in a sheet of E2D = E t [N/m]."""
    return modulus_2d * np.asarray(area_sum) / np.asarray(length_sq)


def material_stiffness(points, triangles, springs, youngs_modulus: float, thickness: float,
                       fallback: float | np.ndarray = 0.0) -> np.ndarray:
    """Per-spring stiffness by van Gelder's formula (see the module doc).

    Args:
        points: Node positions [m], shape (n, 3).
        triangles: Node indices, shape (t, 3).
        springs: Node pairs, shape (s, 2).
        youngs_modulus: E [Pa].
        thickness: t [m].
        fallback: Stiffness [N/m] of springs with no adjacent triangle, scalar or shape (s,).

    Returns:
        Spring stiffness [N/m], shape (s,) float64.
    """
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    spr = np.sort(np.asarray(springs, dtype=np.int64).reshape(-1, 2), axis=1)
    if len(spr) == 0:
        return np.zeros(0)
    # sum the areas of the triangles at each edge, matched to springs through a scalar key
    n = len(pts)
    tri_edge_keys = edge_keys(np.sort(half_edges(tri), axis=1), n)  # three per triangle, in order
    order = np.argsort(edge_keys(spr, n))
    spring_keys = edge_keys(spr, n)[order]
    pos = np.minimum(np.searchsorted(spring_keys, tri_edge_keys), len(spr) - 1)
    found = spring_keys[pos] == tri_edge_keys
    area_sum = np.zeros(len(spr))
    np.add.at(area_sum, order[pos[found]], np.repeat(triangle_areas(pts, tri), 3)[found])
    length2 = np.sum((pts[spr[:, 1]] - pts[spr[:, 0]]) ** 2, axis=1)
    k = np.broadcast_to(np.asarray(fallback, dtype=np.float64), (len(spr),)).copy()
    has = (area_sum > 0) & (length2 > 0)
    k[has] = van_gelder_stiffness(youngs_modulus * thickness, area_sum[has], length2[has])
    return k
