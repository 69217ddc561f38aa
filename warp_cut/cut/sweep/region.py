"""Stage 1 in the rest shape: what the blade swept, and the region of triangles re-meshed around it.

Everything here is decided on the nodes' rest positions (``model.points``), so nothing the tool
does to the current positions changes it:

* the swept band: the tissue nodes within the clearance ``c`` of the part of the piece of rest
  curve the blade cut through tissue in this event are deleted (``c`` is the sweep radius, at
  least the lip offset plus ``CLEARANCE`` spacings, so no node kept beside a lip makes a thin
  triangle with it); nodes on a border of the tissue (an earlier wound, its edge) are left to
  the slit's band, which takes those it reaches (``warp_cut.cut.remesh.cut_piece``);
* the region: every triangle at a node within ``c`` + ``REGION_MARGIN`` spacings of the piece,
  made round (a corner of the region sharper than ``ROUND_ANGLE_DEG`` takes in the whole fan of
  its node), and grown on request (``grow``, ``sweep``);
* its outline: the region's border edges, directed so the region lies on their left (the mesh's
  winding).

Shapes: node and triangle slots are int arrays; positions (k, 3) [m].
"""

from __future__ import annotations

import numpy as np
import shapely

from ...mesh.geometry import triangle_angles
from ...mesh.triangulate import boundary_edges
from ...sim.slots import member
from ...sim.topology_index import TopologyIndex
from ..tolerances import ROUND_ANGLE_DEG

__all__ = ["Region", "tissue_segments", "distance_to_segments", "border_edges", "border_nodes"]


def distance_to_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Least distance [m] (m,) of points (m, 3) to the segments a-b (k, 3) (inf without any)."""
    if not len(a):
        return np.full(len(points), np.inf)
    ab = b - a
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300),
                0.0, 1.0)
    return np.linalg.norm(a[None] + t[..., None] * ab[None] - points[:, None, :], axis=2).min(axis=1)


def tissue_segments(curve: np.ndarray, on_tissue: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The segments (a (k, 3), b (k, 3)) of the polyline ``curve`` (n, 3) with an end on the
    tissue (``on_tissue`` (n,) bool): the part of the curve the blade cut through tissue (over an
    opening it sweeps nothing)."""
    keep = on_tissue[:-1] | on_tissue[1:]
    return curve[:-1][keep], curve[1:][keep]


def border_edges(model, triangles) -> np.ndarray:
    """The edges of ``triangles`` (live triangle slots) on a border of the tissue (held by one
    live triangle of the whole mesh), as sorted node pairs (k, 2) in lexicographic order."""
    tris = np.asarray(triangles, dtype=np.int64)
    if not len(tris):
        return np.zeros((0, 2), dtype=np.int64)
    once = np.sort(boundary_edges(model.triangle_table.column("corners")[tris]), axis=1)
    once = once[np.lexsort((once[:, 1], once[:, 0]))]
    index = model.index  # an edge once among ``triangles`` may have its other triangle outside them
    keep = [len(index.triangles_with_edge(a, b)) == 1 for a, b in once.tolist()]
    return once[np.array(keep, dtype=bool)] if len(once) else once


def border_nodes(model, nodes: np.ndarray) -> np.ndarray:
    """Mask (k,) of ``nodes`` on a border of the tissue (an end of an edge of one live
    triangle): every triangle at such an edge holds the node, so the triangles at ``nodes``
    decide it."""
    nodes = np.asarray(nodes, dtype=np.int64)
    tris = model.index.triangles_at(nodes.tolist())
    if not tris:
        return np.zeros(len(nodes), dtype=bool)
    # an edge at one of ``nodes`` has all its triangles among ``tris``: once among them is once in the mesh
    return member(nodes, boundary_edges(model.triangle_table.column("corners")[tris]))


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
        self.healed: list = []
        """Node rings (lists of node slots): openings the event takes back into the region's
        tissue (the end of the slit past its newest lip pair, which it cuts again)."""

    @classmethod
    def around(cls, model, curve: np.ndarray, on_tissue: np.ndarray, near: np.ndarray, clearance: float,
               margin: float, protected=(), provisional=()) -> Region:
        """The region of the piece of rest curve ``curve`` (k, 3) [m], whose points
        ``on_tissue`` (k,) bool lie on the tissue (not in an opening): ``near`` are the live
        nodes within ``clearance + margin`` (and some more) of it; the tissue nodes within
        ``clearance`` of its part on the tissue are deleted (not those on a border of the tissue:
        where the band reaches them, taking it out of the tissue takes them; never the
        ``protected`` ones: the incision's own lips and start); the ``provisional`` nodes (the
        incision's old tip and what is beyond its last lip pair) go too."""
        points = model.points
        a, b = tissue_segments(curve, np.asarray(on_tissue, dtype=bool))
        dist = distance_to_segments(points[near], a, b) if len(near) else np.zeros(0)
        keep = set(int(v) for v in protected)
        swept = near[(dist <= clearance) & ~border_nodes(model, near)]
        deleted = ({int(v) for v in swept} - keep) | {int(v) for v in provisional}
        within = near[dist <= clearance + margin]
        region = cls(model, deleted, model.index.triangles_at(set(within.tolist()) | deleted))
        region.round()
        return region

    # ------------------------------------------------------------------ shape
    def healed_polygons(self, chart) -> list:
        """The ``healed`` openings as Shapely polygons in ``chart`` (a ``RegionChart``)."""
        return [shapely.make_valid(shapely.Polygon(chart.to2d(self.model.points[ring]))) for ring in self.healed]

    def healed_triangles(self, chart) -> np.ndarray:
        """(t, 3) node slots of triangles covering the ``healed`` openings (a constrained
        Delaunay triangulation of each ring in ``chart``, a ``RegionChart``): with the region's
        triangles, they map the tissue the fill covers back onto the surface."""
        out = []
        for ring, polygon in zip(self.healed, self.healed_polygons(chart)):
            xy = chart.to2d(self.model.points[ring])
            triangles = shapely.constrained_delaunay_triangles(polygon)
            for triangle in getattr(triangles, "geoms", [triangles]):
                if not isinstance(triangle, shapely.Polygon) or triangle.is_empty:
                    continue
                corners = np.asarray(triangle.exterior.coords)[:3]
                nearest = np.argmin(np.linalg.norm(xy[None] - corners[:, None], axis=2), axis=1)
                out.append([ring[k] for k in nearest.tolist()])
        return np.array(out, dtype=np.int64).reshape(-1, 3)

    def outline(self) -> list[tuple[int, int]]:
        """The region's border edges (a, b), directed with the region on their left (each
        appears in one region triangle only; the mesh's counter-clockwise winding)."""
        tris = np.fromiter(self.triangles, dtype=np.int64, count=len(self.triangles))
        return [(a, b) for a, b in boundary_edges(self.model.triangle_table.column("corners")[tris]).tolist()]

    def nodes(self) -> set[int]:
        """Every node of the region's triangles."""
        tris = np.fromiter(self.triangles, dtype=np.int64, count=len(self.triangles))
        return set(self.model.triangle_table.column("corners")[tris].ravel().tolist())

    def on_mesh_border(self, a: int, b: int) -> bool:
        """True if edge a-b has one live triangle in the whole mesh (a border of the tissue)."""
        return len(self.index.triangles_with_edge(a, b)) == 1

    def round(self, rounds: int = 2) -> None:
        """Take in the whole fan of every outline node (not on the mesh's border) at which the
        region's triangles make a corner sharper than ``ROUND_ANGLE_DEG``."""
        corners = self.model.triangle_table.column("corners")
        points = self.model.points
        for _ in range(rounds):
            tris = np.array(sorted(self.triangles), dtype=np.int64)
            if not len(tris):
                return
            c = corners[tris].astype(np.int64)
            angle = np.bincount(c.ravel(), weights=triangle_angles(points, c).ravel(), minlength=int(c.max()) + 1)
            ends = np.array(sorted({a for a, _ in self.outline()}), dtype=np.int64)
            sharp = ends[angle[ends] < ROUND_ANGLE_DEG]
            sharp = sharp[~border_nodes(self.model, sharp)]
            if not len(sharp):
                return
            for v in sharp.tolist():
                self.triangles |= self.index.node_triangles[v]

    def sweep(self, nodes) -> list[int]:
        """Take in the fans of ``nodes``; those on a border of the tissue are deleted too (a sharp
        corner of tissue between the slit and a border goes with the band). Returns those on a
        border: the fan taken in leaves their corner where it was (``layout.corner_cut``)."""
        nodes = np.fromiter((int(v) for v in nodes), dtype=np.int64)
        on_border = border_nodes(model=self.model, nodes=nodes)
        for v, border in zip(nodes.tolist(), on_border.tolist()):
            if border:
                self.deleted.add(v)
            self.triangles |= self.index.node_triangles[v]
        return nodes[on_border].tolist()

    def grow(self, edges) -> None:
        """Take in the triangles across the outline edges ``edges`` (node pairs) that the region
        does not hold (the fill had to split them: they are shared with the mesh outside)."""
        for a, b in edges:
            self.triangles |= self.index.triangles_with_edge(int(a), int(b))
