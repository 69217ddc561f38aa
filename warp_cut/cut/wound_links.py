"""The residual links a cut makes across its wound (SPEC section 1), and where they go when a
later edit takes one of their nodes.

A spring the cut separates (its two nodes on either side of the cut line, ``separated_by``)
leaves a residual-stress link once the wound is open where it crossed (``open_links``); a link
whose node a later event deletes is carried to the node that takes that node's place on the
same side of the incision (``carry_links``), and is lost only when that side is gone.
"""

from __future__ import annotations

import numpy as np

from ..mesh.geometry import cross3
from .incision import Incision
from .topology import TopologyEditor

__all__ = ["separated_by", "open_links", "carry_links"]


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


def open_links(editor: TopologyEditor, inc: Incision, positions, reach: float) -> int:
    """Make the residual links of the springs the cut separated behind the slit's tip (all of
    them once the tool has gone). A node a later event deleted is replaced by the lip that took
    its place on its side, within ``reach`` [m]; the link is lost only if there is none.
    Returns the links lost."""
    active = editor.model.active
    tip_u = inc.tip_u(active) if inc.open_end else np.inf
    due = [link for link in inc.pending_links if link[3] <= tip_u]
    if not due:
        return 0
    inc.pending_links = [link for link in inc.pending_links if link[3] > tip_u]
    places = _Places(inc, positions, _live_lips(inc, active), [], reach)
    pairs, rests, lost = [], [], 0
    for i, j, rest, _ in due:
        a = i if active[i] else places.taking(positions[i], exclude={j})
        b = j if active[j] else places.taking(positions[j], exclude={a})
        if a < 0 or b < 0 or a == b:
            lost += 1
            continue
        pairs.append((a, b))
        rests.append(rest)
    editor.make_links(pairs, rests)
    return lost


def carry_links(editor: TopologyEditor, inc: Incision, report, positions, reach: float) -> int:
    """Move each residual link that lost a node in this edit (``report.orphaned_links``) to the
    node that took that node's place: the nearest lip node on the same side of the incision
    (within ``reach`` [m]; else the nearest node of the edit there); drop it only when that side
    is gone. The lost node lay at the wound's edge, and the stress the link carries acts between
    the wound's two edges: its other node, if not a lip, moves to the nearest lip on its own side
    too (so a lip is never pulled across the wound by a node far on the other side). Returns the
    links lost."""
    model = editor.model
    if not report.orphaned_links:
        return 0
    lips = _live_lips(inc, model.active)
    others = sorted(v for v in set(report.new_nodes) | editor.touched_nodes
                    if model.active[v] and v not in (inc.start_node, inc.end_node) and v not in lips)
    places = _Places(inc, positions, lips, others, reach)
    lost = 0
    for keep, gone, force, smoothing in report.orphaned_links:
        if not model.active[keep]:
            continue
        a = places.taking(positions[gone], exclude={keep})
        b = keep if keep in places.lip_set else places.taking(positions[keep], exclude={a}, lips_only=True)
        if a < 0:
            lost += 1
            continue
        editor.add_link(keep if b < 0 else b, a, force, smoothing)
    return lost
