"""How well a cut followed a stroke: coverage, lip deviation, slivers, split incisions, holes.

Definitions (the measuring stick for cuts on curved and irregular skin):

* wound border - the edges of the live mesh that lie on exactly one live triangle and were
  not on the tissue's border when it was made (the lips of every incision, and the rims of
  holes left open).
* coverage - the fraction of the stroke's ideal in-skin trace (``Stroke.trace``, from where
  the tool axis enters the skin to where it leaves, cut into pieces of about ``spacing / 20``
  of arc length, sampled at their middles)
  at which the skin is open: a sample is covered when wound-border edges pass within
  ``tol`` of it strictly on both sides of the trace (left and right of the travel direction,
  so the trace beyond the end of a slit, where both sides' nearest point is the slit's end
  node, is not open). The test
  is made in the surface's parameter plane with the nodes' rest positions (where the cut made
  them), so neither sag nor the wound gaping moves the lips away: the question is whether
  the material was separated along the path. ``tol`` = 0.5 spacing + the lip offset
  (0.25 tool radius, ``CutSettings`` default): a lip pair straddles the cut at 0.25 r.
  Samples over no live triangle when the stroke began (at rest, in the parameter plane: an
  opening earlier strokes made, e.g. an island of skin three cuts cut out) are left out: the
  tool passes no skin there. nan if the whole trace is over such openings.
* curve coverage - the same fraction for "within ``tol`` of the stroke's incision paths"
  (the contact points the Cutter cut along).
* lip deviation - the 3D distance [m] of the lip nodes the stroke made (at their rest
  positions) from the trace polyline: max and median.
* slivers - triangles the stroke made that are live at its end with a smallest angle below
  10 deg (current positions).
"""

from __future__ import annotations

import math

import numpy as np

from ..cut.classes import NodeClass
from ..mesh.geometry import SLIVER_DEG, triangle_min_angles
from ..mesh.triangulate import border_loop_count as loops_of
from ..mesh.triangulate import boundary_edges

__all__ = ["original_border", "wound_edges", "skin_at_rest", "coverage", "curve_coverage", "lip_deviation",
           "new_slivers", "segment_distances", "border_loop_count"]

SIDE_FRACTION = 1e-9
"""A wound point counts as left (right) of the trace when it lies strictly (more than this
fraction of the spacing, a rounding margin) to that side: beyond the end of a slit the
closest wound point on either side is the slit's end node, on one side of the trace at most,
so the trace is not taken as open beyond the slit, while inside it the two lips are."""


def _keys(pairs: np.ndarray, n: int) -> np.ndarray:
    p = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    return p[:, 0] * np.int64(n) + p[:, 1]


def original_border(model) -> np.ndarray:
    """Keys (sorted pair i * N + j with N = 2**31) of the model's border edges now."""
    return _keys(boundary_edges(model.triangles), 2 ** 31)


def wound_edges(model, border_keys) -> np.ndarray:
    """Node pairs (e, 2) of the wound border: single-triangle edges not in ``border_keys``."""
    edges = boundary_edges(model.triangles)
    return edges[~np.isin(_keys(edges, 2 ** 31), border_keys)]


def segment_distances(points, a, b) -> tuple[np.ndarray, np.ndarray]:
    """For points (m, d) and segments a -> b (e, d): distances (m, e) and closest points (m, e, d)."""
    ab = b - a
    t = ((points[:, None, :] - a[None]) * ab[None]).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300)[None]
    closest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=-1), closest


def _trace_samples(stroke, spacing: float):
    """(uv samples (m, 2), unit travel directions in uv (m, 2)) at the middles of pieces of
    about spacing / 20 of arc length (so each sample stands for an equal length)."""
    count = max(1, math.ceil(stroke.length / (spacing / 20.0)))
    s = (np.arange(count) + 0.5) * (stroke.length / count)
    uv = np.column_stack([np.interp(s, stroke.arclength, stroke.path.uv[:, c]) for c in range(2)])
    d = np.gradient(uv, axis=0) if len(uv) > 1 else np.array([[1.0, 0.0]])
    return uv, d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)


def skin_at_rest(model, surface) -> np.ndarray:
    """The live triangles at their rest positions in the surface's parameter plane, (t, 3, 2)."""
    corners = model.triangles
    return surface.uv_of(model.points[corners.ravel()]).reshape(-1, 3, 2)


def _over_skin(uv: np.ndarray, skin: np.ndarray) -> np.ndarray:
    """Mask of the points ``uv`` (m, 2) inside (or on) any of the triangles ``skin`` (t, 3, 2)."""
    inside = np.zeros(len(uv), dtype=bool)
    a, b, c = skin[:, 0], skin[:, 1], skin[:, 2]

    def cross(p, q, r):  # (m, t): z of (q - p) x (r - p) for the points r
        return ((q - p)[None, :, 0] * (r[:, None, 1] - p[None, :, 1])
                - (q - p)[None, :, 1] * (r[:, None, 0] - p[None, :, 0]))

    for chunk in np.array_split(np.arange(len(uv)), max(1, len(uv) * len(skin) // 200_000)):
        s = np.stack([cross(a, b, uv[chunk]), cross(b, c, uv[chunk]), cross(c, a, uv[chunk])])
        inside[chunk] = (((s >= 0).all(axis=0)) | ((s <= 0).all(axis=0))).any(axis=1)
    return inside


def coverage(stroke, surface, rest_points, wound, tol: float, skin: np.ndarray | None = None,
             skin_now: np.ndarray | None = None) -> float:
    """Fraction of the trace open on both sides within ``tol`` [m] (see the module docstring).
    rest_points: node rest positions (n, 3) [m]; wound: (e, 2) wound-border node pairs; skin:
    ``skin_at_rest`` when the stroke began (None: the whole trace counts); skin_now:
    ``skin_at_rest`` after the stroke, where given a side with no skin ``tol`` away (an island
    the stroke freed and removed) counts as open."""
    uv, direction = _trace_samples(stroke, surface.spacing)
    if skin is not None:
        keep = _over_skin(uv, skin)
        if not keep.any():
            return float("nan")
        uv, direction = uv[keep], direction[keep]
    if not len(wound):
        return 0.0
    ends = surface.uv_of(np.asarray(rest_points)[wound.ravel()]).reshape(-1, 2, 2)
    covered = np.zeros(len(uv), dtype=bool)
    for chunk in np.array_split(np.arange(len(uv)), max(1, len(uv) // 256)):
        dist, closest = segment_distances(uv[chunk], ends[:, 0], ends[:, 1])
        rel = closest - uv[chunk][:, None, :]
        side = direction[chunk][:, None, 0] * rel[..., 1] - direction[chunk][:, None, 1] * rel[..., 0]
        near = dist <= tol
        eps = SIDE_FRACTION * surface.spacing
        left, right = (near & (side > eps)).any(axis=1), (near & (side < -eps)).any(axis=1)
        if skin_now is not None:
            across = np.stack([-direction[chunk][:, 1], direction[chunk][:, 0]], axis=1) * tol
            left |= ~_over_skin(uv[chunk] + across, skin_now)
            right |= ~_over_skin(uv[chunk] - across, skin_now)
        covered[chunk] = left & right
    return float(covered.mean())


def curve_coverage(stroke, surface, contact_paths, tol: float) -> float:
    """Fraction of the trace within ``tol`` [m] (parameter plane) of the contact polylines
    (list of (k, 3) [m]) of the stroke's incisions."""
    uv, _ = _trace_samples(stroke, surface.spacing)
    best = np.full(len(uv), np.inf)
    for path in contact_paths:
        p = surface.uv_of(np.asarray(path, dtype=np.float64).reshape(-1, 3))
        if len(p) == 1:
            p = np.repeat(p, 2, axis=0)
        best = np.minimum(best, segment_distances(uv, p[:-1], p[1:])[0].min(axis=1))
    return float((best <= tol).mean())


def lip_deviation(stroke, model, first_new_node: int) -> tuple[float, float, int]:
    """(max, median) distance [m] of the live lip nodes made since node slot ``first_new_node``
    (rest positions) from the trace polyline in 3D, and their count (nan, nan, 0 if none)."""
    nodes = np.arange(first_new_node, model.node_count)
    nodes = nodes[model.active[nodes] & (model.node_class[nodes] == NodeClass.LIP)]
    if not len(nodes):
        return float("nan"), float("nan"), 0
    dist = np.full(len(nodes), np.inf)
    trace = stroke.trace[:: max(1, len(stroke.trace) // 2000)]
    if not np.array_equal(trace[-1], stroke.trace[-1]):
        trace = np.vstack([trace, stroke.trace[-1]])
    for chunk in np.array_split(np.arange(len(nodes)), max(1, len(nodes) // 64)):
        dist[chunk] = segment_distances(model.points[nodes[chunk]], trace[:-1], trace[1:])[0].min(axis=1)
    return float(dist.max()), float(np.median(dist)), int(len(nodes))


def new_slivers(model, positions, first_new_triangle: int) -> tuple[int, float]:
    """(count of slivers, smallest angle [deg]) among the live triangles made since triangle
    slot ``first_new_triangle`` (nan angle if none)."""
    table = model.triangle_table
    slots = table.live_slots()
    rows = np.flatnonzero(slots >= first_new_triangle)
    if not len(rows):
        return 0, float("nan")
    angles = triangle_min_angles(positions, model.triangles[rows])
    return int((angles < SLIVER_DEG).sum()), float(angles.min())


def border_loop_count(model) -> int:
    """Connected pieces of the live mesh's border edges (border loops when none is pinched)."""
    return loops_of(model.triangles)
