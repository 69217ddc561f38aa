"""Stage 1 in the rest shape: what the blade swept, and the region of triangles re-meshed around it.

Everything here is decided on the nodes' rest positions (``model.points``), so nothing the tool
does to the current positions changes it:

* the swept band: the nodes within the clearance ``c`` of the piece of rest curve the blade cut
  in this event are deleted (``c`` is the sweep radius, at least the lip offset plus
  ``CLEARANCE`` spacings, so no node kept beside a lip makes a thin triangle with it); on a
  border of the tissue (an earlier wound, its edge) only the nodes within the junction reach
  ``j`` (lip offset + ``JUNCTION`` spacings), and the two nodes of every border edge passing
  within half of it: there the slit joins that border, and it never crosses a border edge it
  keeps;
* the region: every triangle at a node within ``c`` + ``REGION_MARGIN`` spacings of the piece,
  made round (a corner of the region sharper than ``ROUND_ANGLE_DEG`` takes in the whole fan of
  its node), and grown on request (``grow``);
* its outline: the region's border edges, directed so the region lies on their left (the mesh's
  winding), and the gaps that the deleted nodes leave in it where the outline runs along a border
  of the mesh (an earlier wound, the tissue's edge, the incision's own tip).

Shapes: node and triangle slots are int arrays; positions (k, 3) [m].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..mesh.geometry import triangle_angles
from ..sim.topology_index import TopologyIndex
from .incision import closest_on_polyline
from .tolerances import ROUND_ANGLE_DEG

__all__ = ["Region", "Gap", "swept_nodes", "outline_gaps"]


@dataclass
class Gap:
    """Deleted nodes in a row on the region's outline: the walk along the outline (region on the
    left) goes ``before`` -> ``nodes`` -> ``after``, with ``before`` and ``after`` kept."""

    before: int
    after: int
    nodes: list = field(default_factory=list)


def swept_nodes(points: np.ndarray, candidates: np.ndarray, curve: np.ndarray, radius: float) -> np.ndarray:
    """The ``candidates`` (node slots) whose rest position (``points`` (n, 3) [m]) lies within
    ``radius`` [m] of the polyline ``curve`` (k, 3) [m]."""
    if not len(candidates):
        return candidates
    poly = curve if len(curve) > 1 else np.repeat(curve, 2, axis=0)
    dist = closest_on_polyline(points[candidates], poly)[3]
    return candidates[dist <= radius]


def _segment_distance(p: np.ndarray, q: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Least distance [m] (m,) between segments p-q (m, 3) and a polyline (k, 3), sampled at
    nine points per segment (enough for segments about as long as the clearance)."""
    t = np.linspace(0.0, 1.0, 9)
    samples = p[:, None, :] + t[None, :, None] * (q - p)[:, None, :]
    dist = closest_on_polyline(samples.reshape(-1, 3), poly)[3].reshape(len(p), -1)
    return dist.min(axis=1)


class Region:
    """The triangles one event re-meshes, with the nodes it deletes.

    Args:
        model: The tissue (its topology index is used).
        deleted: Node slots the swept band deletes.
        triangles: Triangle slots of the region.
    """

    def __init__(self, model, deleted, triangles):
        self.model = model
        self.index: TopologyIndex = model.index
        self.deleted = set(int(v) for v in deleted)
        self.triangles = set(int(t) for t in triangles)

    @classmethod
    def around(cls, model, curve: np.ndarray, near: np.ndarray, clearance: float, junction: float,
               margin: float, protected=(), provisional=()) -> Region:
        """The region of the piece of rest curve ``curve`` (k, 3) [m]: ``near`` are the live nodes
        within ``clearance + margin`` (and some more) of it; nodes within ``clearance`` are
        deleted, those on a border of the tissue only within ``junction``, with the two nodes
        of each border edge passing within half of it (never the ``protected`` ones: the
        incision's own lips and start); the ``provisional`` nodes (the incision's old tip and
        what is beyond its last lip pair) go too."""
        points = model.points
        poly = curve if len(curve) > 1 else np.repeat(curve, 2, axis=0)
        dist = closest_on_polyline(points[near], poly)[3] if len(near) else np.zeros(0)
        keep = set(int(v) for v in protected)
        on_border = cls._border_nodes(model, near)
        reach = np.where(on_border, min(junction, clearance), clearance)
        deleted = {int(v) for v in near[dist <= reach]} - keep
        deleted |= cls._border_edges_near(model, near, poly, 0.5 * junction) - keep
        deleted |= {int(v) for v in provisional}
        within = near[dist <= clearance + margin]
        region = cls(model, deleted, model.index.triangles_at(set(within.tolist()) | deleted))
        region.round()
        return region

    @staticmethod
    def _border_nodes(model, nodes: np.ndarray) -> np.ndarray:
        """Mask (k,) of ``nodes`` on a border of the tissue (an edge of one live triangle)."""
        index, corners = model.index, model.triangle_table.column("corners")
        out = np.zeros(len(nodes), dtype=bool)
        for k, v in enumerate(nodes):
            v = int(v)
            for t in index.node_triangles[v]:
                if any(int(w) != v and len(index.triangles_with_edge(v, int(w))) == 1 for w in corners[t]):
                    out[k] = True
                    break
        return out

    @staticmethod
    def _border_edges_near(model, near: np.ndarray, poly: np.ndarray, clearance: float) -> set[int]:
        """Both nodes of every border edge (on one live triangle) at ``near`` that passes within
        ``clearance`` [m] of the polyline ``poly``."""
        index, corners = model.index, model.triangle_table.column("corners")
        edges = set()
        for v in near:
            for t in index.node_triangles[int(v)]:
                c = corners[t]
                for k in range(3):
                    a, b = int(c[k]), int(c[(k + 1) % 3])
                    if len(index.triangles_with_edge(a, b)) == 1:
                        edges.add((min(a, b), max(a, b)))
        if not edges:
            return set()
        pairs = np.array(sorted(edges), dtype=np.int64)
        close = _segment_distance(model.points[pairs[:, 0]], model.points[pairs[:, 1]], poly) <= clearance
        return {int(v) for v in pairs[close].ravel()}

    # ------------------------------------------------------------------ shape
    def outline(self) -> list[tuple[int, int]]:
        """The region's border edges (a, b), directed with the region on their left (each
        appears in one region triangle only; the mesh's counter-clockwise winding)."""
        corners = self.model.triangle_table.column("corners")
        count: dict[tuple[int, int], int] = {}
        directed = []
        for t in self.triangles:
            c = [int(v) for v in corners[t]]
            for k in range(3):
                a, b = c[k], c[(k + 1) % 3]
                key = (min(a, b), max(a, b))
                count[key] = count.get(key, 0) + 1
                directed.append((a, b))
        return [(a, b) for a, b in directed if count[(min(a, b), max(a, b))] == 1]

    def nodes(self) -> set[int]:
        """Every node of the region's triangles."""
        corners = self.model.triangle_table.column("corners")
        return {int(v) for t in self.triangles for v in corners[t]}

    def on_mesh_border(self, a: int, b: int) -> bool:
        """True if edge a-b has one live triangle in the whole mesh (a border of the tissue)."""
        return len(self.index.triangles_with_edge(a, b)) == 1

    def round(self, rounds: int = 2) -> None:
        """Take in the whole fan of every outline node (not on the mesh's border) at which the
        region's triangles make a corner sharper than ``ROUND_ANGLE_DEG``."""
        corners = self.model.triangle_table.column("corners")
        points = self.model.points
        for _ in range(rounds):
            angle: dict[int, float] = {}
            tris = np.array(sorted(self.triangles), dtype=np.int64)
            if not len(tris):
                return
            ang = triangle_angles(points, corners[tris])
            for row, t in enumerate(tris):
                for k, v in enumerate(corners[t]):
                    angle[int(v)] = angle.get(int(v), 0.0) + float(ang[row, k])
            sharp = [v for v in {a for a, _ in self.outline()}
                     if angle.get(v, 360.0) < ROUND_ANGLE_DEG and not self._touches_border(v)]
            if not sharp:
                return
            for v in sharp:
                self.triangles |= self.index.node_triangles[v]

    def _touches_border(self, v: int) -> bool:
        """True if node ``v`` lies on the border of the mesh."""
        corners = self.model.triangle_table.column("corners")
        for t in self.index.node_triangles[v]:
            for w in corners[t]:
                if int(w) != v and len(self.index.triangles_with_edge(v, int(w))) == 1:
                    return True
        return False

    def grow(self, edges) -> None:
        """Take in the triangles across the outline edges ``edges`` (node pairs) that the region
        does not hold (the fill had to split them: they are shared with the mesh outside)."""
        for a, b in edges:
            self.triangles |= self.index.triangles_with_edge(int(a), int(b))


def outline_gaps(outline: list[tuple[int, int]], deleted: set[int]) -> tuple[list[tuple[int, int]], list[Gap]]:
    """(the outline edges between kept nodes, the gaps deleted nodes leave in it). A gap is
    followed along the outline from the kept node before it to the kept node after it; an
    outline loop whose nodes are all deleted leaves no gap (it is swallowed)."""
    kept = [(a, b) for a, b in outline if a not in deleted and b not in deleted]
    following: dict[int, list[int]] = {}
    for a, b in outline:
        following.setdefault(a, []).append(b)
    gaps = []
    for a, b in outline:
        if a in deleted or b not in deleted:
            continue
        nodes, v, steps = [], b, 0
        while v in deleted and steps <= len(outline):
            nodes.append(v)
            nexts = following.get(v, [])
            if not nexts:
                break
            v = nexts[0] if len(nexts) == 1 else _first_not(nexts, nodes)
            steps += 1
        if v not in deleted:
            gaps.append(Gap(a, v, nodes))
    return kept, gaps


def _first_not(candidates: list[int], seen: list[int]) -> int:
    """The first of ``candidates`` not in ``seen`` (else the first)."""
    for c in candidates:
        if c not in seen:
            return c
    return candidates[0]
