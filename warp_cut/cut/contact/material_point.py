"""Carrying the blade's crossing from where the skin lies now into the rest (material) shape.

The crossing is a point of the deformed skin. A triangle's barycentric coordinates map a point
of it from where the tissue lies now to where it rests: an affine map. Right at the blade the
triangles are the tool's own dent (their nodes pushed onto its cylinder), and the one the axis
pierces changes from step to step, so the map is taken from the tissue round the blade instead:
the affine map that best carries the current positions of the nodes near the crossing (those the
tool pushes left out, Gaussian weights) to their rest positions, in the skin's tangent plane
there (``affine_material_point``). It is the barycentric map wherever a triangle is carried
affinely, and it is smooth from event to event. The point is then put on the rest surface:
onto the plane of the nearest rest triangle, along its normal, so that a crossing in a gaping
wound comes back into the slit it gapes from (a point of the opening, not a lip). A crossing
farther than a reach from every live triangle lies over an opening (an earlier wound): it has no
material point.

Shapes: corners (m, 3, 3) [m]; points (3,) [m].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...mesh.geometry import cross3, plane_frame
from ...sim.collision import axis_distance
from ...sim.control import Tool
from ..tolerances import TOOL_HOLD

__all__ = ["MaterialPoint", "held_by", "closest_on_triangles", "nearest_triangle", "material_point",
           "affine_material_point"]


@dataclass(frozen=True)
class MaterialPoint:
    """A crossing carried into the rest shape.

    Attributes:
        rest: The material point [m], (3,).
        normal: The rest surface's unit outward normal there, (3,).
        triangle: Row (into the triangles given) of the triangle it lies in.
        distance: How far the crossing (the affine fit's point, ``affine_material_point``) lay
            from that triangle [m] (0: on it; more: in an opening beside it).
    """

    rest: np.ndarray
    normal: np.ndarray
    triangle: int
    distance: float


def held_by(x: np.ndarray, tool: Tool | None) -> np.ndarray:
    """(n,) bool: the points (n, 3) [m] within ``TOOL_HOLD`` tool radii of its axis (the tool
    pushes them, so they do not say where the tissue is); none without a tool."""
    if tool is None or tool.radius <= 0.0:
        return np.zeros(len(x), dtype=bool)
    return axis_distance(x, tool) < TOOL_HOLD * tool.radius


def closest_on_triangles(point: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance (m,) [m], barycentric coordinates (m, 3) of the closest point) of ``point`` (3,)
    to each triangle (m, 3, 3): the foot of the perpendicular where it falls inside, else the
    closest point of the nearest edge (the first of equals, edges 01, 12, 20)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    ab, ac = b - a, c - a
    n = cross3(ab, ac)
    nn = (n * n).sum(axis=1)
    flat = nn <= 1e-24 * np.maximum((ab * ab).sum(axis=1) * (ac * ac).sum(axis=1), 1e-300)
    nn = np.maximum(nn, 1e-300)
    foot = point[None] - (((point[None] - a) * n).sum(axis=1) / nn)[:, None] * n
    lam_b = (cross3(foot - a, ac) * n).sum(axis=1) / nn
    lam_c = (cross3(ab, foot - a) * n).sum(axis=1) / nn
    lam = np.stack([1.0 - lam_b - lam_c, lam_b, lam_c], axis=1)
    inside = (lam >= 0.0).all(axis=1) & ~flat  # a triangle with collinear corners is its edges
    edge_d, edge_lam = _closest_on_edges(point, corners)
    best_d = np.where(inside, np.sqrt(((point[None] - foot) ** 2).sum(axis=1)), edge_d)
    return best_d, np.where(inside[:, None], lam, edge_lam)


def _closest_on_edges(point: np.ndarray, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance (m,) [m], barycentric coordinates (m, 3)) of the closest point to ``point``
    (3,) on the edges of each triangle (m, 3, 3), the first of equals (edges 01, 12, 20)."""
    m = len(corners)
    pq = corners[:, [1, 2, 0]] - corners  # (m, 3 edges, 3)
    t = ((point - corners) * pq).sum(axis=2) / np.maximum((pq * pq).sum(axis=2), 1e-300)
    t = np.minimum(np.maximum(t, 0.0), 1.0)
    gap = point - (corners + t[..., None] * pq)
    d = np.sqrt((gap * gap).sum(axis=2))
    rows, edge = np.arange(m), np.argmin(d, axis=1)
    lam = np.zeros((m, 3))
    lam[rows, edge] = 1.0 - t[rows, edge]
    lam[rows, (edge + 1) % 3] = t[rows, edge]
    return d[rows, edge], lam


def _candidates(point: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Indices (sorted) of the triangles (m, 3, 3) that may be nearest to ``point`` (3,): those
    whose distance bound from below (to the centroid, less the farthest corner from it) is
    within the nearest corner of any triangle (a bound from above on the nearest distance)."""
    centroid = corners.mean(axis=1)
    spread = np.sqrt(((corners - centroid[:, None]) ** 2).sum(axis=2).max(axis=1))
    nearest_corner = np.sqrt(((corners - point) ** 2).sum(axis=2).min())
    below = np.sqrt(((centroid - point) ** 2).sum(axis=1)) - spread
    return np.flatnonzero(below <= nearest_corner * (1.0 + 1e-9) + 1e-15)


def nearest_triangle(point: np.ndarray, corners: np.ndarray) -> tuple[int, float, np.ndarray]:
    """(index, distance [m], barycentric coordinates (3,)) of the triangle of ``corners``
    (m >= 1, 3, 3) nearest to ``point`` (3,), the first of equals; ``closest_on_triangles`` on
    the few triangles a distance bound cannot rule out."""
    keep = _candidates(point, corners)
    dist, lam = closest_on_triangles(point, corners[keep])
    k = int(np.argmin(dist))
    return int(keep[k]), float(dist[k]), lam[k]


def _within(point: np.ndarray, corners: np.ndarray, reach: float) -> bool:
    """True if a triangle of ``corners`` (m >= 1, 3, 3) lies within ``reach`` [m] of ``point``
    (3,): at once if a corner does (a triangle is no farther than its corners)."""
    if np.sqrt(((corners - point) ** 2).sum(axis=2).min()) <= reach:
        return True
    return nearest_triangle(point, corners)[1] <= reach


def material_point(point, current: np.ndarray, rest: np.ndarray, reach: float) -> MaterialPoint | None:
    """The material point of the crossing ``point`` [m] (3,): through the live triangle (current
    corners ``current`` (m, 3, 3) [m], rest corners ``rest`` (m, 3, 3) [m]) nearest to it, if
    within ``reach`` [m]; else None (the crossing is over an opening)."""
    if not len(current):
        return None
    k, dist, lam = nearest_triangle(np.asarray(point, dtype=np.float64), np.asarray(current, np.float64))
    if dist > reach:
        return None
    corners = np.asarray(rest[k], dtype=np.float64)
    normal = cross3(corners[1] - corners[0], corners[2] - corners[0])
    return MaterialPoint(lam @ corners, normal / np.linalg.norm(normal), k, dist)


def affine_material_point(point, normal, current: np.ndarray, rest: np.ndarray, weights: np.ndarray,
                          current_corners: np.ndarray, rest_corners: np.ndarray, reach: float) -> MaterialPoint | None:
    """The material point of the crossing ``point`` [m] (3,) (skin normal ``normal``) through the
    affine map carrying the nodes' ``current`` positions (k, 3) [m] to their ``rest`` positions
    (k, 3) [m] with ``weights`` (k,), fitted in the tangent plane at the crossing; put onto the
    plane of the nearest of the rest triangles ``rest_corners`` (m, 3, 3) (it may lie off the
    triangle, in an opening; ``distance`` says how far). None if no live triangle
    (``current_corners`` (m, 3, 3)) lies within ``reach`` [m] of the crossing (over an opening),
    or the nodes do not span the plane (then the triangle map is used)."""
    point = np.asarray(point, dtype=np.float64)
    if not len(current_corners) or not _within(point, np.asarray(current_corners, np.float64), reach):
        return None
    e1, e2 = plane_frame(normal)
    rel = current - point
    basis = np.column_stack([np.ones(len(rel)), rel @ e1, rel @ e2])
    sw = np.sqrt(np.asarray(weights, dtype=np.float64))
    solution, _, rank, _ = np.linalg.lstsq(basis * sw[:, None], rest * sw[:, None], rcond=1e-10)
    if rank < 3:
        return material_point(point, current_corners, rest_corners, reach)
    k, dist, _ = nearest_triangle(solution[0], np.asarray(rest_corners, np.float64))
    corners = rest_corners[k]
    rest_normal = cross3(corners[1] - corners[0], corners[2] - corners[0])
    rest_normal /= np.linalg.norm(rest_normal)
    on_plane = solution[0] - float((solution[0] - corners[0]) @ rest_normal) * rest_normal
    return MaterialPoint(on_plane, rest_normal, k, dist)
