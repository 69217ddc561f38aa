"""Stage 3 in the rest shape: re-mesh the region round the swept band with the slit in it.

One event of an incision (``cut_piece``) takes the piece of rest curve the blade cut since the
last event and, all in a flat chart of the rest surface:

1. picks the region of triangles round the band and the tissue nodes the band sweeps
   (``region.Region``);
2. lays out the slit's band (``event_band``: ``slit_band.plan_band``'s lips at the new
   stations, its tip, its start, or its ends in openings, with the end of the slit cut before)
   and takes it out of the region's tissue (``layout.lay_out``: a polygon difference, GEOS
   through Shapely): the tissue left is exactly the region's triangles less the band, whatever
   earlier wounds or borders the band runs into, crosses or starts in;
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
from typing import NamedTuple

import numpy as np

from ...mesh.geometry import triangle_min_angles
from ...sim.collision import pushed_out
from ...sim.control import Tool
from ..chart import PiecewiseLinearMap, RegionChart, chart_min_angles
from ..classes import NodeClass, SpringClass
from ..curve.incision import Incision
from ..sweep.beside import Beside, strip_polygons
from ..sweep.event_band import add_old_tip, clear_of_old_tip, clearance, edge_clearance, event_band
from ..sweep.region import Region
from ..sweep.slit_band import CUT_BEFORE, EXTENSION, JUNCTION, START, TIP, BandPoint, SlitBand
from ..tolerances import (
    LIP_MATCH,
    MAX_GROWTH,
    MERGE,
    MIN_ANGLE_DEG,
    OLD_END_CLEARANCE,
    REGION_MARGIN,
)
from ..topology import NodePositions, TopologyEditor
from .fill import Fill
from .layout import Layout, Refusal, SlitDoesNotFit, corner_cut, edge_of, lay_out, matched_lips, sharp_corners
from .placement import start_positions

__all__ = ["PieceCut", "NewStation", "Refusal", "SlitDoesNotFit", "cut_piece"]


class NewStation(NamedTuple):
    """A station an event made: its arc length ``u`` [m] and its lip nodes (-1: no lip on that side)."""

    u: float
    left: int
    right: int


@dataclass
class PieceCut:
    """What one event's re-mesh did.

    Attributes:
        deleted: Nodes the event deleted (swept by the band, or left in it).
        lips: New nodes on the slit (lips, tip, start, and where a lip line meets a border).
        inserted: Nodes the refinement inserted.
        stations: Each new station (``NewStation``).
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


def cut_piece(editor: TopologyEditor, inc: Incision, u: np.ndarray, on_tissue: np.ndarray, near: np.ndarray,
              positions: NodePositions, *, tool: Tool | None, first: bool, beside: Beside | None = None) -> PieceCut:
    """Cut the piece of ``inc``'s rest curve sampled at arc lengths ``u`` (k,) [m] (from the last
    cut to the slit's new tip, the last sample), ``on_tissue`` (k,) bool: which samples lie in
    the tissue (the others over an opening, where the blade sweeps nothing). ``near``: live nodes
    within clearance + 2 spacings of the piece, at least; ``positions``: the current node
    positions; ``tool``: the tool now, whose cylinder new nodes are kept out of; ``first``: the
    incision's first event; ``beside``: the samples beside an opening, whose strip of tissue the
    blade cuts off (``beside.Beside``; None: none). Part of an edit begun on ``editor`` (see the
    module docstring).

    Raises:
        SlitDoesNotFit: The band leaves no tissue to fill, or its region cannot be filled.
    """
    model = editor.model
    provisional = inc.provisional_nodes(model.active, model.points)  # the old tip goes: the slit runs on
    protected = (inc.lip_node_set() | inc.slit_nodes) - provisional
    beside = Beside.none(len(u)) if beside is None else beside
    try:
        region, layout, growth = _lay_out_piece(model, inc, u, on_tissue, near, beside, first, protected, provisional)
    except SlitDoesNotFit:
        if not beside.mask.any():
            raise
        # the strips beside an opening do not fit: the slit alone (a later event may take them)
        region, layout, growth = _lay_out_piece(model, inc, u, on_tissue, near, Beside.none(len(u)), first,
                                                protected, provisional)
    return _apply(editor, inc, region, layout, positions, tool, growth)


def _lay_out_piece(model, inc: Incision, u: np.ndarray, on_tissue: np.ndarray, near: np.ndarray, beside: Beside,
                   first: bool, protected: set[int], provisional: set[int]) -> tuple[Region, Layout, int]:
    """Stages 1 and 3 of ``cut_piece`` before anything is written: the region, the band (and
    the strips ``beside`` an opening) taken out of it and the tissue left filled, with the times
    the region grew.

    Raises:
        SlitDoesNotFit: The band leaves no tissue to fill, or its region cannot be filled.
    """
    s = inc.spacing
    piece = inc.point_at(u)
    region = Region.around(model, piece, on_tissue | beside.mask, near, clearance(inc), REGION_MARGIN * s,
                           protected, provisional)
    band = event_band(model, inc, u, on_tissue, first, near)
    band.strips = strip_polygons(inc, u, beside, edge_clearance(inc))
    old_tip = add_old_tip(model, inc, region, band, provisional)
    if not region.triangles:
        raise SlitDoesNotFit(Refusal.NO_TISSUE)
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    chart = RegionChart.of_triangles(model.points[corners])
    if old_tip is not None:
        clear_of_old_tip(band, old_tip, inc, chart, OLD_END_CLEARANCE * s)
    _match_bend_lips(band, inc, model, LIP_MATCH * s)
    try:
        layout, growth = _fill(model, inc, region, band, chart, protected)
    except SlitDoesNotFit:  # node matching, then once more: a lip beside a node of the slit is that node
        if not _match_lips(band, model, (protected | provisional) & set(near.tolist()), MERGE * s):
            raise
        layout, growth = _fill(model, inc, region, band, chart, protected)
    return region, layout, growth


def _fill(model, inc: Incision, region: Region, band: SlitBand, chart: RegionChart,
          protected: set[int]) -> tuple[Layout, int]:
    """The region less the band, filled (``lay_out``), the region grown where the refinement
    would split its fixed outline or leaves a corner it cannot mend (up to ``MAX_GROWTH``
    times), and checked; with the times it grew.

    Raises:
        SlitDoesNotFit: The fill splits the region's outline, leaves a triangle under
            ``MIN_ANGLE_DEG`` or does not lay the whole slit, however far the region grows.
    """
    wedges: list = []
    for growth in range(MAX_GROWTH + 1):
        layout = lay_out(model, inc, region, band, chart, wedges)
        refused = ({edge_of(layout.ids, e) for e in layout.fill.split_edges} & layout.fixed) | layout.cut_across
        sharp = sharp_corners(layout, protected) if layout.fill.unrefined else []
        if not (refused or sharp) or growth == MAX_GROWTH:
            break
        region.grow(refused)
        for turn, wedge in sharp:
            if wedge is None:
                if region.sweep([turn.vertex]):  # its fan taken in, a corner on the tissue's border stays
                    wedges.append(corner_cut(layout, turn, inc.spacing))
            else:
                wedges.append(wedge)
    if refused:  # a split outline edge would leave a node on the edge of a triangle outside
        raise SlitDoesNotFit(Refusal.SPLITS_OUTLINE)
    if layout.fill.unrefined and _smallest_angle(layout.fill) < MIN_ANGLE_DEG:
        raise SlitDoesNotFit(Refusal.UNDER_ANGLE)
    _check_slit(layout, band)
    return layout, growth


def _smallest_angle(fill: Fill) -> float:
    """Smallest angle [deg] of the fill's triangles in its chart."""
    return float(chart_min_angles(fill.points, fill.triangles).min()) if len(fill.triangles) else 180.0


def _check_slit(layout: Layout, band: SlitBand) -> None:
    """The fill lays the whole slit: every lip and the tip the band asks for is a vertex of the
    tissue's new outline, one each, or a lip matched to a node of the outline next to it
    (``matched_lips``: a node of the slit round a sharp bend, an earlier wound's).

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
    for key in matched_lips(layout):
        laid[key] = laid.get(key, 0) + 1
    missing = sorted(k for k in wanted if laid.get(k, 0) != 1)
    if missing:
        raise SlitDoesNotFit(Refusal.SLIT_NOT_LAID, f"(station, side) {missing}")


def _match_bend_lips(band: SlitBand, inc: Incision, model, reach: float) -> int:
    """Node matching round a bend: a new lip of ``band`` within ``reach`` [m] of an earlier lip
    of its own side is that lip. On the inside of a sharp bend the lip lines of the legs before
    and after it meet, and two lips there a sliver apart would leave triangles that small
    (``LIP_MATCH``). Returns the lips matched."""
    return sum(_match_lips(band, model, set(lips), reach, side=side) for side, lips in ((1, inc.left), (-1, inc.right)))


def _match_lips(band: SlitBand, model, nodes: set[int], reach: float, side: int | None = None) -> int:
    """Node matching (the paper's Alg. 2): a new lip of ``band`` (of ``side``; None: either)
    within ``reach`` [m] of one of ``nodes`` (the slit's nodes near, e.g. round a sharp bend,
    where the lip lines of the legs before and after it meet) is that node, each node one lip at
    most. Returns the lips matched. Tried when a fill does not fit: a node a little off the lip
    line makes a less even fill."""
    live = np.array(sorted(v for v in nodes if v >= 0 and model.active[v]), dtype=np.int64)
    if not len(live):
        return 0
    matched = 0
    # a lip of one side may be that side's lip the band closes onto (the inside of the bend)
    used = {p.node for run in band.runs for p in run if p.node >= 0 and not (side and p.station == CUT_BEFORE
                                                                             and p.side == side)}
    for run in band.runs:
        for k, p in enumerate(run):
            if p.node >= 0 or p.station < 0 or side is not None and p.side != side:
                continue
            d = np.linalg.norm(model.points[live] - p.rest, axis=1)
            j = int(np.argmin(d))
            if d[j] <= reach and int(live[j]) not in used:
                used.add(int(live[j]))
                run[k] = BandPoint(model.points[live[j]].copy(), p.side, p.station, p.u, int(live[j]))
                matched += 1
    return matched


def _apply(editor: TopologyEditor, inc: Incision, region: Region, layout: Layout, positions: NodePositions,
           tool: Tool | None, growth: int) -> PieceCut:
    """Write the fill into the model through ``editor``; the new nodes' positions go into
    ``positions``."""
    model = editor.model
    fill, ids = layout.fill, layout.ids
    corners = np.concatenate([model.triangle_table.column("corners")[sorted(region.triangles)],
                              region.healed_triangles(layout.chart)])
    lift = PiecewiseLinearMap(layout.chart.to2d(model.points[corners]), model.points[corners],
                              positions[corners.reshape(-1)].reshape(-1, 3, 3))
    new_rows = [k for k, v in enumerate(ids) if v < 0] + list(range(len(ids), len(fill.points)))
    rest_new, current_new = lift(fill.points[new_rows])
    _check_rest_angles(model, layout, new_rows, rest_new)
    if tool is not None:
        current_new = pushed_out(current_new, tool)
    current_new = _unfolded(layout, new_rows, current_new, positions, tool, inc.spacing)
    kept = {v for v in ids if v >= 0}
    gone = sorted((region.nodes() | region.deleted) - kept)
    editor.delete_nodes(gone)
    editor.delete_triangles(sorted(region.triangles))
    made = editor.add_nodes(rest_new, NodeClass.GREY) if len(new_rows) else np.zeros(0, np.int64)  # lips: _classify
    node_of = list(ids) + [0] * (len(fill.points) - len(ids))
    for row, node, x in zip(new_rows, made, current_new):
        node_of[row] = int(node)
        positions[int(node)] = x
    editor.add_triangles(np.asarray(node_of, dtype=np.int64)[_fill_triangles(layout)],
                         model.points)
    cut = _record(inc, layout, node_of, gone)
    cut.growth, cut.unrefined = growth, fill.unrefined
    on_slit = [node_of[k] for k in _inserted_on_slit(layout, inc.slit_nodes)]
    inc.slit_nodes.update(on_slit)
    cut.lips = sorted(set(cut.lips) | set(on_slit))
    _classify(editor, cut, inc.slit_nodes, {inc.start_node, inc.tip_node} - {-1})
    return cut


def _check_rest_angles(model, layout: Layout, new_rows: list, rest_new: np.ndarray) -> None:
    """The fill's triangles at rest (its nodes' rest positions, its new points lifted onto the
    rest surface, ``rest_new`` (m, 3) [m]) keep ``MIN_ANGLE_DEG``: the chart is a projection,
    exact where the rest shape is flat; a region grown large on a tightly curved surface (a
    cylinder of 13 mm radius) made a 22 deg chart triangle 15 deg at rest.

    Raises:
        SlitDoesNotFit: One is under it (nothing is written: the next event tries again).
    """
    rest = _at_fill_points(layout, model.points, new_rows, rest_new)
    triangles = _fill_triangles(layout)
    if len(triangles) and triangle_min_angles(rest, triangles).min() < MIN_ANGLE_DEG:
        raise SlitDoesNotFit(Refusal.UNDER_ANGLE_AT_REST)


def _unfolded(layout: Layout, new_rows: list, current_new: np.ndarray, positions: NodePositions,
              tool: Tool | None, spacing: float) -> np.ndarray:
    """The new points' current positions (m, 3) [m], those of a triangle born folded over moved
    where the tissue round it carries them (``placement.start_positions``)."""
    x = _at_fill_points(layout, positions, new_rows, current_new)
    new = np.zeros(len(layout.fill.points), dtype=bool)
    new[new_rows] = True
    chart = np.asarray(layout.fill.points, dtype=np.float64)
    return start_positions(chart, _fill_triangles(layout), x, new, tool, spacing)[new_rows]


def _at_fill_points(layout: Layout, by_node, new_rows: list, at_new: np.ndarray) -> np.ndarray:
    """Positions (n, 3) [m] of the fill's n points: a node's from ``by_node`` (indexable by node
    arrays: rest or current positions), the new points' (rows ``new_rows``) ``at_new``."""
    ids = layout.ids
    out = np.zeros((len(layout.fill.points), 3))
    old = [k for k, v in enumerate(ids) if v >= 0]
    out[old] = by_node[np.asarray([ids[k] for k in old], dtype=np.int64)]
    out[new_rows] = at_new
    return out


def _fill_triangles(layout: Layout) -> np.ndarray:
    """The fill's triangles (t, 3), rows of its points."""
    return np.asarray(layout.fill.triangles, dtype=np.int64).reshape(-1, 3)


def _inserted_on_slit(layout: Layout, slit_nodes: set[int]) -> list[int]:
    """Rows of the points the refinement inserted on the slit's edges (edges of the new outline
    with an end among the new points or both ends on the slit)."""
    fill, ids = layout.fill, layout.ids
    extra = fill.points[len(ids):]
    edges = [(row, after) for v, row, _, after in layout.turns
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


def _record(inc: Incision, layout: Layout, node_of: list, gone: list) -> PieceCut:
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
    matched = matched_lips(layout)
    lips.update({key: node for key, node in matched.items() if key not in lips})
    for k, u in enumerate(layout.stations):
        left, right = lips.get((k, 1), -1), lips.get((k, -1), -1)
        if left >= 0 or right >= 0:
            inc.add_station(u, left, right)
            cut.stations.append(NewStation(u, left, right))
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
