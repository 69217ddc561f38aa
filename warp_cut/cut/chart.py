"""A flat chart of a small piece of the rest surface, and the map back through its triangles.

Stage 3 re-meshes a region of a few spacings around the incision in two dimensions. The chart
projects the region's rest positions onto its mean tangent plane (exact where the rest shape is
flat; on curved skin a local unfolding whose lengths shrink by 1 - cos of the surface's turn
across the region, under 1 % for a region of 8 mm on a 4 cm radius). A point of the chart goes
back onto the surface through the region's own triangles (``PiecewiseLinearMap``): its
barycentric coordinates in the triangle it lies in give its rest position on the rest surface and
its current position in the deformed tissue, so a node made there starts where the tissue is
now (nothing jumps).

Shapes: points (k, 3) [m], chart points (k, 2) [m], triangles' corners (t, 3, 2) or (t, 3, 3).
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import cross3, plane_frame

__all__ = ["RegionChart", "PiecewiseLinearMap", "barycentric", "chart_min_angles", "chart_signed_areas"]


class RegionChart:
    """Orthogonal projection onto the plane through ``centre`` with unit ``normal``: (x, y) =
    ((p - centre) . e1, (p - centre) . e2), e1 x e2 = normal, so a triangle wound
    counter-clockwise seen from outside is counter-clockwise in the chart."""

    def __init__(self, centre, normal):
        self.centre = np.asarray(centre, dtype=np.float64)
        n = np.asarray(normal, dtype=np.float64)
        self.normal = n / np.linalg.norm(n)
        self.e1, self.e2 = plane_frame(self.normal)
        if np.dot(cross3(self.e1, self.e2), self.normal) < 0.0:
            self.e2 = -self.e2

    @classmethod
    def of_triangles(cls, corners: np.ndarray) -> RegionChart:
        """The chart of triangles with rest corners (t, 3, 3): the plane through their centroid
        normal to their area-weighted mean normal."""
        corners = np.asarray(corners, dtype=np.float64)
        normals = cross3(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        return cls(corners.reshape(-1, 3).mean(axis=0), normals.sum(axis=0))

    def to2d(self, points) -> np.ndarray:
        """Chart coordinates (..., 2) [m] of points (..., 3) [m]."""
        rel = np.asarray(points, dtype=np.float64) - self.centre
        return np.stack([rel @ self.e1, rel @ self.e2], axis=-1)

    def direction2d(self, vectors) -> np.ndarray:
        """Chart components (..., 2) of vectors (..., 3)."""
        v = np.asarray(vectors, dtype=np.float64)
        return np.stack([v @ self.e1, v @ self.e2], axis=-1)


def barycentric(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (m, t, 3) of chart points (m, 2) in triangles (t, 3, 2) (nan for
    a degenerate triangle)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    rel = points[:, None, :] - a[None]
    with np.errstate(divide="ignore", invalid="ignore"):
        l1 = (rel[..., 0] * v1[:, 1] - rel[..., 1] * v1[:, 0]) / det
        l2 = (v0[:, 0] * rel[..., 1] - v0[:, 1] * rel[..., 0]) / det
    return np.stack([1.0 - l1 - l2, l1, l2], axis=-1)


class PiecewiseLinearMap:
    """Chart points back onto the surface through the triangles they lie in.

    Args:
        chart_corners: The triangles' corners in the chart, (t, 3, 2) [m].
        *fields: Values at the same corners to interpolate, each (t, 3, d) (e.g. rest and
            current positions, (t, 3, 3) [m]).
    """

    def __init__(self, chart_corners: np.ndarray, *fields: np.ndarray):
        self.corners = np.asarray(chart_corners, dtype=np.float64)
        self.fields = [np.asarray(f, dtype=np.float64) for f in fields]

    def locate(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(triangle index (m,), barycentric coordinates (m, 3)) of chart points (m, 2): the
        triangle containing each point, else the nearest one, with its coordinates clamped onto
        it (a point just outside the region, in a slit, goes to the nearest tissue)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if not len(points):
            return np.zeros(0, np.int64), np.zeros((0, 3))
        bary = barycentric(points, self.corners)  # (m, t, 3)
        worst = np.nan_to_num(bary.min(axis=2), nan=-np.inf)
        inside = worst >= -1e-9
        tri = np.where(inside.any(axis=1), np.argmax(inside, axis=1), -1)
        out = np.take_along_axis(bary, np.maximum(tri, 0)[:, None, None], axis=1)[:, 0]
        outside = np.flatnonzero(tri < 0)
        if len(outside):
            k, lam = self._nearest(points[outside])
            tri[outside], out[outside] = k, lam
        return tri, out

    def _nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest triangle of each point (m, 2) and the barycentric coordinates of the
        nearest point on it."""
        c = self.corners
        best_d = np.full(len(points), np.inf)
        best_t = np.zeros(len(points), np.int64)
        best_l = np.zeros((len(points), 3))
        for i, j in ((0, 1), (1, 2), (2, 0)):  # the closest point on each edge i-j
            a, b = c[:, i], c[:, j]
            ab = b - a
            t = ((points[:, None, :] - a[None]) * ab[None]).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300)
            t = np.clip(t, 0.0, 1.0)
            d = np.linalg.norm(points[:, None, :] - (a[None] + t[..., None] * ab[None]), axis=2)
            tri = np.argmin(d, axis=1)
            dmin = d[np.arange(len(points)), tri]
            better = dmin < best_d
            if better.any():
                lam = np.zeros((better.sum(), 3))
                tt = t[better, tri[better]]
                lam[:, i], lam[:, j] = 1.0 - tt, tt
                best_d[better], best_t[better], best_l[better] = dmin[better], tri[better], lam
        return best_t, best_l

    def __call__(self, points) -> list[np.ndarray]:
        """Each field interpolated at chart points (m, 2): a list of (m, d) arrays."""
        tri, lam = self.locate(points)
        return [np.einsum("mk,mkd->md", lam, f[tri]) for f in self.fields]


def chart_min_angles(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Smallest angle [deg] of each triangle (t, 3) of chart points (n, 2), shape (t,) (a
    triangle with a zero-length edge has 0)."""
    corners = np.asarray(points, dtype=np.float64).reshape(-1, 2)[np.asarray(triangles).reshape(-1, 3)]
    ahead = corners[:, [1, 2, 0]] - corners
    behind = corners[:, [2, 0, 1]] - corners
    cross = ahead[..., 0] * behind[..., 1] - ahead[..., 1] * behind[..., 0]
    return np.degrees(np.arctan2(np.abs(cross), (ahead * behind).sum(axis=2))).min(axis=1)


def chart_signed_areas(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Twice the signed area of each triangle (t, 3) of chart points (n, 2), shape (t,)
    (positive: counter-clockwise)."""
    a, b, c = (points[triangles[:, k]] for k in range(3))
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
