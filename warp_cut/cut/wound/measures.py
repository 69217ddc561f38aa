"""What a cut is judged by: the wound's width and its opening along each incision, how far its
lips lie from the tool's path, and how much of the tool's path in the skin the opened incision
covers.

Every function takes the current node positions [m], shape (node_count, 3), the model and
the incisions (``warp_cut.cut.curve.incision.Incision``) of a Cutter.
"""

from __future__ import annotations

import numpy as np

from ..classes import NodeClass
from ..curve.incision import Incision, polyline_distance
from ..curve.samples import closest_on_polyline

__all__ = ["incision_width", "gap_profile", "lip_deviation", "coverage", "path_coverage"]


def _live_pairs(inc: Incision, active: np.ndarray) -> np.ndarray:
    """(k, 2) paired lip nodes (left, right) of ``inc`` that are both alive."""
    pairs = inc.pairs()
    return pairs[active[pairs[:, 0]] & active[pairs[:, 1]]] if len(pairs) else pairs


def incision_width(incisions: list[Incision], model, positions: np.ndarray) -> float:
    """Median distance [m] between the paired lip nodes across the incisions (nan if none)."""
    widths = [np.linalg.norm(positions[p[:, 0]] - positions[p[:, 1]], axis=1)
              for p in (_live_pairs(inc, model.active) for inc in incisions) if len(p)]
    return float(np.median(np.concatenate(widths))) if widths else float("nan")


def gap_profile(incisions: list[Incision], model, positions: np.ndarray) -> dict:
    """The opening of every incision along its length: one row per interior station whose two
    lip nodes are alive. ``incision`` (k,) int: index into ``incisions``; ``arc_length_m`` (k,):
    the station's arc length u along the incision's curve [m]; ``gap_m`` (k,): the distance
    between the station's left and right lip nodes [m] (the pairs whose median is
    ``incision_width``)."""
    active = model.active
    rows = [(n, u, a, b) for n, inc in enumerate(incisions)
            for u, a, b in zip(inc.station_u, inc.left, inc.right)
            if a >= 0 and b >= 0 and active[a] and active[b]]
    index = np.array([r[0] for r in rows], dtype=np.int64)
    u = np.array([r[1] for r in rows], dtype=np.float64)
    pairs = np.array([r[2:] for r in rows], dtype=np.int64).reshape(-1, 2)
    x = np.asarray(positions, dtype=np.float64)
    gap = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1)
    return {"incision": index, "arc_length_m": u, "gap_m": gap}


def lip_deviation(incisions: list[Incision], model, positions: np.ndarray, *, in_plane: bool = True) -> float:
    """Largest distance [m] of a live lip node from the tool's contact path (a polyline of the
    crossings where the skin was when each was cut).

    Args:
        incisions: The incisions whose paths count.
        model: The TissueModel (node classes, liveness).
        positions: Current node positions [m], shape (node_count, 3).
        in_plane: Leave out the component along the skin's normal at the nearest path point
            (the incision's shape as seen on the skin); else the distance in 3D.
    """
    lips = np.flatnonzero(model.active & (model.node_class == NodeClass.LIP))
    paths = [inc for inc in incisions if len(inc.contact_path) > 1]
    if not len(lips) or not paths:
        return float("nan")
    x = np.asarray(positions, dtype=np.float64)[lips]
    best = np.full(len(lips), np.inf)
    for inc in paths:
        poly = np.asarray(inc.contact_path)
        k, t, closest, dist = closest_on_polyline(x, poly)
        if in_plane:
            normals = np.asarray(inc.contact_normals)
            n = (1.0 - t)[:, None] * normals[k] + t[:, None] * normals[k + 1]
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
            d = x - closest
            dist = np.linalg.norm(d - np.einsum("ij,ij->i", d, n)[:, None] * n, axis=1)
        best = np.minimum(best, dist)
    return float(best.max())


def coverage(incisions: list[Incision], model, positions: np.ndarray, trace: np.ndarray,
             tolerance: float) -> float:
    """Fraction of a path in the skin that the opened incisions cover.

    A sample of ``trace`` is covered when an opened stretch of incision passes within
    ``tolerance`` of it: a stretch between two consecutive stations whose lip pairs are both
    alive (or between the start or end node and the nearest pair; the end counts as open
    when the cut has reached the tissue's outer border) - the part of the curve where the
    skin is actually open.

    Args:
        incisions: The incisions of the cut.
        model: The TissueModel.
        positions: Current node positions [m], shape (node_count, 3) (unused for the curve,
            which is the incision's own; kept for symmetry with the other measures).
        trace: The tool's path in the skin [m], shape (k, 3), densely sampled.
        tolerance: Distance [m] within which a trace sample counts as covered.

    Returns:
        Covered fraction of the trace's length in [0, 1] (nan for an empty trace).
    """
    trace = np.asarray(trace, dtype=np.float64).reshape(-1, 3)
    if len(trace) < 2:
        return float("nan")
    covered = np.zeros(len(trace), dtype=bool)
    for inc in incisions:
        for a, b in _opened_stretches(inc, model.active):
            if b - a <= 0:
                continue
            curve = inc.point_at(np.linspace(a, b, max(2, int(np.ceil((b - a) / (0.25 * tolerance))) + 1)))
            covered |= polyline_distance(trace, curve) <= tolerance
    seg = np.linalg.norm(np.diff(trace, axis=0), axis=1)
    weight = np.concatenate([[0.0], seg]) * 0.5 + np.concatenate([seg, [0.0]]) * 0.5
    return float((weight * covered).sum() / weight.sum()) if weight.sum() > 0 else float("nan")


def path_coverage(incisions: list[Incision], model, positions: np.ndarray, tolerance: float) -> float:
    """Fraction of the tool's path in the skin (each incision's contact points, from where the
    blade entered) that the opened incisions cover within ``tolerance`` [m] (``coverage`` of
    each against its own path, weighted by its length); nan without a path."""
    cut = [inc for inc in incisions if len(inc.path) > 1]
    covered = [coverage([inc], model, positions, np.asarray(inc.path), tolerance) for inc in cut]
    lengths = [inc.length for inc in cut]
    return float(np.average(covered, weights=lengths)) if covered and sum(lengths) > 0 else float("nan")


def _opened_stretches(inc: Incision, active: np.ndarray) -> list[tuple[float, float]]:
    """Arc-length intervals [m] of ``inc`` along which both lips exist (the skin is open). A lip
    (or end node) the cut made that a later edit removed (an island taken out with its side of
    the slit, a later cut across it) stands for an opening there: open too."""
    u = np.asarray(inc.station_u)
    alive = np.array([a >= 0 and b >= 0 and (active[a] or active[b]) for a, b in zip(inc.left, inc.right)],
                     dtype=bool)
    start_ok = inc.start_node >= 0
    end_ok = inc.end_node >= 0 or inc.reached_border
    knots = ([0.0] if start_ok else []) + list(u[alive]) + ([inc.length] if end_ok else [])
    flags = ([True] if start_ok else []) + [True] * int(alive.sum()) + ([True] if end_ok else [])
    out = []
    for k in range(len(knots) - 1):
        if flags[k] and flags[k + 1] and _consecutive(inc, knots[k], knots[k + 1]):
            out.append((knots[k], knots[k + 1]))
    return out


def _consecutive(inc: Incision, a: float, b: float) -> bool:
    """True if no station lies strictly between arc lengths a and b (so a dead station in
    between breaks the stretch)."""
    u = np.asarray(inc.station_u)
    return not np.any((u > a + 1e-12) & (u < b - 1e-12))
