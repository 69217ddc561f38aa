"""How well a cut followed a stroke: coverage, lip deviation, slivers, split incisions, holes.

Definitions (the measuring stick for cuts on curved and irregular skin):

* wound border - the edges of the live mesh that lie on exactly one live triangle and were
  not on the tissue's border when it was made (the lips of every incision, and the rims of
  holes left open).
* coverage - the fraction of the stroke's ideal in-skin trace (``Stroke.trace``, from where
  the tool axis enters the skin to where it leaves, cut into pieces of about ``spacing / 20``
  of arc length, sampled at their middles) at which the skin is open: a sample is covered when
  the segment across the trace through it (perpendicular to the travel direction, ``tol`` to
  either side) reaches a new opening - a place that is not skin now (no live triangle over it
  at rest) but was skin when the stroke began. The segment is cut where it crosses wound-border
  edges and each piece is tested at its middle, so a slit narrower than any sampling is found.
  Past the end of a slit the segment runs across intact skin (the slit's lips meet at its end
  node behind it): not open. An earlier wound's opening is not new: a stroke running beside an
  earlier wound is not counted open there. The test is made in the surface's parameter plane
  with the nodes' rest positions (where the cut made them), so neither sag nor the wound gaping
  moves the lips away: the question is whether the material was separated along the path.
  ``tol`` = 0.5 spacing + the lip offset (0.25 tool radius, ``CutSettings`` default): a slit
  up to half a spacing beside the trace (the tool pushed the skin aside as it cut) counts.
  Samples over no live triangle when the stroke began (at rest, in the parameter plane: an
  opening earlier strokes made, e.g. an island of skin three cuts cut out) are left out: the
  tool passes no skin there. nan if the whole trace is over such openings.
* curve coverage - the same fraction for "within ``tol`` of the stroke's incision paths"
  (the contact points the Cutter cut along).
* lip deviation - the 3D distance [m] of the lip nodes the stroke made (at their rest
  positions) from the trace polyline: max and median.
* slivers - triangles the stroke made that are live at its end with a smallest angle below
  10 deg (``SLIVER_DEG``) as the skin lies (current positions).
* rest slivers - the same triangles with a smallest angle below 20 deg (``MIN_ANGLE_DEG``, what
  the cut promises) in the rest shape (``model.points``): a rest sliver is a re-mesh defect, a
  sliver only as the skin lies was crushed (or made crushed) by the motion.
* small triangles - the same triangles with a rest edge shorter than 0.2 spacing
  (``SMALL_EDGE``), and the shortest rest edge: the angles may be good, yet a small relative
  motion crushes such a triangle as the skin lies.
"""

from __future__ import annotations

import math

import numpy as np

from ..cut.classes import NodeClass
from ..cut.tolerances import MIN_ANGLE_DEG
from ..mesh.geometry import SLIVER_DEG, triangle_min_angles
from ..mesh.triangulate import border_loop_count as loops_of
from ..mesh.triangulate import boundary_edges

__all__ = ["original_border", "wound_edges", "skin_at_rest", "in_plane", "coverage", "curve_coverage", "lip_deviation",
           "new_slivers", "new_rest_slivers", "new_rest_edges", "segment_distances", "border_loop_count"]

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
    """The live triangles at their rest positions in the surface's parameter plane, (t', 3, 2)
    (on a closed tube, those across the seam once more on its other side: ``in_plane``)."""
    return in_plane(surface, model.points[model.triangles])


def in_plane(surface, shapes: np.ndarray) -> np.ndarray:
    """Triangles or segments ``shapes`` (k, c, 3) [m] in the surface's parameter plane, (k', c, 2).

    Where v is periodic (a closed tube's ``RectDomain.period_v``), each shape's corners are
    brought within half a period of its first corner (one across the seam is not stretched
    over the whole plane), and a shape reaching past +-half a period is repeated one period
    over, so points near the seam on either side meet it."""
    k, c = shapes.shape[:2]
    uv = surface.uv_of(np.asarray(shapes, dtype=np.float64).reshape(-1, 3)).reshape(k, c, 2)
    period = getattr(surface.domain, "period_v", None)
    if not period or not k:
        return uv
    v = uv[..., 1]
    v -= period * np.round((v - v[:, :1]) / period)
    past = np.abs(v).max(axis=1) > 0.5 * period
    again = uv[past].copy()
    again[..., 1] -= period * np.sign(again[:, 0, 1])[:, None]
    return np.concatenate([uv, again])


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


def coverage(stroke, surface, rest_points, wound, tol: float, skin_now: np.ndarray,
             skin: np.ndarray | None = None) -> float:
    """Fraction of the trace at which a new opening lies within ``tol`` [m] across it (see the
    module docstring).

    Args:
        stroke: The stroke (its trace in the parameter plane).
        surface: The surface (its parameter plane).
        rest_points: Node rest positions (n, 3) [m].
        wound: (e, 2) wound-border node pairs (``wound_edges``).
        tol: Reach [m] to either side of the trace.
        skin_now: ``skin_at_rest`` after the stroke.
        skin: ``skin_at_rest`` when the stroke began (None: everywhere was skin).
    """
    uv, direction = _trace_samples(stroke, surface.spacing)
    if skin is not None:
        keep = _over_skin(uv, skin)
        if not keep.any():
            return float("nan")
        uv, direction = uv[keep], direction[keep]
    across = np.stack([-direction[:, 1], direction[:, 0]], axis=1) * tol
    ends = in_plane(surface, np.asarray(rest_points)[np.asarray(wound, dtype=np.int64).reshape(-1, 2)])
    chunks = np.array_split(np.arange(len(uv)), max(1, len(uv) // 256))
    found = [_piece_middles(uv[c] - across[c], uv[c] + across[c], ends) for c in chunks]
    sample = np.concatenate([c[j] for c, (j, _) in zip(chunks, found)])
    middles = np.concatenate([m for _, m in found])
    opening = ~_over_skin(middles, skin_now)
    if skin is not None:
        opening[opening] = _over_skin(middles[opening], skin)
    return float(np.bincount(sample[opening], minlength=len(uv)).astype(bool).mean())


def _piece_middles(a: np.ndarray, b: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The segments a -> b (m, 2) cut where they cross the segments ``edges`` (e, 2, 2): the
    middle of each piece, and of each whole segment, (k, 2), with its segment's index (k,)."""
    d = b - a
    cuts = [np.zeros((len(a), 0))]
    if len(edges):
        p, q = edges[:, 0], edges[:, 1]
        e = q - p
        denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # (m, e)
        ap = p[None] - a[:, None]
        ok = np.abs(denom) > 1e-300
        denom = np.where(ok, denom, 1.0)
        s = (ap[..., 0] * e[None, :, 1] - ap[..., 1] * e[None, :, 0]) / denom
        t = (ap[..., 0] * d[:, None, 1] - ap[..., 1] * d[:, None, 0]) / denom
        cuts.append(np.where(ok & (s >= 0) & (s <= 1) & (t >= 0) & (t <= 1), s, np.nan))
    cuts = np.sort(np.concatenate([np.zeros((len(a), 1)), *cuts, np.ones((len(a), 1))], axis=1), axis=1)
    mid = 0.5 * (cuts[:, :-1] + cuts[:, 1:])  # nan where a bound is (sorted last): dropped
    mid = np.concatenate([np.full((len(a), 1), 0.5), mid], axis=1)  # the sample itself
    sample, k = np.nonzero(np.isfinite(mid))
    return sample, a[sample] + mid[sample, k, None] * d[sample]


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


def _made_since(model, first_new_triangle: int) -> np.ndarray:
    """(t, 3) node slots of the live triangles in slots from ``first_new_triangle`` on."""
    return model.triangles[model.triangle_table.live_slots() >= first_new_triangle]


def new_slivers(model, positions, first_new_triangle: int, below: float = SLIVER_DEG) -> tuple[int, float]:
    """(count of triangles with a smallest angle under ``below`` [deg], smallest angle [deg])
    among the live triangles made since triangle slot ``first_new_triangle``, at ``positions``
    (n, 3) [m] (nan angle if none)."""
    triangles = _made_since(model, first_new_triangle)
    if not len(triangles):
        return 0, float("nan")
    angles = triangle_min_angles(positions, triangles)
    return int((angles < below).sum()), float(angles.min())


def new_rest_slivers(model, first_new_triangle: int) -> tuple[int, float]:
    """``new_slivers`` in the rest shape (``model.points``) against the cut's promise,
    ``MIN_ANGLE_DEG``: (count under it, smallest rest angle [deg])."""
    return new_slivers(model, model.points, first_new_triangle, below=MIN_ANGLE_DEG)


SMALL_EDGE = 0.2
"""A triangle a stroke made with a rest edge shorter than this [x spacing] is small: a relative
motion of its nodes that size crushes it as the skin lies, and its nodes are light."""


def new_rest_edges(model, first_new_triangle: int, spacing: float) -> tuple[int, float]:
    """(count of the live triangles made since triangle slot ``first_new_triangle`` with a rest
    edge shorter than ``SMALL_EDGE`` spacings, their shortest rest edge [x ``spacing``]; nan if
    none was made)."""
    triangles = _made_since(model, first_new_triangle)
    if not len(triangles):
        return 0, float("nan")
    corners = model.points[triangles]
    shortest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).min(axis=1) / spacing
    return int((shortest < SMALL_EDGE).sum()), float(shortest.min())


def border_loop_count(model) -> int:
    """Connected pieces of the live mesh's border edges (border loops when none is pinched)."""
    return loops_of(model.triangles)
