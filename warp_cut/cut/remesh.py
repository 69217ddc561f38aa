"""Stage 3 in the rest shape: re-mesh the region round the swept band with the slit in it.

One event of an incision (``cut_piece``) takes the piece of rest curve the blade cut since the
last event and, all in the rest shape:

1. deletes what the band swept and picks the region of triangles round it (``region.Region``);
2. finds where the slit meets the region's outline (``region.outline_gaps``) and walks it
   (``band.walk_the_slit``): the lip nodes of the new stations, the tip, the start;
3. fills the region minus the slit in a flat chart of the rest surface with triangles of at
   least ``REFINE_ANGLE_DEG`` (``fill.fill_region``); a fill that had to split an edge the
   region shares with the tissue outside it grows the region across that edge and fills again;
4. writes the new nodes, their rest positions on the rest surface and their current positions
   in the deformed tissue (both through the region's triangles: nothing jumps; a node the tool's
   cylinder holds is put on its surface, as the tool would push it) and the new triangles
   through the ``TopologyEditor``, and gives the nodes and springs their classes.

It returns a ``PieceCut`` record, or raises ``SlitDoesNotFit`` (saying why) before it has
edited anything: the event is left for the next one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..sim.collision import pushed_out
from ..sim.control import Tool
from .band import Walk, walk_the_slit
from .chart import PiecewiseLinearMap, RegionChart
from .classes import NodeClass, SpringClass
from .fill import Fill, fill_region
from .incision import Incision
from .region import Region, outline_gaps
from .tolerances import CLEARANCE, JUNCTION, LAST_STATION, MAX_GROWTH, MIN_EDGE, REFINE_ANGLE_DEG, REGION_MARGIN
from .topology import NodePositions, TopologyEditor

__all__ = ["PieceCut", "SlitDoesNotFit", "cut_piece", "clearance"]


class SlitDoesNotFit(Exception):
    """The slit of an event could not be laid out in its region (nothing was edited)."""


@dataclass
class PieceCut:
    """What one event's re-mesh did.

    Attributes:
        deleted: Nodes the swept band deleted.
        lips: New lip nodes (with the tip and the start).
        inserted: Nodes the refinement inserted.
        stations: (u [m], left node, right node) of each new station (-1: no lip there).
        tip: The new tip node (-1: the slit ends in an opening).
        start: The start node made here (-1: none made).
        growth: How many times the region grew before the fill was accepted.
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


def clearance(inc: Incision) -> float:
    """How far from the curve [m] the swept band deletes nodes: the sweep radius, at least the
    lip offset plus ``CLEARANCE`` spacings."""
    return max(inc.sweep_radius, inc.lip_offset + CLEARANCE * inc.spacing)


@dataclass
class _Layout:
    """A region's fill: the vertices (node ids >= 0, new points < 0), their chart points, the
    fill, and which outline edges it may not split."""

    ids: list
    fill: Fill
    walk: Walk
    chart: RegionChart
    fixed: set


def cut_piece(editor: TopologyEditor, inc: Incision, piece: np.ndarray, upto: float, near: np.ndarray,
              positions: NodePositions, *, tool: Tool | None, first: bool) -> PieceCut | None:
    """Cut the piece ``piece`` (k, 3) [m] of ``inc``'s rest curve (from the last cut to the arc
    length ``upto`` [m], where the slit's new tip goes) into the model (see the module
    docstring). ``near``: live nodes within clearance + 2 spacings of it, at least;
    ``positions``: the current node positions; ``tool``: the tool now, whose cylinder new nodes
    are kept out of; ``first``: the incision's first event (its start node may be made). Part
    of an edit begun on ``editor``."""
    model = editor.model
    s = inc.spacing
    provisional = inc.provisional_nodes(model.active, model.points)  # the old tip goes: the slit runs on
    protected = inc.lip_node_set() - provisional
    region = Region.around(model, piece, near, clearance(inc), inc.lip_offset + JUNCTION * s,
                           REGION_MARGIN * s, protected, provisional)
    stations = inc.next_stations(upto - LAST_STATION * s)
    start = inc.start_node if inc.start_node >= 0 and model.active[inc.start_node] else None
    start_possible = first or (start is not None and start in region.nodes())
    growth = 0
    while True:
        layout = _lay_out(model, inc, region, stations, start_possible, start, upto)
        refused = {_edge_of(layout.ids, e) for e in layout.fill.split_edges} & layout.fixed
        if not refused or growth == MAX_GROWTH:
            break
        region.grow(refused)
        growth += 1
    return _apply(editor, inc, region, layout, positions, tool, growth)


def _edge_of(ids: list, edge: tuple[int, int]) -> tuple[int, int]:
    """The sorted node pair of a fill edge (indices into ``ids``)."""
    a, b = ids[edge[0]], ids[edge[1]]
    return (min(a, b), max(a, b))


def _lay_out(model, inc: Incision, region: Region, stations: list[float], start_possible: bool,
             start: int | None, upto: float) -> _Layout:
    """The region's outline and slit in a chart, filled.

    Raises:
        SlitDoesNotFit: The gaps do not make a walk round the slit, the walk and the outline do
            not close, or the fill found no area.
    """
    outline = region.outline()
    kept, gaps = outline_gaps(outline, region.deleted)
    walk = walk_the_slit(inc, gaps, model.points, stations=stations, margin=LAST_STATION * inc.spacing,
                         start_possible=start_possible, start=start, length=upto)
    if walk is None:
        raise SlitDoesNotFit(f"the slit does not meet the outline's {len(gaps)} gaps in turn")
    if not _balanced(kept + walk.edges):
        raise SlitDoesNotFit("the slit and the outline do not make closed loops")
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    chart = RegionChart.of_triangles(model.points[corners])
    border = {v for e in kept for v in e} | {v for e in walk.edges for v in e if v >= 0}
    inside = sorted(region.nodes() - region.deleted - border)
    ids = sorted(border) + inside + [-1 - k for k in range(len(walk.points))]
    where = {v: k for k, v in enumerate(ids)}
    rest = np.concatenate([model.points[[v for v in ids if v >= 0]],
                           np.array([p.rest for p in walk.points]).reshape(-1, 3)])
    edges = [(where[a], where[b]) for a, b in kept + walk.edges]
    try:
        fill = fill_region(chart.to2d(rest), edges, min_angle_deg=REFINE_ANGLE_DEG, min_edge=MIN_EDGE * inc.spacing)
    except InputError as err:
        raise SlitDoesNotFit(str(err)) from err
    fixed = {(min(a, b), max(a, b)) for a, b in kept if not region.on_mesh_border(a, b)}
    return _Layout(ids, fill, walk, chart, fixed)


def _balanced(edges: list[tuple[int, int]]) -> bool:
    """True if every node of the directed edges has as many edges in as out (closed loops)."""
    balance: dict[int, int] = {}
    for a, b in edges:
        balance[a] = balance.get(a, 0) + 1
        balance[b] = balance.get(b, 0) - 1
    return bool(edges) and not any(balance.values())


def _apply(editor: TopologyEditor, inc: Incision, region: Region, layout: _Layout, positions: NodePositions,
           tool: Tool | None, growth: int) -> PieceCut:
    """Write the fill into the model through ``editor``; the new nodes' positions go into
    ``positions``."""
    model = editor.model
    fill, walk, ids = layout.fill, layout.walk, layout.ids
    corners = model.triangle_table.column("corners")[sorted(region.triangles)]
    lift = PiecewiseLinearMap(layout.chart.to2d(model.points[corners]), model.points[corners],
                              positions[corners.reshape(-1)].reshape(-1, 3, 3))
    new_rows = [k for k, v in enumerate(ids) if v < 0] + list(range(len(ids), len(fill.points)))
    rest_new, current_new = lift(fill.points[new_rows])
    if tool is not None:
        current_new = pushed_out(current_new, tool)
    editor.delete_nodes(sorted(region.deleted))
    editor.delete_triangles(sorted(region.triangles))
    made = editor.add_nodes(rest_new) if len(new_rows) else np.zeros(0, np.int64)
    node_of = list(ids) + [0] * (len(fill.points) - len(ids))
    for row, node, x in zip(new_rows, made, current_new):
        node_of[row] = int(node)
        positions[int(node)] = x
    for tri in fill.triangles:
        editor.add_triangle([node_of[k] for k in tri], model.points)
    cut = _record(inc, walk, ids, node_of, fill, region)
    cut.growth, cut.unrefined = growth, fill.unrefined
    on_slit = [node_of[k] for k in _inserted_on_slit(fill, ids, walk, inc.spacing)]
    inc.slit_nodes.update(on_slit)
    _classify(editor, cut, on_slit)
    return cut


def _record(inc: Incision, walk: Walk, ids: list, node_of: list, fill: Fill, region: Region) -> PieceCut:
    """The PieceCut of a written fill, and the incision's new stations, tip and start."""
    cut = PieceCut(deleted=sorted(region.deleted))
    point_node = {k: node_of[ids.index(-1 - k)] for k in range(len(walk.points))}
    lips = {(p.station, p.side): point_node[k] for k, p in enumerate(walk.points)}
    for k, u in enumerate(walk.stations):
        left, right = lips.get((k, 1), -1), lips.get((k, -1), -1)
        if left >= 0 or right >= 0:
            inc.add_station(u, left, right)
            cut.stations.append((u, left, right))
    cut.tip = lips.get((-2, 0), -1)
    cut.start = lips.get((-1, 0), -1)
    inc.tip_node = cut.tip
    if cut.start >= 0:
        inc.start_node = cut.start
    cut.lips = sorted(point_node.values())
    inc.slit_nodes.update(cut.lips)
    cut.inserted = [int(node_of[k]) for k in range(len(ids), len(fill.points))]
    cut.met_border = cut.tip < 0
    return cut


def _classify(editor: TopologyEditor, cut: PieceCut, on_slit: list[int]) -> None:
    """Lip, tip and start nodes are lips, and so are ``on_slit`` (points the refinement put on
    the slit); the nodes joined to a lip are blue (yellow where joined to the tip or start);
    springs along the slit are lip springs, those joining a lip to another node red, the others
    the fill made green."""
    pairs = editor.model.spring_table.column("pairs")
    lips = set(cut.lips) | set(on_slit)
    editor.set_node_class(lips, NodeClass.LIP)
    ends = {cut.tip, cut.start} - {-1}
    yellow, blue = set(), set()
    for slot in editor.report.new_springs:
        a, b = (int(v) for v in pairs[slot])
        if a in lips and b in lips:
            editor.set_spring_class(slot, SpringClass.LIP)
        elif a in lips or b in lips:
            editor.set_spring_class(slot, SpringClass.RED)
            other, lip = (b, a) if a in lips else (a, b)
            (yellow if lip in ends else blue).add(other)
        else:
            editor.set_spring_class(slot, SpringClass.GREEN)
    editor.set_node_class(blue - lips, NodeClass.BLUE)
    editor.set_node_class(yellow - lips, NodeClass.YELLOW)


def _inserted_on_slit(fill: Fill, ids: list, walk: Walk, spacing: float) -> list[int]:
    """Rows of the points the refinement inserted on the slit's edges (it split a lip edge)."""
    extra = fill.points[len(ids):]
    if not len(extra) or not walk.edges:
        return []
    row = {v: k for k, v in enumerate(ids)}
    seg = np.array([(row[a], row[b]) for a, b in walk.edges])
    a, b = fill.points[seg[:, 0]], fill.points[seg[:, 1]]
    ab = b - a
    t = np.clip(((extra[:, None] - a[None]) * ab[None]).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300),
                0.0, 1.0)
    dist = np.linalg.norm(a[None] + t[..., None] * ab[None] - extra[:, None], axis=2).min(axis=1)
    return [len(ids) + int(k) for k in np.flatnonzero(dist < 1e-9 * spacing)]
