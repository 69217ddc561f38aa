"""Stage 3 in the rest shape: re-mesh the region round the swept band with the slit in it.

One event of an incision (``cut_piece``) takes the piece of rest curve the blade cut since the
last event and, all in a flat chart of the rest surface:

1. picks the region of triangles round the band and the tissue nodes the band sweeps
   (``region.Region``);
2. lays out the slit's band (``event_band``: ``slit_band.plan_band``'s lips at the new
   stations, its tip, its start, or its ends in openings, with the end of the slit cut before)
   and takes it out of the region's tissue (a polygon difference, GEOS through Shapely): the
   tissue left is exactly the region's triangles less the band, whatever earlier wounds or
   borders the band runs into, crosses or starts in;
3. fills that tissue with triangles of at least ``REFINE_ANGLE_DEG`` (``fill.fill_region``,
   keeping the region's outline, the lips and the nodes inside); a fill that had to split an
   edge the region shares with the tissue outside grows the region across it, and a corner of
   tissue sharper than the fill can mend (a slit meeting a border at a shallow angle) goes with
   the band; then fills again;
4. writes the new nodes, their rest positions on the rest surface and their current positions in
   the deformed tissue (both through the region's triangles: nothing jumps; a node the tool's
   cylinder holds is put on its surface, as the tool would push it) and the new triangles through
   the ``TopologyEditor``, and gives the nodes and springs their classes.

It returns a ``PieceCut`` record, or raises ``SlitDoesNotFit`` (saying why) before it has edited
anything: the event is left for the next one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely

from ..errors import InputError
from ..mesh.geometry import triangle_min_angles
from ..sim.collision import pushed_out
from ..sim.control import Tool
from .chart import PiecewiseLinearMap, RegionChart
from .classes import NodeClass, SpringClass
from .event_band import add_old_tip, clear_of_old_tip, clearance, event_band
from .fill import Fill, fill_region
from .incision import Incision
from .region import Region
from .slit_band import EXTENSION, JUNCTION, START, TIP, BandPoint, SlitBand
from .tolerances import (
    MATCH,
    MAX_GROWTH,
    MERGE,
    MIN_ANGLE_DEG,
    MIN_EDGE,
    OLD_END_CLEARANCE,
    REFINE_ANGLE_DEG,
    REGION_MARGIN,
)
from .topology import NodePositions, TopologyEditor

__all__ = ["PieceCut", "SlitDoesNotFit", "cut_piece"]


class SlitDoesNotFit(Exception):
    """The slit of an event could not be laid out in its region (nothing was edited)."""


@dataclass
class PieceCut:
    """What one event's re-mesh did.

    Attributes:
        deleted: Nodes the event deleted (swept by the band, or left in it).
        lips: New nodes on the slit (lips, tip, start, and where a lip line meets a border).
        inserted: Nodes the refinement inserted.
        stations: (u [m], left node, right node) of each new station (-1: no lip there).
        tip: The new tip node (-1: the slit ends in an opening).
        start: The start node made here (-1: none made).
        growth: How many times the region grew (or a sharp corner went) before the fill.
        unrefined: Triangles left under the target angle (sharp corners of the outline).
        met_border: The slit ran into an opening or the tissue's edge in this event.
    """

    deleted: list = field(default_factory=list)
    lips: list = field(default_factory=list)
    inserted: list = field(default_factory=list)
    stations: list = field(default_factory=list)
    tip: int = -1
    start: int = -1
    growth: int = 0
    unrefined: int = 0
    met_border: bool = False


@dataclass
class _Layout:
    """A region's fill: ``ids`` of its vertices (node ids >= 0, new points < 0: ``points[-1-k]``),
    the fill, the chart, which outline edges it may not split, and the outline's turns."""

    ids: list
    points: list
    fill: Fill
    chart: RegionChart
    fixed: set
    turns: dict
    """Outline vertex id -> (its row, the row before it, the row after it) along the tissue's
    new outline, the tissue on the left (rows of ``fill.points``)."""
    cut_across: set
    """Fixed outline edges the band cuts across (the region must grow across them)."""
    stations: list
    """Arc lengths [m] of the band's new stations (``BandPoint.station`` indexes them)."""
    resumed_at: float | None = None
    """Where the band's last run begins at an opening's border [m] (``SlitBand.resumed_at``)."""
    band_lips: dict = field(default_factory=dict)
    """(station, side) -> the node a lip of the band was matched to (``_match_lips``)."""
    matched: dict = field(default_factory=dict)
    """New point id (< 0) -> the node on the outline next to it that it was matched to
    (``MERGE``): that node stands in for it."""


@dataclass(frozen=True)
class _NewPoint:
    """A node the layout makes: a band point, or where a lip line meets a border (``band`` None)."""

    band: BandPoint | None
    chart: np.ndarray


def cut_piece(editor: TopologyEditor, inc: Incision, u: np.ndarray, on_tissue: np.ndarray, near: np.ndarray,
              positions: NodePositions, *, tool: Tool | None, first: bool) -> PieceCut:
    """Cut the piece of ``inc``'s rest curve sampled at arc lengths ``u`` (k,) [m] (from the last
    cut to the slit's new tip, the last sample), ``on_tissue`` (k,) bool: which samples lie in
    the tissue (the others over an opening, where the blade sweeps nothing). ``near``: live nodes
    within clearance + 2 spacings of the piece, at least; ``positions``: the current node
    positions; ``tool``: the tool now, whose cylinder new nodes are kept out of; ``first``: the
    incision's first event. Part of an edit begun on ``editor`` (see the module docstring).

    Raises:
        SlitDoesNotFit: The band leaves no tissue to fill, or its region cannot be filled.
    """
    model = editor.model
    s = inc.spacing
    provisional = inc.provisional_nodes(model.active, model.points)  # the old tip goes: the slit runs on
    protected = (inc.lip_node_set() | inc.slit_nodes) - provisional
    piece = inc.point_at(u)
    region = Region.around(model, piece, on_tissue, near, clearance(inc), REGION_MARGIN * s, protected, provisional)
    band = event_band(model, inc, u, on_tissue, first, near)
    old_tip = add_old_tip(model, inc, region, band)
    if not region.triangles:
        raise SlitDoesNotFit("no tissue around the piece")
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    chart = RegionChart.of_triangles(model.points[corners])
    if old_tip is not None:
        clear_of_old_tip(band, old_tip, inc, chart, OLD_END_CLEARANCE * s)
    try:
        layout, growth = _fill(model, inc, region, band, chart, protected)
    except SlitDoesNotFit:  # node matching, then once more: a lip beside a node of the slit is that node
        if not _match_lips(band, model, (protected | provisional) & set(near.tolist()), MERGE * s):
            raise
        layout, growth = _fill(model, inc, region, band, chart, protected)
    return _apply(editor, inc, region, layout, positions, tool, growth)


def _fill(model, inc: Incision, region: Region, band: SlitBand, chart: RegionChart,
          protected: set[int]) -> tuple[_Layout, int]:
    """The region less the band, filled (``_lay_out``), the region grown where the refinement
    would split its fixed outline or leaves a corner it cannot mend (up to ``MAX_GROWTH``
    times), and checked; with the times it grew.

    Raises:
        SlitDoesNotFit: The fill splits the region's outline, leaves a triangle under
            ``MIN_ANGLE_DEG`` or does not lay the whole slit, however far the region grows.
    """
    wedges: list = []
    for growth in range(MAX_GROWTH + 1):
        layout = _lay_out(model, inc, region, band, chart, wedges)
        refused = ({_edge_of(layout.ids, e) for e in layout.fill.split_edges} & layout.fixed) | layout.cut_across
        sharp = _sharp_corners(layout, protected) if layout.fill.unrefined else []
        if not (refused or sharp) or growth == MAX_GROWTH:
            break
        region.grow(refused)
        for v, wedge in sharp:
            if wedge is None:
                region.sweep([v])
            else:
                wedges.append(wedge)
    if refused:  # a split outline edge would leave a node on the edge of a triangle outside
        raise SlitDoesNotFit("the refinement splits the region's outline however far it grows")
    if layout.fill.unrefined and _smallest_angle(layout.fill) < MIN_ANGLE_DEG:
        raise SlitDoesNotFit("the fill leaves a triangle under the smallest angle however far it grows")
    _check_slit(layout, band)
    return layout, growth


def _smallest_angle(fill: Fill) -> float:
    """Smallest angle [deg] of the fill's triangles in its chart."""
    flat = np.column_stack([fill.points, np.zeros(len(fill.points))])
    return float(triangle_min_angles(flat, fill.triangles).min()) if len(fill.triangles) else 180.0


def _check_slit(layout: _Layout, band: SlitBand) -> None:
    """The fill lays the whole slit: every lip and the tip the band asks for is a vertex of the
    tissue's new outline, one each, or a lip matched to a node of the outline next to it
    (``_matched_lips``: a node of the slit round a sharp bend, an earlier wound's).

    Raises:
        SlitDoesNotFit: One is missing or doubled (the band and the region's outline met in a
            sliver the polygon operations cut apart): the next event tries again.
    """
    wanted = {(p.station, p.side) for run in band.runs for p in run if p.node < 0 and p.station not in
              (EXTENSION, JUNCTION)}
    laid: dict = {}
    for v in layout.ids:
        if v < 0 and layout.points[-1 - v].band is not None:
            key = (layout.points[-1 - v].band.station, layout.points[-1 - v].band.side)
            laid[key] = laid.get(key, 0) + 1
    for key in _matched_lips(layout):
        laid[key] = laid.get(key, 0) + 1
    missing = sorted(k for k in wanted if laid.get(k, 0) != 1)
    if missing:
        raise SlitDoesNotFit(f"the fill does not lay the slit's points {missing} once each")


def _match_lips(band: SlitBand, model, nodes: set[int], reach: float) -> int:
    """Node matching (the paper's Alg. 2): a new lip of ``band`` within ``reach`` [m] of one of
    ``nodes`` (the slit's nodes near, e.g. round a sharp bend, where the lip lines of the legs
    before and after it meet) is that node, each node one lip at most. Returns the lips matched.
    Tried when a fill does not fit: a node a little off the lip line makes a less even fill."""
    live = np.array(sorted(v for v in nodes if model.active[v]), dtype=np.int64)
    if not len(live):
        return 0
    matched = 0
    used = {p.node for run in band.runs for p in run if p.node >= 0}
    for run in band.runs:
        for k, p in enumerate(run):
            if p.node >= 0 or p.station < 0:
                continue
            d = np.linalg.norm(model.points[live] - p.rest, axis=1)
            j = int(np.argmin(d))
            if d[j] <= reach and int(live[j]) not in used:
                used.add(int(live[j]))
                run[k] = BandPoint(model.points[live[j]].copy(), p.side, p.station, p.u, int(live[j]))
                matched += 1
    return matched


def _matched_lips(layout: _Layout) -> dict:
    """(station, side) -> node of the lips matched to a node: by the band (``_match_lips``) or by
    the outline, next to them (``MERGE``), each node standing in for one lip only (two lips on
    one node would be no slit)."""
    lips: dict = dict(layout.band_lips)
    for v, node in layout.matched.items():
        band = layout.points[-1 - v].band
        if band is not None and band.station >= 0 and node not in lips.values():
            lips[(band.station, band.side)] = node
    return lips


def _edge_of(ids: list, edge: tuple[int, int]) -> tuple[int, int]:
    """The sorted node pair of a fill edge (indices into ``ids``)."""
    a, b = ids[edge[0]], ids[edge[1]]
    return (min(a, b), max(a, b))


def _lay_out(model, inc: Incision, region: Region, band: SlitBand, chart: RegionChart, wedges: list) -> _Layout:
    """The region's tissue less the band (and the sharp ``wedges`` (3, 2) chart triangles cut off
    before), in ``chart``, filled.

    Raises:
        SlitDoesNotFit: No tissue is left, or the fill found no area.
    """
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    tissue = shapely.union_all(shapely.polygons(chart.to2d(model.points[corners])))
    rings = [_distinct(chart.to2d(np.array([p.rest for p in run]))) for run in band.runs]
    cut = shapely.union_all([shapely.make_valid(shapely.Polygon(r)) for r in rings if len(r) >= 3]
                            + [shapely.Polygon(w) for w in wedges])
    grid = 1e-6 * inc.spacing  # slivers of rounding where the band runs along a border collapse on it
    left = shapely.orient_polygons(shapely.set_precision(tissue.difference(cut), grid), exterior_cw=False)
    pieces = [g for g in getattr(left, "geoms", [left]) if isinstance(g, shapely.Polygon)
              and g.area > (0.01 * inc.spacing) ** 2]
    if not pieces:
        raise SlitDoesNotFit("the band leaves no tissue in its region")
    table = _VertexTable(model, chart, region, band, MATCH * inc.spacing)
    loops, points, matched = _loops(pieces, table, MERGE * inc.spacing)
    outline = {v for loop in loops for v in loop}
    rim = shapely.union_all([p.boundary for p in pieces])
    inside = [v for v in sorted(region.nodes() - region.deleted - outline)
              if any(p.contains(shapely.Point(chart.to2d(model.points[v]))) for p in pieces)
              and rim.distance(shapely.Point(chart.to2d(model.points[v]))) > MERGE * inc.spacing]
    ids = sorted(v for v in outline if v >= 0) + inside + sorted((v for v in outline if v < 0), reverse=True)
    where = {v: k for k, v in enumerate(ids)}
    chart_points = np.array([chart.to2d(model.points[v]) if v >= 0 else points[-1 - v].chart for v in ids])
    edges = [(where[a], where[b]) for loop in loops for a, b in zip(loop, loop[1:] + loop[:1]) if a != b]
    try:
        fill = fill_region(chart_points, edges, min_angle_deg=REFINE_ANGLE_DEG, min_edge=MIN_EDGE * inc.spacing)
    except InputError as err:
        raise SlitDoesNotFit(str(err)) from err
    fixed = {(min(a, b), max(a, b)) for a, b in region.outline() if not region.on_mesh_border(a, b)}
    kept = {(min(a, b), max(a, b)) for loop in loops for a, b in zip(loop, loop[1:] + loop[:1])}
    cut_across = {e for e in fixed if e not in kept and not {*e} & region.deleted}
    turns = {b: (where[b], where[a], where[c]) for loop in loops
             for a, b, c in zip(loop[-1:] + loop[:-1], loop, loop[1:] + loop[:1])}
    band_lips = {(p.station, p.side): p.node for run in band.runs for p in run if p.node >= 0 and p.station >= 0}
    return _Layout(ids, points, fill, chart, fixed, turns, cut_across, band.stations, band.resumed_at,
                   band_lips, matched)


def _distinct(ring: np.ndarray) -> np.ndarray:
    """The ring (k, 2) without a point equal to the one before it (cyclically): a band whose two
    ends close on one node."""
    if len(ring) < 2:
        return ring
    keep = np.any(ring != np.roll(ring, 1, axis=0), axis=1)
    return ring[keep]


class _VertexTable:
    """What lies at a chart point: a node id (the region's nodes, the band's existing nodes) or a
    BandPoint (a new point of the band), found within ``tolerance`` [m] (GEOS returns the input
    vertices it keeps, but only to rounding)."""

    def __init__(self, model, chart: RegionChart, region: Region, band: SlitBand, tolerance: float):
        nodes = sorted(region.nodes())
        self.items: list = list(nodes)
        xy = [chart.to2d(model.points[nodes])] if nodes else []
        for run in band.runs:
            for p in run:
                self.items.append(p.node if p.node >= 0 else p)
                xy.append(chart.to2d(p.rest)[None])
        self.xy = np.concatenate(xy) if xy else np.zeros((0, 2))
        self.tolerance = tolerance

    def get(self, point):
        """The item at ``point`` (2,), or None."""
        if not len(self.xy):
            return None
        d = np.linalg.norm(self.xy - point, axis=1)
        k = int(np.argmin(d))
        return self.items[k] if d[k] <= self.tolerance else None

    def nodes_xy(self) -> np.ndarray:
        """Chart points (k, 2) of the node items."""
        mask = np.array([isinstance(v, (int, np.integer)) for v in self.items], dtype=bool)
        return self.xy[mask]


def _loops(pieces: list, table: _VertexTable, merge: float) -> tuple[list[list[int]], list[_NewPoint], dict]:
    """The outline loops of the tissue left (the tissue on their left) as vertex ids, the new
    points (band points on the new outline, and points where a lip line meets a border), and
    the new points matched to a node: one nearer than ``merge`` [m] to its neighbour on the loop
    that is a node is left out, the loop going straight on to that node (node matching: no
    tiny edge)."""
    points: list[_NewPoint] = []
    made: dict = {}
    matched: dict = {}
    loops = []
    for poly in pieces:
        for ring in [poly.exterior, *poly.interiors]:
            coords = np.asarray(ring.coords)[:-1]
            ids = []
            for xy in coords:
                hit = table.get(xy)
                if isinstance(hit, (int, np.integer)):
                    ids.append(int(hit))
                    continue
                key = tuple(xy)
                if key not in made:
                    points.append(_NewPoint(hit if isinstance(hit, BandPoint) else None, xy))
                    made[key] = -len(points)
                ids.append(made[key])
            keep = [k for k in range(len(ids)) if ids[k] != ids[k - 1]]  # two points matched one vertex
            loops.append(_merge_near([ids[k] for k in keep], coords[keep], merge, matched))
    return [loop for loop in loops if len(loop) >= 3], points, matched


def _merge_near(ids: list[int], coords: np.ndarray, merge: float, matched: dict) -> list[int]:
    """``ids`` without the new points (< 0) that lie within ``merge`` [m] of a neighbouring node
    (>= 0) on the loop; ``matched`` takes each such point's node."""
    n = len(ids)
    keep = []
    for k in range(n):
        v = ids[k]
        if v < 0:
            near = [j for j in ((k - 1) % n, (k + 1) % n) if ids[j] >= 0
                    and np.linalg.norm(coords[j] - coords[k]) < merge]
            if near:
                matched[v] = ids[min(near, key=lambda j: np.linalg.norm(coords[j] - coords[k]))]
                continue
        keep.append(v)
    return keep


def _sharp_corners(layout: _Layout, protected: set[int]) -> list[tuple[int, np.ndarray | None]]:
    """Corners of the tissue's new outline under ``REFINE_ANGLE_DEG`` (the fill cannot mend them):
    (vertex id, None) at a node of the region's own outline (the region takes its fan in), else
    (vertex id, the corner's triangle (3, 2) in the chart: it goes with the band)."""
    chart = layout.fill.points
    out = []
    for v, (row, before, after) in layout.turns.items():
        if v in protected:
            continue
        a, b = chart[after] - chart[row], chart[before] - chart[row]
        angle = np.degrees(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b)) % 360.0  # after -> before, CCW
        if angle >= REFINE_ANGLE_DEG:
            continue
        wedge = np.array([chart[before], chart[row], chart[after]])
        out.append((v, None if v >= 0 and layout.ids[before] >= 0 and layout.ids[after] >= 0 else wedge))
    return out


def _apply(editor: TopologyEditor, inc: Incision, region: Region, layout: _Layout, positions: NodePositions,
           tool: Tool | None, growth: int) -> PieceCut:
    """Write the fill into the model through ``editor``; the new nodes' positions go into
    ``positions``."""
    model = editor.model
    fill, ids = layout.fill, layout.ids
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    lift = PiecewiseLinearMap(layout.chart.to2d(model.points[corners]), model.points[corners],
                              positions[corners.reshape(-1)].reshape(-1, 3, 3))
    new_rows = [k for k, v in enumerate(ids) if v < 0] + list(range(len(ids), len(fill.points)))
    rest_new, current_new = lift(fill.points[new_rows])
    if tool is not None:
        current_new = pushed_out(current_new, tool)
    kept = {v for v in ids if v >= 0}
    gone = sorted((region.nodes() | region.deleted) - kept)
    editor.delete_nodes(gone)
    editor.delete_triangles(sorted(region.triangles))
    made = editor.add_nodes(rest_new, NodeClass.GREY) if len(new_rows) else np.zeros(0, np.int64)  # lips: _classify
    node_of = list(ids) + [0] * (len(fill.points) - len(ids))
    for row, node, x in zip(new_rows, made, current_new):
        node_of[row] = int(node)
        positions[int(node)] = x
    for tri in fill.triangles:
        editor.add_triangle([node_of[k] for k in tri], model.points)
    cut = _record(inc, layout, node_of, gone)
    cut.growth, cut.unrefined = growth, fill.unrefined
    on_slit = [node_of[k] for k in _inserted_on_slit(layout, inc.slit_nodes)]
    inc.slit_nodes.update(on_slit)
    cut.lips = sorted(set(cut.lips) | set(on_slit))
    _classify(editor, cut, inc.slit_nodes, {inc.start_node, inc.tip_node} - {-1})
    return cut


def _inserted_on_slit(layout: _Layout, slit_nodes: set[int]) -> list[int]:
    """Rows of the points the refinement inserted on the slit's edges (edges of the new outline
    with an end among the new points or both ends on the slit)."""
    fill, ids = layout.fill, layout.ids
    extra = fill.points[len(ids):]
    edges = [(row, after) for v, (row, _, after) in layout.turns.items()
             if v < 0 or ids[after] < 0 or (v in slit_nodes and ids[after] in slit_nodes)]
    if not len(extra) or not edges:
        return []
    seg = np.array(edges)
    a, b = fill.points[seg[:, 0]], fill.points[seg[:, 1]]
    ab = b - a
    t = np.clip(((extra[:, None] - a[None]) * ab[None]).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300),
                0.0, 1.0)
    dist = np.linalg.norm(a[None] + t[..., None] * ab[None] - extra[:, None], axis=2).min(axis=1)
    scale = max(float(np.ptp(fill.points, axis=0).max()), 1e-12)
    return [len(ids) + int(k) for k in np.flatnonzero(dist < 1e-9 * scale)]


def _record(inc: Incision, layout: _Layout, node_of: list, gone: list) -> PieceCut:
    """The PieceCut of a written fill, and the incision's new stations, tip and start."""
    cut = PieceCut(deleted=gone)
    made = {v: node_of[k] for k, v in enumerate(layout.ids) if v < 0}
    lips, on_slit = {}, []
    for v, node in made.items():
        band = layout.points[-1 - v].band
        if band is None:
            on_slit.append(node)
            cut.met_border = True
        else:
            lips[(band.station, band.side)] = node
    matched = _matched_lips(layout)
    lips.update({key: node for key, node in matched.items() if key not in lips})
    for k, u in enumerate(layout.stations):
        left, right = lips.get((k, 1), -1), lips.get((k, -1), -1)
        if left >= 0 or right >= 0:
            inc.add_station(u, left, right)
            cut.stations.append((u, left, right))
    if layout.resumed_at is not None:
        inc.resume_u = max(inc.resume_u, layout.resumed_at)
    cut.tip = lips.get((TIP, 0), -1)
    cut.start = lips.get((START, 0), -1)
    inc.tip_node = cut.tip
    if cut.start >= 0:
        inc.start_node = cut.start
    cut.lips = sorted(set(made.values()) | set(matched.values()))
    inc.slit_nodes.update(cut.lips)
    cut.inserted = [int(node_of[k]) for k in range(len(layout.ids), len(layout.fill.points))]
    cut.met_border |= cut.tip < 0
    return cut


def _classify(editor: TopologyEditor, cut: PieceCut, slit: set[int], ends: set[int]) -> None:
    """The slit's new nodes are lips (with those of earlier events, ``slit``: every node the
    incision put on its slit); springs along the slit are lip springs, those joining a lip to
    another node red, the others the fill made green. Every tissue node a new spring joins to
    the slit is classed from all its springs: yellow if one joins it to an end of the incision
    (``ends``: its start and tip now), else blue."""
    pairs = editor.model.spring_table.column("pairs")
    editor.set_node_class(set(cut.lips), NodeClass.LIP)
    lips = set(cut.lips) | set(slit)
    joined = set()
    for slot in editor.report.new_springs:
        a, b = (int(v) for v in pairs[slot])
        if a in lips and b in lips:
            editor.set_spring_class(slot, SpringClass.LIP)
        elif a in lips or b in lips:
            editor.set_spring_class(slot, SpringClass.RED)
            joined.add(b if a in lips else a)
        else:
            editor.set_spring_class(slot, SpringClass.GREEN)
    yellow = {v for v in joined if _partners(editor, v) & ends}
    editor.set_node_class(joined - yellow, NodeClass.BLUE)
    editor.set_node_class(yellow, NodeClass.YELLOW)


def _partners(editor: TopologyEditor, v: int) -> set[int]:
    """The nodes joined to node ``v`` by a live spring."""
    pairs = editor.model.spring_table.column("pairs")
    return {int(w) for slot in editor.index.node_springs[v] for w in pairs[slot] if int(w) != v}
