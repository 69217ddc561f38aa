"""Filling a region of the chart with triangles of a guaranteed smallest angle.

The region to fill is given by its outline: the edges of closed loops of vertex indices (the outer
border and the holes, in any orientation) and vertices inside it. A constrained Delaunay triangulation of
the loops (their edges kept), refined by inserting points until no triangle has an angle under
the target (Delaunay refinement, Ruppert / Chew), is made by CDT (PythonCDT: robust predicates,
C++; MPL-2.0). Refinement may split a constraint edge that a new point encroaches; which edges it
split is reported, so that the caller can refuse splits of edges it shares with the mesh outside
the region (it then grows the region and fills again). Inserted points closer together than the
caller needs are taken out again where the fill keeps its angle without them (``coarsen``).

Shapes: points (n, 2) [m]; triangles (t, 3) indices into the returned points, counter-clockwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pythoncdt as cdt

from ...errors import InputError
from ...mesh.geometry import half_edges
from ..chart import chart_min_angles, chart_signed_areas
from .coarsen import coarsen

__all__ = ["Fill", "fill_region"]


@dataclass
class Fill:
    """A filled region.

    Attributes:
        points: Every vertex [m], (n, 2): the input vertices first (same indices), then the
            points the refinement inserted.
        triangles: Counter-clockwise triangles, (t, 3) indices into ``points``.
        split_edges: Input constraint edges the refinement or a crossing split, as sorted
            pairs (i, j) of input indices.
        unrefined: Triangles left under the target angle (at a sharp corner of the outline,
            or where an edge would have become shorter than the least length).
        input_count: How many of ``points`` were given (the rest were inserted).
    """

    points: np.ndarray
    triangles: np.ndarray
    split_edges: set = field(default_factory=set)
    unrefined: int = 0
    input_count: int = 0
    """How many of ``points`` were given (the rest were inserted)."""
    reasons: dict = field(default_factory=dict)
    """Why the refinement left triangles as they were: reason -> count (PythonCDT's ``Unrefined``)."""


def _constraint_edges(edges) -> np.ndarray:
    """The distinct undirected edges (e, 2) of (a, b) vertex pairs."""
    unique = {tuple(sorted((int(a), int(b)))) for a, b in edges if a != b}
    return np.array(sorted(unique), dtype=np.uintc).reshape(-1, 2)


def fill_region(points: np.ndarray, edges, *, min_angle_deg: float, min_edge: float,
                max_points: int = 2000, coarsen_below: float | None = None) -> Fill:
    """Fill the region bounded by the closed loops ``edges`` make ((a, b) pairs of indices into
    ``points`` (n, 2) [m], in any direction; points on no edge are inside the region and are
    kept) with counter-clockwise triangles
    whose angles are at least ``min_angle_deg`` where the outline allows, inserting at most
    ``max_points`` points, none making an edge shorter than ``min_edge`` [m]; then the inserted
    points with an edge shorter than ``coarsen_below`` [m] are taken out where the triangles
    round them can be re-made at ``min_angle_deg`` without them (``coarsen.coarsen``; None:
    none are).

    Raises:
        InputError: The loops do not bound a region (no triangle left), or cross where they
            cannot be split (loops that cross are split at the crossing and filled by parity).
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    edges = _constraint_edges(edges)
    tri = cdt.Triangulation(cdt.VertexInsertionOrder.AUTO, cdt.IntersectingConstraintEdges.TRY_RESOLVE, 0.0)
    try:
        tri.insert_vertices(points)
        tri.insert_edges(edges)
    except RuntimeError as err:  # PythonCDT: duplicate points, constraint edges that cross
        raise InputError(f"the region's outline is not a set of simple loops: {err}") from err
    erase = tri.collect_outer_triangles_and_holes()
    why = tri.refine_triangles(max_points, cdt.RefinementCriterion.SMALLEST_ANGLE, cdt.deg_to_rad(min_angle_deg),
                               erase, min_edge)
    tri.finalize_triangulation(erase)
    vertices = tri.vertices_array()
    out = np.stack([vertices["x"], vertices["y"]], axis=1)
    triangles = np.asarray(tri.triangles_array()["vertices"], dtype=np.int64).reshape(-1, 3)
    if not len(triangles):
        raise InputError("the region to fill has no area")
    triangles = _counter_clockwise(out, triangles)
    split = {tuple(sorted((e.v1, e.v2))) for originals in tri.piece_to_originals.values() for e in originals}
    unrefined = len(tri.find_unrefined_triangles(cdt.RefinementCriterion.SMALLEST_ANGLE,
                                                 cdt.deg_to_rad(min_angle_deg)))
    if coarsen_below is not None and len(out) > len(points):
        count = len(out)
        out, triangles = coarsen(out, triangles, len(points), coarsen_below, min_angle_deg)
        if len(out) < count:
            split -= _edges_of(triangles)  # an edge whose split points all went is whole again
            unrefined = int((chart_min_angles(out, triangles) < min_angle_deg).sum())
    reasons = {name: getattr(why, name) for name in ("short_edge_triangles", "circumcenter_outside",
                                                      "circumcenter_on_vertex", "sharp_fixed_corner", "short_edges",
                                                      "split_vertex_invalid") if getattr(why, name)}
    return Fill(out, triangles, {(int(a), int(b)) for a, b in split}, unrefined, len(points), reasons)


def _edges_of(triangles: np.ndarray) -> set:
    """The sorted vertex pairs of the triangles' edges."""
    pairs = np.sort(half_edges(triangles), axis=1)
    return {(int(a), int(b)) for a, b in pairs}


def _counter_clockwise(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The triangles wound counter-clockwise in the chart."""
    out = triangles.copy()
    flip = chart_signed_areas(points, triangles) < 0
    out[flip] = out[flip][:, [0, 2, 1]]
    return out
