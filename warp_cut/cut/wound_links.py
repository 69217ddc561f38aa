"""The residual links a cut makes across its wound (SPEC section 1), and where they go when a
later edit takes one of their nodes.

A spring the cut separates (its two nodes on either side of the cut line, ``separated_by``)
leaves a residual-stress link once the wound is open where it crossed (``open_links``); a link
whose node a later event deletes is carried to the node that takes that node's place on the
same side of the incision (``carry_links``), and is lost only when that side is gone. A link
made or carried between the lips of two different stations is moved to one station's lip pair
(``align_links``): the stress it carries acts across the wound, not along it.
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import cross3
from .incision import Incision
from .topology import TopologyEditor

__all__ = ["separated_by", "open_links", "carry_links", "align_links"]


def separated_by(x: np.ndarray, pairs: np.ndarray, a, b, normal) -> np.ndarray:
    """Mask (s,) of node pairs (s, 2) on either side of the cut line a-b in the surface whose
    outward normal is ``normal`` (a pair on one side is not separated by the cut); ``x`` the
    node positions [m] (n, 3)."""
    if not len(pairs):
        return np.zeros(0, dtype=bool)
    lateral = (x[pairs.reshape(-1)] - a) @ cross3(normal, np.asarray(b, np.float64) - a)
    return lateral[0::2] * lateral[1::2] < 0.0


class _Places:
    """Where a residual link's node goes when the cut takes it: candidates by side of the
    incision, lips first."""

    def __init__(self, inc: Incision, positions, lips: list[int], others: list[int], radius: float):
        self.inc, self.radius = inc, radius
        self.lip_set = set(lips)
        self.nodes = np.array(lips + others, dtype=np.int64)
        self.is_lip = np.arange(len(self.nodes)) < len(lips)
        self.x = positions[self.nodes] if len(self.nodes) else np.zeros((0, 3))
        self.sides = inc.project(self.x)[1] if len(self.nodes) else np.zeros(0, np.int64)
        self.load = {}

    def side_of(self, node: int) -> int:
        """The side (+1 left, -1 right) of one of the candidate nodes."""
        return int(self.sides[np.flatnonzero(self.nodes == node)[0]])

    def taking(self, point, exclude=(), lips_only: bool = False) -> int:
        """The node that takes the place of one at ``point`` [m]: on its side, within the
        radius, lips before other nodes, the least loaded, the nearest; -1 if none."""
        if not len(self.nodes):
            return -1
        side = self.inc.project(np.asarray(point)[None])[1][0]
        dist = np.linalg.norm(self.x - point, axis=1)
        ok = (self.sides == side) & (dist <= self.radius) & ~np.isin(self.nodes, list(exclude))
        for group in (ok & self.is_lip, ok & ~self.is_lip if not lips_only else ok & False):
            k = np.flatnonzero(group)
            if len(k):
                load = np.array([self.load.get(int(self.nodes[i]), 0) for i in k])
                k = k[load == load.min()]
                best = int(self.nodes[k[np.argmin(dist[k])]])
                self.load[best] = self.load.get(best, 0) + 1
                return best
        return -1


def _live_lips(inc: Incision, active: np.ndarray) -> list[int]:
    return [v for v in inc.left + inc.right if v >= 0 and active[v]]


def _crossings(inc: Incision, positions, links) -> tuple[np.ndarray, np.ndarray]:
    """(arc length u (l,) [m] where each pending link's spring crossed the incision, the sides
    (l, 2) of its two nodes): u of the spring's midpoint, from its nodes' last positions [m] (a
    deleted node's included)."""
    if not links:
        return np.zeros(0), np.zeros((0, 2), dtype=np.int64)
    pairs = np.array([link[:2] for link in links], dtype=np.int64)
    x = np.asarray(positions[pairs.reshape(-1)], dtype=np.float64).reshape(-1, 2, 3)
    u, sides, _ = inc.project(np.concatenate([x.mean(axis=1), x.reshape(-1, 3)]))
    return u[: len(links)], sides[len(links):].reshape(-1, 2)


class _LipsAlong:
    """The live lips of an incision's stations, found by arc length and side."""

    def __init__(self, inc: Incision, active: np.ndarray, reach: float):
        self.u = np.asarray(inc.station_u, dtype=np.float64)
        self.reach = reach
        self.nodes = {side: np.array([v if v >= 0 and active[v] else -1 for v in lips], dtype=np.int64)
                      for side, lips in ((1, inc.left), (-1, inc.right))}

    def at(self, u: float, side: int) -> int:
        """The lip on ``side`` (+1 left, -1 right) of the live station nearest arc length u [m],
        within ``reach`` [m] of it; -1 if none."""
        nodes = self.nodes[int(side)]
        if not len(nodes):
            return -1
        dist = np.where(nodes >= 0, np.abs(self.u - u), np.inf)
        k = int(np.argmin(dist))
        return int(nodes[k]) if dist[k] <= self.reach else -1

    def nearest_station(self, u: float) -> int:
        """Index of the station nearest arc length u [m] (len(stations) for u = inf, -1 with no
        station)."""
        if not len(self.u):
            return -1
        return len(self.u) if np.isinf(u) else int(np.argmin(np.abs(self.u - u)))


def open_links(editor: TopologyEditor, inc: Incision, positions, reach: float) -> int:
    """Make the residual links of the springs the cut separated (all of them once the tool has
    gone). A link between two nodes that survived acts once the slit's tip has passed where
    the spring was cut. A node the cut deleted is replaced by the lip on its side at the
    station nearest where the spring crossed the incision, within ``reach`` [m] along it, so
    a stretch of wound's links pull on that stretch's lips; such a link waits until the slit
    is open past that station: the tip pair, next to the tool, takes none while the tool cuts
    (several links there pulled its lips into the next capsule). A link with no such lip
    waits for the next event while the tool cuts, and is lost once it has gone. Each spring's
    link is made, several on one lip pair if need be: the residual force across the wound is
    the released stress of every spring the cut separated, however coarse its events. Returns
    the links lost."""
    active = editor.model.active
    tip_u = inc.tip_u(active) if inc.open_end else np.inf
    lips = _LipsAlong(inc, active, reach)
    pending, inc.pending_links = inc.pending_links, []
    crossing_u, sides = _crossings(inc, positions, pending)
    tip = lips.nearest_station(tip_u)
    own, carried, lost = ([], []), ([], []), 0
    for link, u, (side_i, side_j) in zip(pending, crossing_u, sides):
        i, j, rest, cut_at = link
        replaced = not (active[i] and active[j])
        if inc.open_end and (cut_at > tip_u or (replaced and lips.nearest_station(u) >= tip)):
            inc.pending_links.append(link)  # the slit is not open past it yet
            continue
        a = i if active[i] else lips.at(u, side_i)
        b = j if active[j] else lips.at(u, side_j)
        if (a < 0 or b < 0) and inc.open_end:
            inc.pending_links.append(link)  # no lip there yet: tried again at the next event
            continue
        if a < 0 or b < 0 or a == b:
            lost += 1
            continue
        into = own if (a, b) == (i, j) else carried
        into[0].append((a, b))
        into[1].append(rest)
    editor.make_links(*own)
    editor.make_links(*carried, once_per_pair=False)  # several springs' links may share lips
    return lost


def carry_links(editor: TopologyEditor, inc: Incision, report, positions, reach: float) -> int:
    """Move each residual link that lost a node in this edit (``report.orphaned_links``) to the
    node that took that node's place: the nearest lip node on the same side of the incision
    (within ``reach`` [m]; else the nearest node of the edit there); drop it only when that side
    is gone. The lost node lay at the wound's edge, and the stress the link carries acts between
    the wound's two edges: its other node, if not a lip, moves to the nearest lip on its own side
    too (so a lip is never pulled across the wound by a node far on the other side). A link
    that lost both nodes (``report.severed_links``; or whose kept node went later in the edit)
    is carried to a lip on each side of this incision if its nodes lay on both, and is lost
    otherwise. Returns the links lost."""
    model = editor.model
    if not (report.orphaned_links or report.severed_links):
        return 0
    lips = _live_lips(inc, model.active)
    others = sorted(v for v in set(report.new_nodes) | editor.touched_nodes
                    if model.active[v] and v not in (inc.start_node, inc.end_node) and v not in lips)
    places = _Places(inc, positions, lips, others, reach)
    severed = list(report.severed_links)
    lost = 0
    for keep, gone, force, smoothing in report.orphaned_links:
        if not model.active[keep]:
            severed.append((keep, gone, force, smoothing))
            continue
        a = places.taking(positions[gone], exclude={keep})
        b = keep if keep in places.lip_set else places.taking(positions[keep], exclude={a}, lips_only=True)
        if a < 0:
            lost += 1
            continue
        editor.add_link(keep if b < 0 else b, a, force, smoothing)
    for i, j, force, smoothing in severed:
        a = places.taking(positions[i], lips_only=True)
        b = places.taking(positions[j], exclude={a}, lips_only=True)
        if a < 0 or b < 0 or places.side_of(a) == places.side_of(b):
            lost += 1
            continue
        editor.add_link(a, b, force, smoothing)
    return lost


def _stations_of(inc: Incision, active: np.ndarray) -> dict[int, int]:
    """Live interior lip node -> its station index."""
    return {v: k for side in (inc.left, inc.right) for k, v in enumerate(side) if v >= 0 and active[v]}


def align_links(editor: TopologyEditor, inc: Incision, slots) -> int:
    """Move each of the residual links ``slots`` that joins the left lip of one station to the
    right lip of another onto the lip pair of one station between them (both lips alive, the
    fewest links on it, then the nearest the middle), keeping its force and smoothing. With
    coarse cut events the links a re-closed stretch of the slit leaves, or carries to the lips
    that replace its nodes, run diagonally between neighbouring stations: their pull along the
    wound drags the lips sideways and makes the wound's width depend on the event interval.
    Returns the links moved."""
    model = editor.model
    table = model.link_table
    station = _stations_of(inc, model.active)
    left = set(inc.left)
    pairs = table.column("pairs")
    moved = 0
    for slot in sorted({int(s) for s in slots}):
        if not table.alive[slot]:
            continue
        i, j = (int(v) for v in pairs[slot])
        if i not in station or j not in station or (i in left) == (j in left):
            continue
        lo, hi = sorted((station[i], station[j]))
        if lo == hi:
            continue
        k = _least_loaded_pair(editor, inc, range(lo, hi + 1), 0.5 * (lo + hi))
        if k < 0:
            continue
        editor.move_link(slot, inc.left[k], inc.right[k])
        moved += 1
    return moved


def _least_loaded_pair(editor: TopologyEditor, inc: Incision, stations, middle: float) -> int:
    """Of ``stations`` whose two lips live, the one whose lip pair carries the fewest links
    (ties: nearest ``middle``); -1 if none."""
    active = editor.model.active
    best, best_key = -1, None
    for k in stations:
        a, b = inc.left[k], inc.right[k]
        if a < 0 or b < 0 or not (active[a] and active[b]):
            continue
        key = (len(editor.node_links[a] & editor.node_links[b]), abs(k - middle))
        if best_key is None or key < best_key:
            best, best_key = k, key
    return best
