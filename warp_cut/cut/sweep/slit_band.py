"""The slit one event opens, as polygons of the rest surface: the band between the two lips.

The piece of rest curve an event cut runs over the tissue and, where it crosses an earlier wound
or runs off the tissue's edge, over openings. Its samples that lie in the tissue (inside a live
triangle, and a clearance ``edge`` away from every border) make runs; each run is the band of
the slit there: up its left lip line (+``lip_offset`` across the curve, one lip at each station),
round its front end, back down its right lip line, round its back end. A run's end is

* the slit's tip (the run reaches the cut's end in the tissue): a point on the curve;
* the incision's start (its first event, the blade having entered the tissue): a point on the
  curve, the start node;
* the incision's newest lip pair (an event continuing the slit): those two nodes, exactly, so
  the band closes onto the slit cut before;
* an opening (the run stops short of a border): the band's two lip lines go on until each meets
  that border, and the band's end there runs along the border between the two meeting points
  (through the border's nodes between them): band and opening join without a sliver of tissue.
  (Where a lip line meets no border within reach, the band just goes on past the run's end by
  the edge clearance and the lip offset, into the opening.)

The band's vertices are ``BandPoint``s: existing nodes (the pair), or new points the event makes
if they end up on the tissue's new border (lips, tip, start), or extension points in an opening
(never made). Stage 3 subtracts the band from the region (``warp_cut.cut.remesh.cut_piece``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from ...mesh.geometry import plane_frame
from ..curve.incision import Incision
from ..tolerances import FIRST_STATION, MIN_ANGLE_DEG, SNAP

__all__ = ["BandPoint", "Role", "SlitBand", "plan_band", "samples_to_cut", "EXTENSION", "TIP", "START", "JUNCTION",
           "CUT_BEFORE"]

class Role(IntEnum):
    """``BandPoint.station`` of a band point that is no lip (a lip's is its station's index,
    >= 0): the slit's start, its tip, an extension point into an opening, a node of the slit cut
    before (the newest lip pair, the old tip's outline), and a point where a lip line meets a
    border or a border node the band's end runs through. Negative, so ``station < 0`` asks
    whether a point is no lip."""

    START = -1
    TIP = -2
    EXTENSION = -3
    CUT_BEFORE = -4
    JUNCTION = -5


TIP, START, EXTENSION, CUT_BEFORE, JUNCTION = Role.TIP, Role.START, Role.EXTENSION, Role.CUT_BEFORE, Role.JUNCTION


@dataclass(frozen=True)
class BandPoint:
    """A vertex of the band: an existing node (``node`` >= 0), or a new point at ``rest`` [m]:
    a lip of station ``station`` on ``side`` (+1 left, -1 right), the tip (``TIP``, side 0), the
    start (``START``) or an extension into an opening (``EXTENSION``): a ``Role``."""

    rest: np.ndarray
    side: int
    station: int | Role
    u: float
    node: int = -1


@dataclass
class SlitBand:
    """The band of one event: its runs (each a closed ring of ``BandPoint``, the band on the
    right of the ring: left lip up, right lip down) and the arc lengths [m] of the stations its
    lips belong to (``BandPoint.station`` indexes them), increasing."""

    runs: list = field(default_factory=list)
    stations: list = field(default_factory=list)
    resumed_at: float | None = None
    """Arc length [m] where the last run begins at an opening's border (None: it goes on from
    the slit cut before or the start)."""
    strips: list = field(default_factory=list)
    """Polygons (m, 3) of rest points [m]: strips of tissue beside an opening the blade cuts off
    (``beside.strip_polygons``), taken out with the band."""


def runs_of(on_tissue: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) sample index of each run of True in ``on_tissue``."""
    out, start = [], None
    for k, inside in enumerate(on_tissue):
        if inside and start is None:
            start = k
        if not inside and start is not None:
            out.append((start, k - 1))
            start = None
    if start is not None:
        out.append((start, len(on_tissue) - 1))
    return out


def samples_to_cut(u: np.ndarray, on_tissue: np.ndarray, least: float) -> int:
    """How many of an event's samples ``u`` (k,) [m] (``on_tissue`` (k,) bool) to cut while the
    blade is still in the skin: all of them, or those before the last run when that run comes
    from an opening (it does not begin the piece) and reaches the tip shorter than ``least`` [m]:
    such a run could hold no lip pair, and a slit from an opening without one is a wedge the
    next event cannot go on from. The cut then stops in the opening and the run waits for the
    blade to be further on."""
    runs = runs_of(np.asarray(on_tissue, dtype=bool))
    if not runs:
        return len(u)
    first, last = runs[-1]
    if first == 0 or last != len(u) - 1 or u[last] - u[first] >= least:
        return len(u)
    return first


def _point(inc: Incision, u: float, side: int, station: int, node: int = -1) -> BandPoint:
    rest = inc.lip_position(u, side) if side != 0 else inc.point_at(u)[0]
    return BandPoint(np.asarray(rest, dtype=np.float64), side, station, float(u), node)


def _crossing(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[float, float] | None:
    """Parameters (t along a-b, w along p-q), both in [0, 1], where segment a-b (2,) crosses
    segment p-q (2,), or None."""
    r, s = b - a, q - p
    denom = r[0] * s[1] - r[1] * s[0]
    if abs(denom) <= 1e-300:
        return None
    rel = p - a
    t = (rel[0] * s[1] - rel[1] * s[0]) / denom
    w = (rel[0] * r[1] - rel[1] * r[0]) / denom
    return (float(t), float(w)) if 0.0 <= t <= 1.0 and 0.0 <= w <= 1.0 else None


def _meet(line: np.ndarray, borders: np.ndarray, flat) -> tuple[np.ndarray, int] | None:
    """(the point [m] (3,) on the border edge, the edge's row) where the polyline ``line`` (k, 3)
    first meets one of the border edges ``borders`` (e, 2, 3), in the plane map ``flat``; None if
    none. The point lies on the edge itself (not on the line, which may pass above or below it
    on a curved surface), so the band's end runs along the border in any chart."""
    if not len(borders):
        return None
    l2, b2 = flat(line), flat(borders)
    for k in range(len(line) - 1):
        best = None
        for e in range(len(borders)):
            hit = _crossing(l2[k], l2[k + 1], b2[e, 0], b2[e, 1])
            if hit is not None and (best is None or hit[0] < best[0]):
                best = (hit[0], hit[1], e)
        if best is not None:
            _, w, e = best
            return borders[e, 0] + w * (borders[e, 1] - borders[e, 0]), e
    return None


def _passing(line: np.ndarray, edges: np.ndarray, points: np.ndarray, flat, limit: float):
    """(the node's rest position (3,), a border edge's row at it) of the border node nearest the
    polyline ``line`` (k, 3) that it passes within ``limit`` [m] of without crossing a border
    (a lip line passing the tip of an earlier slit: the band's end closes on that tip); None if
    there is none."""
    nodes = np.unique(edges)
    l2, n2 = flat(line), flat(points[nodes])
    a, b = l2[:-1][None], l2[1:][None]                                   # (1, k-1, 2)
    d = b - a
    t = np.clip(np.sum((n2[:, None] - a) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    dist = np.linalg.norm(a + t[..., None] * d - n2[:, None], axis=-1).min(axis=1)  # (n,)
    k = int(np.argmin(dist))
    if dist[k] > limit:
        return None
    row = int(np.flatnonzero((edges == nodes[k]).any(axis=1))[0])
    return points[nodes[k]], row


def _border_chain(edges: np.ndarray, first: int, last: int) -> list[int] | None:
    """Nodes of the shortest path of border edges from edge ``first`` to edge ``last`` (rows of
    ``edges`` (e, 2) node pairs), starting at an end of ``first`` and ending at an end of
    ``last``; [] if they are the same edge; None if they do not join."""
    if first == last:
        return []
    graph: dict[int, set] = {}
    for a, b in edges:
        graph.setdefault(int(a), set()).add(int(b))
        graph.setdefault(int(b), set()).add(int(a))
    goal = {int(v) for v in edges[last]}
    paths = {int(v): [int(v)] for v in edges[first]}
    frontier = list(paths)
    while frontier:
        nxt = []
        for v in frontier:
            if v in goal:
                return paths[v]
            for w in graph.get(v, ()):
                if w not in paths:
                    paths[w] = paths[v] + [w]
                    nxt.append(w)
        frontier = nxt
    return None


def _snapped(meet: np.ndarray, edge: np.ndarray, points: np.ndarray, snap: float, u: float, side: int) -> BandPoint:
    """The band's point where a lip line meets border edge ``edge`` (2,) at ``meet`` (3,) [m]:
    the edge's nearer node if within ``snap`` [m] of it (node matching: no tiny edge beside
    it), else the meeting point itself."""
    d = np.linalg.norm(points[edge] - meet, axis=1)
    k = int(np.argmin(d))
    if d[k] <= snap:
        return BandPoint(points[edge[k]], side, JUNCTION, u, int(edge[k]))
    return BandPoint(meet, side, JUNCTION, u)


def _junction(inc: Incision, u0: float, direction: int, reach: float, borders, points: np.ndarray):
    """The band's end where it runs from arc length ``u0`` [m] in ``direction`` (-1 back, +1 on)
    out of the tissue into an opening: its lip lines' meeting points with the opening's border
    (``borders``: node pairs (e, 2) of border edges) and the border's nodes between them, as
    (left meeting, nodes from the right meeting's side to the left's, right meeting); None
    if a lip line meets no border within ``reach`` [m] or the two meet unjoined borders."""
    edges = np.asarray(borders, dtype=np.int64).reshape(-1, 2)
    if not len(edges):
        return None
    us = u0 + direction * np.linspace(0.0, reach, max(2, int(np.ceil(reach / (0.05 * inc.spacing))) + 1))
    normal = inc.normal_at(np.array([u0]))[0]
    e1, e2 = plane_frame(normal)

    def flat(x):
        return np.stack([x @ e1, x @ e2], axis=-1)

    segments = points[edges]
    meets = []
    for side in (1, -1):
        line = np.array([inc.lip_position(v, side) for v in us])
        hit = _meet(line, segments, flat) or _passing(line, edges, points, flat, reach / 3.0)
        if hit is None:
            return None
        meets.append(hit)
    (left, e_left), (right, e_right) = meets
    chain = _border_chain(edges, e_right, e_left)
    if chain is None:
        return None
    snap = SNAP * inc.spacing
    left_point = _snapped(left, edges[e_left], points, snap, u0, 1)
    right_point = _snapped(right, edges[e_right], points, snap, u0, -1)
    chain = [w for w in chain if w not in (left_point.node, right_point.node)]
    return left_point, chain, right_point


def plan_band(inc: Incision, u: np.ndarray, on_tissue: np.ndarray, *, stations: list[float],
              pair: tuple[int, int] | None, pair_u: float, start: int | None, start_possible: bool,
              extension: float, margin: float, points: np.ndarray, borders=()) -> SlitBand:
    """The band of an event cutting ``inc`` along the samples ``u`` (k,) [m] (the last one the
    tip's), ``on_tissue`` (k,) bool; ``stations``: arc lengths of the new stations of a run
    that goes on from the slit cut before or its start (a run from an opening has its own, from
    ``FIRST_STATION`` spacings past its first sample, as the incision's first run has; a run from
    the start into an opening, or from an opening to the tip, that none of them falls in gets
    one halfway); ``pair``:
    the incision's newest live lip pair (left, right) at ``pair_u`` [m], which the band closes
    onto when its first run starts at the piece's start, else None; ``start``: the start node
    (None: a new one, where the run starts at the incision's start and ``start_possible``);
    ``extension``: how far past a run's end in an opening the band goes at most [m]; ``margin``:
    no lip nearer an opening end than this [m]; ``points``: rest positions by node slot [m];
    ``borders``: node pairs (e, 2) of the tissue's border edges near (the incision's own slit
    left out), where a run's end in an opening meets them."""
    band = SlitBand()
    for first, last in runs_of(np.asarray(on_tissue, dtype=bool)):
        if first == last and 0 < first < len(u) - 1 or (first == last == 0 and pair is None and not start_possible):
            continue  # one sample between openings: no length of tissue to open
        ua, ub = float(u[first]), float(u[last])
        left, right = [], []
        wanted = stations
        to_tip = last == len(u) - 1
        if first == 0 and pair is not None:  # closes onto the slit cut before
            begins = "pair"
            left.append(BandPoint(points[pair[0]], 1, CUT_BEFORE, pair_u, pair[0]))
            right.append(BandPoint(points[pair[1]], -1, CUT_BEFORE, pair_u, pair[1]))
            lo = pair_u
        elif first == 0 and ua <= 1e-12 and start_possible:  # the incision's start
            begins = "start"
            left.append(_point(inc, 0.0, 0, START, -1 if start is None else start))
            lo = 0.0
        else:  # from an opening
            begins = "opening"
            band.resumed_at = ua
            left, right = _from_opening(inc, ua, extension, borders, points)
            lo = ua + margin
            wanted = inc.stations_from(ua + FIRST_STATION * inc.spacing, ub - margin)
        hi = ub if to_tip else ub - margin
        if not any(lo < s <= hi + 1e-12 for s in wanted):
            wanted = _station_halfway(begins, to_tip, ua, ub, lo, hi)
        for s in wanted:
            if lo < s <= hi + 1e-12:
                k = len(band.stations)
                band.stations.append(float(s))
                left.append(_point(inc, s, 1, k))
                right.append(_point(inc, s, -1, k))
        front = [_point(inc, ub, 0, TIP)] if to_tip else _into_opening(inc, ub, extension, borders, points)
        if _sliver_wedge(left, right, front):
            continue
        band.runs.append(left + front + right[::-1])
    return band


def _from_opening(inc: Incision, ua: float, extension: float, borders, points: np.ndarray) -> tuple[list, list]:
    """The left and right lip lines' first points of a run that begins at arc length ``ua`` [m]
    at an opening: where they meet its border (and the border's nodes between them, on the
    left), else ``extension`` [m] back into the opening."""
    back = _junction(inc, ua, -1, 3.0 * extension, borders, points)
    if back is None:
        return [_point(inc, ua - extension, 1, EXTENSION)], [_point(inc, ua - extension, -1, EXTENSION)]
    meet_left, chain, meet_right = back
    return [BandPoint(points[w], 0, JUNCTION, ua, w) for w in chain] + [meet_left], [meet_right]


def _into_opening(inc: Incision, ub: float, extension: float, borders, points: np.ndarray) -> list:
    """The front of a run that ends at arc length ``ub`` [m] in an opening, from its left lip
    line to its right: where they meet the opening's border, with the border's nodes between,
    else ``extension`` [m] on into the opening."""
    ahead = _junction(inc, ub, 1, 3.0 * extension, borders, points)
    if ahead is None:
        return [_point(inc, ub + extension, 1, EXTENSION), _point(inc, ub + extension, -1, EXTENSION)]
    meet_left, chain, meet_right = ahead
    return [meet_left] + [BandPoint(points[w], 0, JUNCTION, ub, w) for w in chain[::-1]] + [meet_right]


def _station_halfway(begins: str, to_tip: bool, ua: float, ub: float, lo: float, hi: float) -> list[float]:
    """The station [m] a run from ``ua`` to ``ub`` too short for any that falls due gets, so that
    its band has width (where both lip lines meet an opening's border at one node it has none
    without): from the incision's start into an opening, halfway but no nearer the opening than
    ``hi``; from an opening to the tip, halfway between ``lo`` (the margin past the opening) and
    the tip. None for other runs. ``begins``: "pair", "start" or "opening"."""
    if begins == "start" and not to_tip:
        return [min(0.5 * (ua + ub), hi)]
    if begins == "opening" and to_tip:
        return [0.5 * (lo + hi)]
    return []


def _sliver_wedge(left: list, right: list, front: list) -> bool:
    """True for a run from the incision's start into an opening without a lip pair whose
    wedge is sharper at the start than ``MIN_ANGLE_DEG``: no fill has a good triangle there
    (a thin blade's slit a few spacings from its start to an earlier wound). It is left for
    the next event, which cuts the rest of the incision."""
    if not left or left[0].station != START or len(left) > 1 or right or front[-1].station != JUNCTION:
        return False
    apex = left[0].rest
    a, b = front[0].rest - apex, front[-1].rest - apex
    cos = float(np.dot(a, b)) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) < MIN_ANGLE_DEG
