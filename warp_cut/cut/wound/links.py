"""The residual links a cut makes across its wound (SPEC section 1), and where they go when a
later edit takes one of their nodes.

Every spring of the tissue as it was built that an incision's rest curve crosses leaves one
residual-stress link (paper Eq. 4: force sigma_r x thickness x the spring's rest length), one
however many incisions cross it (a spring's tension is released once), so the links of a wound
depend on the curves alone, not on how often the cut ran or how the region was re-meshed.
The tissue's springs are kept in a grid of their rest midpoints (``OriginalSprings``), so an
event finds those its piece of curve crosses in what it touches.

A crossed spring whose two nodes survive on either side of the curve is joined by its link
directly. Otherwise the link joins the lip pair of the station nearest where the spring crossed;
where no pair is near yet (the tip of the slit), it waits (``Incision.pending_links``) for the
next station, and at the incision's end goes to the nearest pair. A link whose node a later edit
deletes is carried to the node nearest the deleted one's rest position on its side of that
edit's incision that no spring joins to the link's other end (``carry_links``), and is lost
only where no such node is left.
"""

from __future__ import annotations

import numpy as np

from ..chart import RegionChart
from ..curve.incision import Incision
from ..tolerances import LINK_REACH, LINK_TAKER_MASS
from ..topology import EditReport, TopologyEditor

__all__ = ["OriginalSprings", "link_crossed_springs", "settle_pending_links", "carry_links"]


class OriginalSprings:
    """The tissue's springs as built: node pairs (s, 2), rest lengths (s,) [m] and rest end
    points, in a uniform grid of their midpoints (cell: the longest spring)."""

    def __init__(self, model):
        self.pairs = model.springs.copy()
        self.rest_lengths = model.rest_lengths.copy()
        points = model.points
        self.a, self.b = points[self.pairs[:, 0]].copy(), points[self.pairs[:, 1]].copy()
        lengths = np.linalg.norm(self.b - self.a, axis=1)
        self.cell = float(max(lengths.max(), 1e-9)) if len(lengths) else 1.0
        keys = self._keys(0.5 * (self.a + self.b))
        self.order = np.lexsort(keys.T[::-1])  # by x cell, then y, then z
        self.sorted_keys = keys[self.order]
        self._sorted_x = np.ascontiguousarray(self.sorted_keys[:, 0])

    def _keys(self, points: np.ndarray) -> np.ndarray:
        return np.floor(points / self.cell).astype(np.int64)

    def near(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices of the springs whose midpoint lies in the grid cells of the box [lo, hi] [m]
        grown by one cell."""
        if not len(self.pairs):
            return np.zeros(0, np.int64)
        k_lo, k_hi = self._keys(np.asarray(lo)) - 1, self._keys(np.asarray(hi)) + 1
        # the rows are sorted by x cell first: only the slab of x cells in the box can hold any
        first = int(np.searchsorted(self._sorted_x, k_lo[0], side="left"))
        last = int(np.searchsorted(self._sorted_x, k_hi[0], side="right"))
        keys = self.sorted_keys[first:last]
        inside = np.all((keys >= k_lo) & (keys <= k_hi), axis=1)
        return self.order[first:last][inside]


def _crossings(springs: OriginalSprings, piece: np.ndarray, normal: np.ndarray):
    """(spring indices (m,), crossing points [m] (m, 3)) of the springs whose rest segment
    crosses the polyline ``piece`` (k, 3), in the tangent plane of normal ``normal``."""
    lo, hi = piece.min(axis=0), piece.max(axis=0)
    cand = springs.near(lo, hi)
    if not len(cand) or len(piece) < 2:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    chart = RegionChart(piece.mean(axis=0), normal)
    p, q = chart.to2d(springs.a[cand]), chart.to2d(springs.b[cand])  # (m, 2)
    c2 = chart.to2d(piece)
    c, d = c2[:-1], c2[1:]  # (k, 2)

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    r, s = (q - p)[:, None, :], (d - c)[None, :, :]
    denom = cross(r, s)
    rel = c[None] - p[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross(rel, s) / denom
        w = cross(rel, r) / denom
    hit = (np.abs(denom) > 0) & (t >= 0) & (t < 1) & (w >= 0) & (w < 1)
    rows, cols = np.nonzero(hit)
    rows, first = np.unique(rows, return_index=True)
    t_hit = t[rows, cols[first]]
    points = springs.a[cand[rows]] + t_hit[:, None] * (springs.b[cand[rows]] - springs.a[cand[rows]])
    return cand[rows], points


def link_crossed_springs(editor: TopologyEditor, inc: Incision, springs: OriginalSprings, piece: np.ndarray,
                         seen: set) -> None:
    """Make the links of the tissue's springs that ``piece`` (k, 3) [m] of ``inc``'s rest curve
    crosses (each once, whatever incision crossed it before: ``seen`` holds those already
    linked; a spring's tension is released once): directly between
    its nodes where both live on either side of the curve, else between the lip pair nearest
    where it crossed, or pending until there is one. Part of an edit begun on ``editor``."""
    normal = inc.normal_at(inc.project(piece.mean(axis=0)[None])[0])[0]
    crossed, points = _crossings(springs, piece, normal)
    fresh = [(k, x) for k, x in zip(crossed.tolist(), points) if k not in seen]
    if not fresh:
        return
    seen.update(k for k, _ in fresh)
    active = editor.model.active
    ends = springs.pairs[[k for k, _ in fresh]].tolist()
    live = [row for row, (i, j) in enumerate(ends) if active[i] and active[j]]
    apart = set()
    if live:  # which live pairs lie on either side of the curve: one projection for all their ends
        sides = inc.project(editor.model.points[np.array([ends[row] for row in live]).reshape(-1)])[1]
        apart = {row for row, (a, b) in zip(live, sides.reshape(-1, 2)) if a != b}
    direct, direct_rest, waiting = [], [], []
    for row, (k, x) in enumerate(fresh):
        if row in apart:
            direct.append(tuple(ends[row]))
            direct_rest.append(springs.rest_lengths[k])
        else:
            waiting.append((k, x))
    if waiting:  # where along the curve each crossed, to find its lip pair later
        crossing_u = inc.project(np.array([x for _, x in waiting]))[0]
        inc.pending_links += [(float(u), float(springs.rest_lengths[k])) for (k, _), u in zip(waiting, crossing_u)]
    editor.make_links(direct, direct_rest, once_per_pair=False)
    settle_pending_links(editor, inc, reach=LINK_REACH * inc.spacing)


def settle_pending_links(editor: TopologyEditor, inc: Incision, reach: float) -> None:
    """Give each pending link the live lip pair of the station nearest where its spring crossed,
    if one lies within ``reach`` [m] of it along the curve (``np.inf``: the nearest there is)."""
    if not inc.pending_links:
        return
    active = editor.model.active
    live = [(u, a, b) for u, a, b in zip(inc.station_u, inc.left, inc.right)
            if a >= 0 and b >= 0 and active[a] and active[b]]
    if not live:
        return
    u_pairs = np.array([u for u, _, _ in live])
    pairs, rest, waiting = [], [], []
    for u, length in inc.pending_links:
        k = int(np.argmin(np.abs(u_pairs - u)))
        if abs(u_pairs[k] - u) <= reach:
            pairs.append(live[k][1:])
            rest.append(length)
        else:
            waiting.append((u, length))
    inc.pending_links = waiting
    editor.make_links(pairs, rest, once_per_pair=False)


def _link_takers(model, candidates) -> np.ndarray:
    """The live nodes of ``candidates`` that may take a carried link (sorted): those not much
    lighter than the others (``LINK_TAKER_MASS``)."""
    nodes = np.array(sorted({int(v) for v in candidates if model.active[int(v)]}), dtype=np.int64)
    if not len(nodes):
        return nodes
    masses = model.masses[nodes]
    return nodes[masses >= LINK_TAKER_MASS * np.median(masses)]


def carry_links(editor: TopologyEditor, inc: Incision | None, report: EditReport, candidates, reach: float) -> int:
    """Carry the links an edit orphaned (one node deleted) or severed (both) to the live node of
    ``candidates`` nearest each deleted node's rest position, on the same side of ``inc``'s curve
    (any side without an incision), within ``reach`` [m] and not joined by a spring to the
    link's other end (a link pulls across a wound: along a spring it would crush the triangles
    on it); only candidates weighing at least ``LINK_TAKER_MASS`` of the candidates' median
    mass take one. Returns how many were lost."""
    model = editor.model
    nodes = _link_takers(model, candidates)
    gone_nodes = sorted({link.gone for link in report.orphaned_links}
                        | {v for link in report.severed_links for v in (link.i, link.j)})
    if inc is not None and len(nodes):  # one projection for the takers and the deleted nodes
        both = inc.project(model.points[np.concatenate([nodes, np.array(gone_nodes, dtype=np.int64)])])[1]
        sides, gone_side = both[:len(nodes)], dict(zip(gone_nodes, both[len(nodes):].tolist()))
    else:
        sides, gone_side = np.zeros(len(nodes)), {}
    lost = 0

    def taking(gone: int, partner: int) -> int:
        """The node taking ``gone``'s end of a link whose other end is ``partner`` (-1: none yet)."""
        if not len(nodes):
            return -1
        x = model.points[gone]
        dist = np.linalg.norm(model.points[nodes] - x, axis=1)
        ok = (dist <= reach) & (nodes != partner)
        if inc is not None:
            ok &= sides == gone_side[gone]
        if partner >= 0:
            ok &= np.array([editor.spring_between(partner, v) is None for v in nodes.tolist()])
        return int(nodes[np.flatnonzero(ok)[np.argmin(dist[ok])]]) if ok.any() else -1

    for keep, gone, force, smoothing in report.orphaned_links:
        new = taking(gone, keep)
        if new < 0:
            lost += 1
            continue
        editor.add_link(keep, new, force, smoothing)
    for i, j, force, smoothing in report.severed_links:
        a, b = taking(i, -1), taking(j, -1)
        if a < 0 or b < 0 or a == b or editor.spring_between(a, b) is not None:
            lost += 1
            continue
        editor.add_link(a, b, force, smoothing)
    return lost
