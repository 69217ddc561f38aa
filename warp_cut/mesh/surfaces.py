"""Skin-like surface meshes with the analytic surface they sample, for cutting on more than a
flat patch: a turned flat grid, an irregular Delaunay disk, a dome, a forearm-like cylinder and
a saddle.

Each generator returns a ``Surface``: ``points`` (n, 3) float64 [m] on the analytic surface,
``triangles`` (t, 3) int64 wound counter-clockwise seen from outside (normals outward / up),
``uv`` (n, 2) [m] the nodes' parameter coordinates, and the chart (``warp_cut.mesh.charts``)
for planning strokes: ``point(u, v)``, ``normal(u, v)`` (unit, outward), ``uv_of(points)``.
Edges are about ``spacing`` long; meshes have no degenerate, duplicate or flipped triangles,
a consistent winding and are manifold (checked when made, see ``warp_cut.mesh.validity``).
The border nodes are the natural pinned set: ``TissueModel.from_surface(surface)`` builds the tissue
with ``pinned="border"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

from ..errors import InputError
from .charts import Cylinder, DiskDomain, Plane, RectDomain, Saddle, Sphere
from .checks import check_mesh
from .geometry import edges_of
from .triangulate import delaunay, disk_points, jitter_lattice, lattice, topology_problems, trim_border_slivers

__all__ = ["Surface", "flat_grid", "jittered_delaunay", "dome", "cylinder", "saddle", "on_plane"]

SLIVER_TRIM_DEG = 15.0
"""Border triangles of a Delaunay mesh with a smaller angle [deg] are trimmed off."""


@dataclass(frozen=True, eq=False)
class Surface:
    """A triangle mesh sampling an analytic surface.

    name: the generator ("flat_grid", "jittered_delaunay", "dome", "cylinder", "saddle", "plane").
    points: node positions [m], (n, 3) float64, on the analytic surface.
    triangles: (t, 3) int64, counter-clockwise seen from outside.
    uv: parameter coordinates [m] of the nodes, (n, 2).
    spacing: the requested edge length [m].
    chart: the analytic surface (``Plane``, ``Sphere``, ``Cylinder`` or ``Saddle``).
    domain: the parameter region the mesh covers (``RectDomain`` or ``DiskDomain``).
    border_loops: number of border loops (1 for a disk-like patch, 2 for a closed tube).
    """

    name: str
    points: np.ndarray
    triangles: np.ndarray
    uv: np.ndarray
    spacing: float
    chart: object
    domain: object
    border_loops: int = 1

    def point(self, u, v) -> np.ndarray:
        """Surface points [m], shape (..., 3), at parameters u, v [m] (broadcast)."""
        return self.chart.point(np.stack(np.broadcast_arrays(u, v), axis=-1))

    def normal(self, u, v) -> np.ndarray:
        """Outward unit normals, shape (..., 3), at parameters u, v [m] (broadcast)."""
        return self.chart.normal(np.stack(np.broadcast_arrays(u, v), axis=-1))

    def uv_of(self, points) -> np.ndarray:
        """Parameters (..., 2) [m] of points (..., 3) [m] on or near the surface."""
        return self.chart.uv_of(points)

    def offset(self, points) -> np.ndarray:
        """Signed distance (...,) [m] of points (..., 3) from the surface, positive outside."""
        return self.chart.offset(points)

    def depth(self, uv) -> np.ndarray:
        """Distance (...,) [m] of parameter points (..., 2) from the border of the mesh's
        parameter domain, negative outside it."""
        return self.domain.depth(uv)



def _positive(**values) -> None:
    for name, value in values.items():
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{name} must be > 0, got {value}")


def _size2(size) -> tuple[float, float]:
    w, h = (float(size), float(size)) if np.ndim(size) == 0 else (float(size[0]), float(size[1]))
    _positive(width=w, height=h)
    return w, h


def _make(name, chart, domain, uv, triangles, spacing, border_loops=1) -> Surface:
    surf = Surface(name, chart.point(uv), np.asarray(triangles, np.int64), np.asarray(uv, np.float64),
                   float(spacing), chart, domain, border_loops)
    problems = surface_problems(surf)
    if problems:
        raise InputError(f"{name}: the generated mesh is invalid: {'; '.join(problems)}")
    return surf


def flat_grid(size=0.04, spacing: float = 2e-3, angle: float = 0.0) -> Surface:
    """A flat square (or (width, height)) [m] triangular lattice in the XY plane, centred on
    the origin and turned by ``angle`` [rad] about Z, so cuts need not follow lattice rows."""
    w, h = _size2(size)
    _positive(spacing=spacing)
    uv, tri = lattice(w, h, spacing)
    c, s = math.cos(angle), math.sin(angle)
    uv = uv @ np.array([[c, s], [-s, c]])
    return _make("flat_grid", Plane(), RectDomain(w / 2, h / 2, float(angle)), uv, tri, spacing)


def _delaunay_disk(name, chart, radius, spacing, jitter, seed) -> Surface:
    """Jittered points in the parameter disk, Delaunay triangulated, slivers trimmed off the border."""
    rng = np.random.default_rng(seed)
    uv = disk_points(radius, spacing, jitter, rng)
    kept, tri = trim_border_slivers(chart.point(uv), delaunay(uv), SLIVER_TRIM_DEG)
    return _make(name, chart, DiskDomain(radius), uv[kept], tri, spacing)


def jittered_delaunay(radius: float = 0.02, spacing: float = 2e-3, jitter: float = 0.25,
                      seed: int = 0) -> Surface:
    """An irregular flat disk of ``radius`` [m] in the XY plane: a triangular lattice of
    ``spacing`` [m] with every point moved by up to ``jitter`` x spacing (at most 0.3), a ring
    of border points, Delaunay triangulated; border triangles with an angle below 15 deg are
    trimmed off.

    Smallest angle: in a triangle with circumradius R an edge e faces an angle a with
    sin a = e / (2 R). Jittered points are at least (1 - 2 jitter) spacing apart, and a Delaunay
    circle holds no point, so R <= spacing / sqrt(3) + jitter x spacing (the lattice's covering
    radius plus the jitter). Hence every triangle whose circumcentre lies inside the disk has
    a >= asin((1 - 2 j) / (2 (1/sqrt(3) + j))): 17.6 deg at j = 0.25, 13.2 deg at 0.3; border
    triangles, whose circumcentre may lie outside, are trimmed below 15 deg.
    """
    _positive(radius=radius, spacing=spacing)
    return _delaunay_disk("jittered_delaunay", Plane(), float(radius), float(spacing), jitter, seed)


def dome(radius_of_curvature: float = 0.04, base_radius: float = 0.025, spacing: float = 2e-3,
         jitter: float = 0.0, seed: int = 0) -> Surface:
    """A spherical cap of ``radius_of_curvature`` [m] whose rim is a circle of ``base_radius``
    [m] (at most the radius of curvature: up to a hemisphere), apex at the origin, normal
    outward. Built as ``jittered_delaunay`` in the geodesic polar chart (see ``Sphere``), so
    edges along the rim are up to 1 - sin(theta)/theta shorter than ``spacing``."""
    _positive(radius_of_curvature=radius_of_curvature, base_radius=base_radius, spacing=spacing)
    if base_radius > radius_of_curvature:
        raise InputError(f"dome base_radius {base_radius} m must be <= radius_of_curvature {radius_of_curvature} m")
    geodesic = radius_of_curvature * math.asin(base_radius / radius_of_curvature)
    return _delaunay_disk("dome", Sphere(float(radius_of_curvature)), geodesic, float(spacing), jitter, seed)


def cylinder(radius: float = 0.03, length: float = 0.06, arc_angle: float = math.pi,
             spacing: float = 2e-3, jitter: float = 0.0, seed: int = 0) -> Surface:
    """The outer surface of a cylinder (a forearm) of ``radius`` [m] along X, ``length`` [m]
    long, covering ``arc_angle`` [rad] about its crest (2 pi: a closed tube, open at both
    ends), normal outward; the crest is the X axis. A triangular lattice in (x, arc length),
    each node moved by up to ``jitter`` x half its shortest edge (0 <= jitter < 1; border nodes
    along the border only)."""
    _positive(radius=radius, length=length, arc_angle=arc_angle, spacing=spacing)
    if arc_angle > 2.0 * math.pi + 1e-12:
        raise InputError(f"cylinder arc_angle must be <= 2 pi rad, got {arc_angle}")
    closed = arc_angle >= 2.0 * math.pi - 1e-12
    width_v = radius * (2.0 * math.pi if closed else arc_angle)
    uv, tri = lattice(length, width_v, spacing, periodic_v=closed)
    if jitter:
        uv = jitter_lattice(uv, tri, jitter, np.random.default_rng(seed), border_u=length / 2,
                            border_v=None if closed else width_v / 2)
    domain = RectDomain(length / 2, width_v / 2, 0.0, width_v if closed else None)
    return _make("cylinder", Cylinder(float(radius)), domain, uv, tri, spacing, 2 if closed else 1)


def saddle(size=0.04, curvature: float = 25.0, spacing: float = 2e-3, jitter: float = 0.0,
           seed: int = 0) -> Surface:
    """The saddle z = c (x^2 - y^2) / 2 over a square (or (width, height)) [m] centred on the
    origin, ``curvature`` c [1/m] (25 /m: radius 4 cm), normal up; a triangular lattice in
    (x, y) (edges stretch by up to sqrt(1 + (c x)^2 + (c y)^2) at the corners), jittered as
    in ``cylinder``."""
    w, h = _size2(size)
    _positive(spacing=spacing)
    if not np.isfinite(curvature):
        raise InputError(f"saddle curvature must be finite, got {curvature}")
    uv, tri = lattice(w, h, spacing)
    if jitter:
        uv = jitter_lattice(uv, tri, jitter, np.random.default_rng(seed), border_u=w / 2, border_v=h / 2)
    return _make("saddle", Saddle(float(curvature)), RectDomain(w / 2, h / 2), uv, tri, spacing)


def on_plane(points, triangles, spacing: float) -> Surface:
    """Wrap an existing flat mesh in the XY plane (z = 0, e.g. ``TissueModel.from_patch``'s) as
    a Surface; its domain is the bounding rectangle of the points."""
    pts = np.asarray(points, dtype=np.float64)
    lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
    centre = 0.5 * (lo + hi)
    if np.abs(centre).max() > 1e-9 * max(1.0, np.abs(hi).max()):
        raise InputError("on_plane expects a mesh centred on the origin")
    domain = RectDomain(*(0.5 * (hi - lo)))
    return _make("plane", Plane(), domain, pts[:, :2], triangles, spacing)


def flipped_triangles(points, triangles, chart) -> np.ndarray:
    """Rows of triangles (t, 3) whose normal (points (n, 3) [m]) points against the chart's
    outward normal at the triangle's centroid (degenerate triangles are not counted)."""
    p = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    if not len(tri):
        return np.zeros(0, dtype=np.int64)
    centroid = p[tri].mean(axis=1)
    reference = chart.normal(chart.uv_of(centroid))
    cross = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
    return np.flatnonzero(np.einsum("ij,ij->i", cross, reference) < 0.0)


def trimesh_problems(points, triangles) -> list[str]:
    mesh = trimesh.Trimesh(points, triangles, process=False)
    problems = []
    if not mesh.is_winding_consistent:
        problems.append("trimesh_winding: trimesh finds the winding inconsistent")
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    if (counts > 2).any():
        problems.append(f"trimesh_edges: {int((counts > 2).sum())} edges used more than twice")
    return problems


def surface_problems(surface, *, tolerance: float = 1e-9) -> list[str]:
    """Why a generated Surface is not a valid skin mesh ([] if it is)."""
    pts, tri = surface.points, surface.triangles
    report = check_mesh(pts, tri, edges_of(tri), min_area=1e-6 * surface.spacing ** 2)
    problems = list(report.problems)
    flipped = flipped_triangles(pts, tri, surface.chart)
    if len(flipped):
        problems.append(f"tri_flipped: {len(flipped)} triangles against the analytic normal, "
                        f"first {flipped[:5].tolist()}")
    off = np.abs(surface.offset(pts)).max()
    if not off <= tolerance:
        problems.append(f"points_on_surface: a node lies {off:.3g} m off the analytic surface")
    problems += trimesh_problems(pts, tri)
    problems += [f"topology: {p}" for p in topology_problems(tri, len(pts), surface.border_loops)]
    return problems
