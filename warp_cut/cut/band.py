"""The slit one event opens, as chains of lip nodes joined to the region's outline.

The incision's slit, seen from the tissue, is one walk round it: up the left lip (u increasing,
the tissue on the left), round the tip, back down the right lip. Its points have the slit
coordinate

    theta = u on the left lip,   theta = L at the tip,   theta = 2 L - u on the right lip

(L the curve's length, the tip's arc length). In one event the walk meets the region's outline
where the swept band left gaps in it (``region.Gap``: an earlier wound, the tissue's edge, the
incision's own tip of the previous event): the walk *leaves* the tissue into the node after a
gap and *comes back* from the node before it. The node's side of the curve and its arc length
give the theta of each such meeting, so the walk is cut into pieces, each from a node it comes
back from to the next node it leaves into; along each piece lie the lip nodes of the stations
in it, the tip, and the incision's start node when the walk goes round the start (a cut that
starts in the tissue). Every case is the same rule:

* continuing an incision: the old tip's gap, from the last left lip to the last right lip;
* a first event in the tissue: no gap, one closed walk round the start node;
* starting in an earlier wound (a T), crossing one (an X), ending on one (an excision's second
  arc), running along one or reaching the tissue's edge: the gaps on those borders.

The pieces are returned as directed edges between node ids (existing nodes, >= 0) and new
points (< 0, ``NewPoint``), ready to be joined to the kept outline edges.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .incision import Incision
from .region import Gap

__all__ = ["NewPoint", "Walk", "walk_the_slit"]


@dataclass(frozen=True)
class NewPoint:
    """A node the slit needs: a lip of station ``station`` on ``side`` (+1 left, -1 right), the
    tip (side 0, station -2) or the start (side 0, station -1), at rest position ``rest`` [m]."""

    rest: np.ndarray
    side: int
    station: int
    u: float


@dataclass
class Walk:
    """The slit of one event.

    Attributes:
        edges: Directed edges (a, b) of the walk's pieces, the tissue on their left; a node id
            >= 0 is an existing node, -1 - k the new point ``points[k]``.
        points: The new points (lips, tip, start).
        stations: Arc lengths u [m] of the new stations, in order (``NewPoint.station`` indexes
            them).
        closed: True if the walk goes round the start node (a first event in the tissue).
    """

    edges: list = field(default_factory=list)
    points: list = field(default_factory=list)
    stations: list = field(default_factory=list)
    closed: bool = False


@dataclass(frozen=True)
class _Meeting:
    theta: float
    node: int
    leaves: bool
    """The walk leaves the tissue into ``node`` (else it comes back from it)."""


@dataclass(frozen=True)
class _Mark:
    theta: float
    side: int
    station: int


def _meetings(inc: Incision, gaps: list[Gap], points: np.ndarray, length: float) -> list[_Meeting]:
    """Where the walk meets the outline: for each gap, it comes back from the node before it and
    leaves into the node after it, at the theta of each node's closest curve point; by theta.
    The gap of the incision's own old tip lies between its own two lips (the slit's border
    runs up the left lip to the tip and back down the right), whatever their projections say:
    they lie so near the curve that a refit of it may move them across."""
    out = []
    for gap in gaps:
        nodes = np.array([gap.before, gap.after])
        u, side, _ = inc.project(points[nodes])
        if inc.tip_node >= 0 and inc.tip_node in gap.nodes:
            side = np.array([1, -1])
        u = np.clip(u, 0.0, length)  # a node ahead of the tip meets the walk at the tip
        theta = np.where(side > 0, u, 2.0 * length - u)
        out.append(_Meeting(float(theta[0]), gap.before, False))
        out.append(_Meeting(float(theta[1]), gap.after, True))
    return sorted(out, key=lambda m: m.theta)


def _marks(length: float, stations: list[float]) -> list[_Mark]:
    """The possible new points of the walk by theta: the start (0), the new stations' left lips,
    the tip (L), their right lips."""
    marks = [_Mark(0.0, 0, -1), _Mark(length, 0, -2)]
    for k, u in enumerate(stations):
        marks += [_Mark(u, 1, k), _Mark(2.0 * length - u, -1, k)]
    return sorted(marks, key=lambda m: m.theta)


def _pieces(meetings: list[_Meeting], length: float) -> list[tuple[_Meeting, _Meeting, float, float]] | None:
    """(comes back from, leaves into, theta from, theta to) of each piece of the walk (theta to
    past 2 L where the piece goes round the start); None unless the meetings alternate."""
    k = next((i for i, m in enumerate(meetings) if not m.leaves), None)
    if k is None:
        return None
    ring = meetings[k:] + meetings[:k]
    if any(m.leaves != (i % 2 == 1) for i, m in enumerate(ring)):
        return None
    out = []
    for back, leave in zip(ring[0::2], ring[1::2]):
        hi = leave.theta if leave.theta > back.theta else leave.theta + 2.0 * length
        out.append((back, leave, back.theta, hi))
    return out


def _mark_u(mark: _Mark, length: float) -> float:
    """The arc length [m] of a mark: theta on the left lip and at the tip, 2 L - theta on the
    right, 0 at the start."""
    if mark.station == -1:
        return 0.0
    return mark.theta if mark.side > 0 or mark.station == -2 else 2.0 * length - mark.theta


def _mark_rest(inc: Incision, mark: _Mark, length: float) -> np.ndarray:
    """Rest position [m] (3,) of a mark's point: a lip beside the curve, the tip or start on it."""
    u = _mark_u(mark, length)
    rest = inc.lip_position(u, mark.side) if mark.side != 0 else inc.point_at(u)[0]
    return np.asarray(rest, dtype=np.float64)


def _clear_of(point: np.ndarray, nodes: np.ndarray, margin: float) -> bool:
    """True if ``point`` (3,) lies farther than ``margin`` [m] from each of ``nodes`` (k, 3)."""
    return bool(np.all(np.linalg.norm(nodes - point, axis=1) > margin))


def walk_the_slit(inc: Incision, gaps: list[Gap], points: np.ndarray, *, stations: list[float],
                  margin: float, start_possible: bool, start: int | None = None,
                  length: float | None = None) -> Walk | None:
    """The slit of an event: ``gaps`` in the region's outline (``points`` (n, 3): rest positions
    [m] by node slot), the arc lengths ``stations`` [m] of the new stations, no new point nearer
    than ``margin`` [m] to a node the walk meets at either end of its piece. ``start_possible``: the walk may go
    round the incision's start, through ``start`` (its node) or a new point there if None;
    ``length``: the arc length [m] the slit is cut to, its tip (default the curve's length). None
    if the gaps do not make a walk (they do not alternate round the slit, or a piece would need
    a start there is not)."""
    length = inc.length if length is None else float(length)
    marks = _marks(length, stations)
    walk = Walk(stations=list(stations))
    made: dict[tuple[int, int], int] = {}

    def point_of(mark: _Mark) -> int:
        if mark.station == -1 and start is not None:
            return start
        key = (mark.side, mark.station)
        if key not in made:
            walk.points.append(NewPoint(_mark_rest(inc, mark, length), mark.side, mark.station,
                                        _mark_u(mark, length)))
            made[key] = -len(walk.points)
        return made[key]

    meetings = _meetings(inc, gaps, points, length)
    if not meetings:  # one closed walk round the start
        if not start_possible:
            return None
        ids = [point_of(m) for m in marks]
        walk.edges = [(a, b) for a, b in zip(ids, ids[1:] + ids[:1]) if a != b]
        walk.closed = True
        return walk
    pieces = _pieces(meetings, length)
    if pieces is None:
        return None
    for back, leave, lo, hi in pieces:
        ends = points[[back.node, leave.node]]
        inner = [m for _, m in sorted(((m.theta + shift, m) for shift in (0.0, 2.0 * length) for m in marks
                                       if lo < m.theta + shift < hi), key=lambda tm: tm[0])]
        inner = [m for m in inner if _clear_of(_mark_rest(inc, m, length), ends, margin)]
        if any(m.station == -1 for m in inner):
            if not start_possible:
                return None
            walk.closed = True
        ids = [back.node] + [point_of(m) for m in inner] + [leave.node]
        walk.edges.extend((a, b) for a, b in zip(ids[:-1], ids[1:]) if a != b)
    return walk
