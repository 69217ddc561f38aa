"""A triangle mesh that no formula made (a scan, an anatomical surface) as a ``Surface``, so
strokes can be drawn on it and cuts judged on it as on the analytic surfaces.

The chart is the orthographic projection onto the mesh's best-fit plane (through the nodes'
centroid, normal = the covariance's least eigenvector, turned to the side the triangles face):

* ``uv_of(points)`` - the projection [m] of points onto that plane, in a frame (e1, e2) of it;
* ``point(uv)`` - where the ray along the plane's normal through uv meets the mesh (the
  triangle whose projection holds uv, barycentric interpolation of its corners);
* ``normal(uv)`` - the normal of the hit triangle, interpolated over it from its corners'
  area-weighted normals (so a tool axis following it turns smoothly from triangle to triangle);
* ``offset(points)`` - the distance [m] from ``point(uv_of(p))`` along ``normal`` (first order).

The mesh must be a height field over that plane: every triangle's projection is wound
counter-clockwise (it faces the plane's normal side). The parameter domain is the polygon of
the projected border loop; ``depth(uv)`` is the distance [m] from it (negative outside).
Shapes: parameter points (..., 2), points (..., 3); leading dimensions are kept.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from ..errors import InputError
from ..mesh.checks import cuttable_problems
from ..mesh.geometry import cross3, plane_frame
from ..mesh.surfaces import Surface
from ..mesh.triangulate import boundary_edges, topology_problems

__all__ = ["MeshChart", "PolygonDomain", "mesh_surface", "load_mesh_surface", "border_polygon"]

CELL_SPACINGS = 2.0
"""Side of the point-location grid's cells in median edge lengths."""


def best_fit_plane(points) -> tuple[np.ndarray, np.ndarray]:
    """(centroid (3,) [m], unit normal (3,)) of the least-squares plane through points (n, 3)."""
    p = np.asarray(points, dtype=np.float64)
    centre = p.mean(axis=0)
    _, vectors = np.linalg.eigh(np.cov((p - centre).T))
    return centre, vectors[:, 0]


class _Grid:
    """Uniform grid over the projected triangles (t, 3, 2) [m]: which triangles may hold a point."""

    def __init__(self, corners: np.ndarray, cell: float):
        self.lo = corners.reshape(-1, 2).min(axis=0) - cell
        self.cell = float(cell)
        self.shape = np.ceil((corners.reshape(-1, 2).max(axis=0) + cell - self.lo) / cell).astype(int) + 1
        first = np.floor((corners.min(axis=1) - self.lo) / cell).astype(int)
        last = np.floor((corners.max(axis=1) - self.lo) / cell).astype(int)
        cells, owners = [], []
        for t, (a, b) in enumerate(zip(first, last)):
            i, j = np.meshgrid(np.arange(a[0], b[0] + 1), np.arange(a[1], b[1] + 1), indexing="ij")
            cells.append((i * self.shape[1] + j).ravel())
            owners.append(np.full(i.size, t))
        cells, owners = np.concatenate(cells), np.concatenate(owners)
        order = np.argsort(cells, kind="stable")
        counts = np.bincount(cells, minlength=int(self.shape.prod()))
        self.start = np.concatenate([[0], np.cumsum(counts)])
        self.owners = owners[order]
        self.width = int(counts.max())

    def candidates(self, uv: np.ndarray) -> np.ndarray:
        """Triangle candidates (m, width) of points uv (m, 2), padded with -1."""
        ij = np.clip(np.floor((uv - self.lo) / self.cell).astype(int), 0, self.shape - 1)
        cell = ij[:, 0] * self.shape[1] + ij[:, 1]
        offsets = self.start[cell][:, None] + np.arange(self.width)[None, :]
        valid = offsets < self.start[cell + 1][:, None]
        return np.where(valid, self.owners[np.minimum(offsets, len(self.owners) - 1)], -1)


def _barycentric(uv: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (..., 3) of points uv (..., 2) in triangles corners (..., 3, 2)."""
    a, b, c = corners[..., 0, :], corners[..., 1, :], corners[..., 2, :]
    v0, v1, v2 = b - a, c - a, uv - a
    det = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    w1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / det
    w2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / det
    return np.stack([1.0 - w1 - w2, w1, w2], axis=-1)


class MeshChart:
    """The orthographic chart of a height-field mesh (see the module docstring).

    Args:
        points: (n, 3) [m].
        triangles: (t, 3), wound counter-clockwise seen from the side they face.

    Attributes:
        origin: (3,) [m], the nodes' centroid; axes: (3, 3), rows e1, e2 and the plane's unit
        normal; uv: (n, 2) [m], the nodes' parameters.

    Raises:
        InputError: a triangle's projection is wound clockwise or flat (not a height field).
    """

    def __init__(self, points, triangles):
        self.points = np.asarray(points, dtype=np.float64)
        self.triangles = np.asarray(triangles, dtype=np.int64)
        self.origin, normal = best_fit_plane(self.points)
        corners = self.points[self.triangles]
        if cross3(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).sum(axis=0) @ normal < 0:
            normal = -normal
        self.axes = np.vstack([*plane_frame(normal), normal])
        self.uv = self.uv_of(self.points)
        corners = self.uv[self.triangles]
        turned = _signed_areas(corners) <= 0
        if turned.any():
            raise InputError(f"the mesh is not a height field over its best-fit plane: {int(turned.sum())} "
                             f"triangles project wound clockwise or flat (first {np.flatnonzero(turned)[:5].tolist()})")
        edges = np.linalg.norm(np.diff(self.points[self.triangles[:, [0, 1, 2, 0]]], axis=1), axis=2)
        self._grid = _Grid(corners, CELL_SPACINGS * float(np.median(edges)))
        self._vertex_normals = _vertex_normals(self.points, self.triangles)

    def uv_of(self, points) -> np.ndarray:
        """Parameters (..., 2) [m]: projections of points (..., 3) [m] onto the plane."""
        return (np.asarray(points, dtype=np.float64) - self.origin) @ self.axes[:2].T

    def locate(self, uv) -> tuple[np.ndarray, np.ndarray]:
        """(triangle rows (m,), barycentric coordinates (m, 3)) of parameter points (m, 2):
        the triangle whose projection holds the point, or outside the mesh the candidate it is
        least outside of (coordinates then extrapolate its plane)."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        rows = np.empty(len(uv), dtype=np.int64)
        weights = np.empty((len(uv), 3))
        for chunk in np.array_split(np.arange(len(uv)), max(1, len(uv) // 4096)):
            cand = self._grid.candidates(uv[chunk])
            bary = _barycentric(uv[chunk][:, None, :], self.uv[self.triangles[np.maximum(cand, 0)]])
            score = np.where(cand >= 0, bary.min(axis=2), -np.inf)
            best = score.argmax(axis=1)
            lost = ~np.isfinite(score[np.arange(len(chunk)), best])
            rows[chunk] = cand[np.arange(len(chunk)), best]
            weights[chunk] = bary[np.arange(len(chunk)), best]
            if lost.any():  # no triangle near the cell: the nearest triangle by centroid
                r, w = self._nearest(uv[chunk][lost])
                rows[chunk[lost]], weights[chunk[lost]] = r, w
        return rows, weights

    def _nearest(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        centroids = self.uv[self.triangles].mean(axis=1)
        rows = np.array([int(np.argmin(np.linalg.norm(centroids - q, axis=1))) for q in uv], dtype=np.int64)
        return rows, _barycentric(uv, self.uv[self.triangles[rows]])

    def point(self, uv) -> np.ndarray:
        """Points (..., 3) [m] of the mesh above (or below) parameter points (..., 2)."""
        uv = np.asarray(uv, dtype=np.float64)
        rows, w = self.locate(uv)
        p = np.einsum("mk,mkd->md", w, self.points[self.triangles[rows]])
        return p.reshape(uv.shape[:-1] + (3,))

    def normal(self, uv) -> np.ndarray:
        """Unit normals (..., 3) at parameter points (..., 2): the hit triangle's corner normals
        interpolated barycentrically."""
        uv = np.asarray(uv, dtype=np.float64)
        rows, w = self.locate(uv)
        n = np.einsum("mk,mkd->md", np.clip(w, 0.0, 1.0), self._vertex_normals[self.triangles[rows]])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        return n.reshape(uv.shape[:-1] + (3,))

    def offset(self, points) -> np.ndarray:
        """Signed distance (...,) [m] of points (..., 3) from the mesh along its normal
        (first order: measured from the mesh point with the same parameters)."""
        p = np.asarray(points, dtype=np.float64)
        uv = self.uv_of(p)
        return np.einsum("...d,...d->...", p - self.point(uv), self.normal(uv))


def _signed_areas(corners: np.ndarray) -> np.ndarray:
    """Twice the signed areas (t,) [m^2] of 2D triangles (t, 3, 2) (positive: counter-clockwise)."""
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    return e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]


def _vertex_normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Unit area-weighted node normals (n, 3)."""
    face = cross3(points[triangles[:, 1]] - points[triangles[:, 0]], points[triangles[:, 2]] - points[triangles[:, 0]])
    total = np.zeros_like(points)
    for k in range(3):
        np.add.at(total, triangles[:, k], face)
    return total / np.maximum(np.linalg.norm(total, axis=1, keepdims=True), 1e-300)


def border_polygon(triangles) -> np.ndarray:
    """Nodes (b,) of the single border loop of a disk-like mesh, in its winding order."""
    edges = boundary_edges(triangles)
    following = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist()))
    if len(following) != len(edges):
        raise InputError("the mesh's border is pinched (a node on more than two border edges)")
    loop = [int(edges[0, 0])]
    while following[loop[-1]] != loop[0]:
        loop.append(following[loop[-1]])
        if len(loop) > len(edges):
            raise InputError("the mesh's border does not close")
    if len(loop) != len(edges):
        raise InputError("the mesh has more than one border loop (a disk-like patch is needed)")
    return np.asarray(loop, dtype=np.int64)


@dataclass(frozen=True, eq=False)
class PolygonDomain:
    """The parameter region inside a simple polygon ``corners`` (k, 2) [m]."""

    corners: np.ndarray

    def depth(self, uv) -> np.ndarray:
        """Distance (...,) [m] of parameter points (..., 2) from the polygon, negative outside."""
        uv = np.asarray(uv, dtype=np.float64)
        q = uv.reshape(-1, 2)
        a, b = self.corners, np.roll(self.corners, -1, axis=0)
        out = np.empty(len(q))
        for chunk in np.array_split(np.arange(len(q)), max(1, len(q) // 2048)):
            p = q[chunk][:, None, :]
            ab = b - a
            t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
            dist = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=1)
            straddle = (a[None, :, 1] > p[..., 1]) != (b[None, :, 1] > p[..., 1])
            x_cross = a[None, :, 0] + (p[..., 1] - a[None, :, 1]) * ab[None, :, 0] / np.where(
                straddle, ab[None, :, 1], 1.0)
            inside = (straddle & (p[..., 0] < x_cross)).sum(axis=1) % 2 == 1
            out[chunk] = np.where(inside, dist, -dist)
        return out.reshape(uv.shape[:-1])


def mesh_surface(points, triangles, *, name: str = "mesh", spacing: float | None = None) -> Surface:
    """A disk-like mesh as a ``Surface`` with a ``MeshChart`` and the polygon of its border.
    spacing [m]: the mesh's edge length (default: the median edge length)."""
    pts = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    problems = cuttable_problems(pts, tri) + topology_problems(tri, len(pts), 1)
    if problems:
        raise InputError(f"{name}: not a cuttable disk-like mesh: {'; '.join(problems)}")
    chart = MeshChart(pts, tri)
    if spacing is None:
        spacing = float(np.median(np.linalg.norm(np.diff(pts[tri[:, [0, 1, 2, 0]]], axis=1), axis=2)))
    domain = PolygonDomain(chart.uv[border_polygon(tri)])
    return Surface(name, pts, tri, chart.uv.copy(), float(spacing), chart, domain, 1)


def load_mesh_surface(path, *, name: str | None = None, scale: float = 1.0) -> Surface:
    """``mesh_surface`` of a mesh file (OBJ/STL/PLY through trimesh, node order kept) [m x scale]."""
    path = Path(path)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise InputError(f"{path}: cannot read mesh ({exc})") from exc
    return mesh_surface(np.asarray(mesh.vertices) * scale, np.asarray(mesh.faces), name=name or path.stem)
