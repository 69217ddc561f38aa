"""Coarsening a refined fill: removing the points Delaunay refinement inserted closer together
than it needed.

Refinement splits a constraint edge that a point encroaches, and (in PythonCDT) a point across
a narrow opening encroaches too: round the narrow wedge at a thin slit's tip the split points on
one side encroach the other side's pieces, and the splits cascade down to the opening's width
(rest edges of 0.04 spacings, where nothing in the tissue needs them). ``coarsen`` takes such
points out again, one at a time, shortest edge first, wherever the triangles round the point
can be re-made without it at the target angle: the fill keeps its guarantee, with fewer and
larger triangles.

Shapes: points (n, 2) [m]; triangles (t, 3) indices into points, counter-clockwise.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
import pythoncdt as cdt

from ...mesh.geometry import half_edges
from ..chart import chart_min_angles, chart_signed_areas

__all__ = ["coarsen"]


def coarsen(points: np.ndarray, triangles: np.ndarray, first_inserted: int, short: float,
            min_angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The fill (``points`` (n, 2) [m], counter-clockwise ``triangles`` (t, 3)) without the
    inserted points (index >= ``first_inserted``) that have an edge shorter than ``short`` [m]
    and whose star can be re-triangulated with every angle at least ``min_angle_deg``, shortest
    edge first; a point is tried again only once the triangles round it have changed. A point on
    the outline goes only where it splits a straight piece of it (its two outline edges in
    line): the outline stays what it was. Returns the points left (the input's first, in their
    order) and the triangles."""
    if not _any_short_inserted_edge(points, triangles, first_inserted, short):
        return points, triangles  # the common fill: nothing to take out
    mesh = _Stars(points, triangles)
    queue = [(length, v) for v in range(first_inserted, len(points))
             if mesh.star[v] and (length := mesh.shortest_edge(v)) < short]
    heapq.heapify(queue)
    while queue:
        length, v = heapq.heappop(queue)
        if not mesh.star[v] or length != mesh.shortest_edge(v):
            continue  # gone, or its edges changed since it was queued (queued again then)
        made = _retriangulate_without(points, mesh.triangles_round(v), v, min_angle_deg)
        if made is None:
            continue
        for w in mesh.replace_star(v, made):
            if w >= first_inserted and (edge := mesh.shortest_edge(w)) < short:
                heapq.heappush(queue, (edge, w))
    return _compact(points, mesh.all_triangles(), mesh.alive())


def _any_short_inserted_edge(points: np.ndarray, triangles: np.ndarray, first_inserted: int, short: float) -> bool:
    """Whether an edge of the triangles with an inserted point at an end is shorter than
    ``short`` [m]."""
    ends = half_edges(np.asarray(triangles).reshape(-1, 3)).reshape(-1, 3, 2)
    lengths = np.linalg.norm(points[ends[..., 0]] - points[ends[..., 1]], axis=2)
    return bool(np.any((lengths < short) & (ends.max(axis=2) >= first_inserted)))


class _Stars:
    """Triangles by id, and the ids of the triangles round each point, updated as stars are
    re-made."""

    def __init__(self, points: np.ndarray, triangles: np.ndarray):
        self._xy = np.asarray(points, dtype=np.float64).tolist()
        self.triangles: dict[int, tuple[int, int, int]] = {}
        self.star: list[set[int]] = [set() for _ in range(len(points))]
        self.removed: set[int] = set()
        self._next = 0
        self._add(np.asarray(triangles, dtype=np.int64).tolist())

    def _add(self, triangles) -> None:
        for corners in triangles:
            self.triangles[self._next] = tuple(int(c) for c in corners)
            for c in corners:
                self.star[int(c)].add(self._next)
            self._next += 1

    def triangles_round(self, v: int) -> np.ndarray:
        """The triangles (k, 3) round point ``v``."""
        return np.array([self.triangles[t] for t in self.star[v]], dtype=np.int64)

    def shortest_edge(self, v: int) -> float:
        """Length [m] of point ``v``'s shortest edge."""
        x, y = self._xy[v]
        return min(math.hypot(self._xy[c][0] - x, self._xy[c][1] - y)
                   for t in self.star[v] for c in self.triangles[t] if c != v)

    def replace_star(self, v: int, made: np.ndarray) -> set[int]:
        """Put ``made`` (k, 3) in place of the triangles round ``v`` (``v`` goes); returns the
        points round it, whose stars changed."""
        link = set()
        for t in self.star[v]:
            for c in self.triangles.pop(t):
                if c != v:
                    self.star[c].discard(t)
                    link.add(c)
        self.star[v] = set()
        self.removed.add(v)
        self._add(made.tolist())
        return link

    def all_triangles(self) -> np.ndarray:
        return np.array(list(self.triangles.values()), dtype=np.int64).reshape(-1, 3)

    def alive(self) -> np.ndarray:
        """Which points are left, (n,) bool (all but those whose stars were re-made without them)."""
        out = np.ones(len(self._xy), dtype=bool)
        out[sorted(self.removed)] = False
        return out


def _retriangulate_without(points: np.ndarray, star: np.ndarray, v: int, min_angle_deg: float) -> np.ndarray | None:
    """Counter-clockwise triangles (k, 3) covering ``star`` (the triangles round point ``v``)
    without ``v``, every angle at least ``min_angle_deg``; None if there are none such (``v``
    at a corner of the outline, or the triangles would be worse)."""
    link = _link(star, v)
    if link is None:
        return None
    ring, closed = link
    if len(ring) < 3 or not closed and not _in_line(points[ring[-1]], points[v], points[ring[0]]):
        return None
    polygon = points[ring]
    tri = cdt.Triangulation(cdt.VertexInsertionOrder.AUTO, cdt.IntersectingConstraintEdges.NOT_ALLOWED, 0.0)
    try:
        tri.insert_vertices(np.ascontiguousarray(polygon))
        tri.insert_edges(np.array([(k, (k + 1) % len(ring)) for k in range(len(ring))], dtype=np.uintc))
        tri.erase_outer_triangles()
    except RuntimeError:  # a degenerate link (points repeated or crossing)
        return None
    local = np.asarray(tri.triangles_array()["vertices"], dtype=np.int64).reshape(-1, 3)
    if len(local) != len(star) - (2 if closed else 1):
        return None
    made = np.asarray(ring)[local]
    if chart_min_angles(points, made).min() < min_angle_deg or np.any(chart_signed_areas(points, made) <= 0.0):
        return None
    return made


def _link(star: np.ndarray, v: int) -> tuple[list[int], bool] | None:
    """The star's outer edges (those not touching ``v``) chained counter-clockwise: (the points
    in order, whether they close on themselves: ``v`` inside; else ``v`` lies on the outline
    between the chain's last point and its first). None if they do not form one chain."""
    after: dict[int, int] = {}
    for a, b, c in star.tolist():
        k = (a, b, c).index(v)
        p, q = (a, b, c)[(k + 1) % 3], (a, b, c)[(k + 2) % 3]
        if p in after:
            return None
        after[p] = q
    starts = set(after) - set(after.values())
    if len(starts) > 1:
        return None
    first = starts.pop() if starts else next(iter(after))
    ring = [first]
    while ring[-1] in after and len(ring) <= len(after):
        nxt = after[ring[-1]]
        if nxt == first:
            return ring, True
        ring.append(nxt)
    return (ring, False) if len(ring) == len(after) + 1 else None


def _in_line(a: np.ndarray, v: np.ndarray, b: np.ndarray) -> bool:
    """``v`` lies on the segment from ``a`` to ``b`` (to rounding)."""
    ab, av = b - a, v - a
    scale = float(ab @ ab)
    return abs(ab[0] * av[1] - ab[1] * av[0]) <= 1e-9 * scale and 0.0 < av @ ab < scale


def _compact(points: np.ndarray, triangles: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points left and the triangles renumbered onto them."""
    new_index = np.cumsum(alive) - 1
    return points[alive], new_index[triangles]
